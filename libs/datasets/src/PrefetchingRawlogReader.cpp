#include "pslam/datasets/PrefetchingRawlogReader.h"

#include <utility>

#include "pslam/core/Error.h"

namespace pslam::datasets {

PrefetchingRawlogReader::PrefetchingRawlogReader(std::filesystem::path rawlogPath, std::size_t capacity,
                                                 RawlogChannels channels, StampOrder order)
    : reader_(std::move(rawlogPath), channels, order), capacity_(capacity) {
  if (capacity_ == 0) throw Error(reader_.path().string() + ": a prefetching reader needs a capacity of at least 1");
  thread_ = std::thread([this] { readLoop(); });
}

PrefetchingRawlogReader::~PrefetchingRawlogReader() { stop(); }

void PrefetchingRawlogReader::readLoop() {
  for (;;) {
    Frame frame;
    bool more = false;
    std::exception_ptr error;
    try {
      more = reader_.next(frame);
    } catch (...) {
      error = std::current_exception();
    }
    std::unique_lock<std::mutex> lock(mutex_);
    if (error || !more) {
      error_ = error;
      finished_ = true;
      changed_.notify_all();
      return;
    }
    changed_.wait(lock, [&] { return stopping_ || ready_.size() < capacity_; });
    if (stopping_) {
      finished_ = true;
      changed_.notify_all();
      return;
    }
    ready_.push_back(std::move(frame));
    changed_.notify_all();
  }
}

bool PrefetchingRawlogReader::next(Frame& frame) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return !ready_.empty() || finished_; });
  if (!ready_.empty()) {
    frame = std::move(ready_.front());
    ready_.pop_front();
    changed_.notify_all();
    return true;
  }
  if (error_ && !stopping_) std::rethrow_exception(error_);  // after stop() the frames read ahead do not count
  return false;
}

void PrefetchingRawlogReader::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    ready_.clear();
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

}  // namespace pslam::datasets
