#include "pslam/core/Progress.h"

#include <cstdio>

#include <unistd.h>

namespace pslam {

Progress::Progress(std::string label, std::size_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), tty_(::isatty(STDERR_FILENO) != 0) {
  start_ = last_ = std::chrono::steady_clock::now();
}

Progress::~Progress() {
  if (enabled_ && !finished_ && tty_) std::fputc('\n', stderr);
}

void Progress::update(std::size_t done, const std::string& detail) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const double sinceLast = std::chrono::duration<double>(now - last_).count();
  const bool last = total_ > 0 && done >= total_;
  if (!last && sinceLast < (tty_ ? 0.1 : 5.0)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0.0;
  if (total_ > 0)
    std::fprintf(stderr, "%s%s: %zu/%zu (%.0f%%) %.1f/s %s%s", tty_ ? "\r" : "", label_.c_str(), done, total_,
                 100.0 * done / total_, rate, detail.c_str(), tty_ ? "\033[K" : "\n");
  else
    std::fprintf(stderr, "%s%s: %zu %.1f/s %s%s", tty_ ? "\r" : "", label_.c_str(), done, rate, detail.c_str(),
                 tty_ ? "\033[K" : "\n");
  std::fflush(stderr);
}

void Progress::finish(const std::string& summary) {
  if (!enabled_ || finished_) return;
  finished_ = true;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(stderr, "%s%s: done in %.1f s %s%s\n", tty_ ? "\r" : "", label_.c_str(), elapsed,
               summary.c_str(), tty_ ? "\033[K" : "");
  std::fflush(stderr);
}

}  // namespace pslam
