#pragma once
// Progress on the terminal for long runs: one line rewritten in place on a TTY, a line every few seconds
// otherwise (logs, CI). Writes to stderr so stdout stays machine-readable.
#include <chrono>
#include <cstddef>
#include <string>

namespace pslam {

class Progress {
 public:
  /// total = 0 means unknown.
  Progress(std::string label, std::size_t total, bool enabled = true);
  ~Progress();
  void update(std::size_t done, const std::string& detail = "");
  void finish(const std::string& summary = "");

 private:
  std::string label_;
  std::size_t total_;
  bool enabled_;
  bool tty_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace pslam
