#pragma once
// Project-wide error type: every failure that reaches a user carries a message naming the file, key or
// frame at fault. CLI apps catch it in main(), print one line and exit non-zero.
#include <stdexcept>
#include <string>

namespace pslam {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// Throws pslam::Error("<context>: <message>") when `condition` is false.
void require(bool condition, const std::string& context, const std::string& message);

}  // namespace pslam
