#pragma once
// Project-wide error type: every failure that reaches a user carries a message naming the file, key or
// frame at fault. CLI apps catch it in main(), print one line and exit non-zero.
#include <exception>
#include <stdexcept>
#include <string>

namespace pslam {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// Throws pslam::Error("<context>: <message>") when `condition` is false.
void require(bool condition, const std::string& context, const std::string& message);

/// The message of an exception as one line. MRPT's multi-line reports ("==== MRPT exception ====", then
/// "Message: ...", its location and a call stack) are reduced to their (first) message; other messages to
/// their first non-empty line.
std::string oneLineMessage(const std::exception& e);
std::string oneLineMessage(const std::string& what);

}  // namespace pslam
