#pragma once
// A rawlog read ahead of its consumer: a thread of its own reads and decodes the next frames (the images are
// PNG files: about a fifth of a KITTI run's CPU) while the caller works on the current one. Frames come out in
// the order and with the content RawlogReader::next gives; nothing the consumer computes depends on when they
// were read, so a deterministic run stays deterministic.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>

#include "pslam/datasets/Rawlog.h"

namespace pslam::datasets {

class PrefetchingRawlogReader {
 public:
  /// Opens the rawlog (errors as RawlogReader's constructor) and starts reading up to `capacity` (>= 1) frames
  /// ahead, decoding `channels` besides CAMERA.
  explicit PrefetchingRawlogReader(std::filesystem::path rawlogPath, std::size_t capacity = 3,
                                   RawlogChannels channels = {}, StampOrder order = StampOrder::strict);
  /// Stops the reading thread (stop()).
  ~PrefetchingRawlogReader();
  /// RawlogReader::warnings() (StampOrder::sort: what it reordered; known when the reader is made).
  const std::vector<std::string>& warnings() const { return reader_.warnings(); }
  PrefetchingRawlogReader(const PrefetchingRawlogReader&) = delete;
  PrefetchingRawlogReader& operator=(const PrefetchingRawlogReader&) = delete;

  /// The next frame; false at the end (or after stop()). A read error (RawlogReader::next's pslam::Error) is
  /// thrown by the call that would have returned the frame it concerns, after every frame before it.
  bool next(Frame& frame);
  /// Ends the reading thread and waits for it (frames read ahead are dropped). Call it before anything else
  /// that deserializes with MRPT in this process (e.g. saving a map), so the two never run at once.
  void stop();
  const std::filesystem::path& path() const { return reader_.path(); }

 private:
  void readLoop();

  RawlogReader reader_;
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Frame> ready_;
  bool finished_ = false;  ///< the reading thread ended: end of the rawlog, an error or stop()
  bool stopping_ = false;
  std::exception_ptr error_;
  std::thread thread_;
};

}  // namespace pslam::datasets
