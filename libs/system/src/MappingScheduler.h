#pragma once
// Where and when keyframes are mapped (doc/architecture.md, "Threading"). Sequential mode: in the tracking thread,
// before track() returns. Threaded mode: a queue and a mapping thread; tracking and mapping share the map under
// one lock, which local mapping lends back around its computations on copies (the triangulation search, the BA
// solve); a loop's global BA runs on a thread of its own and is written back by the mapping thread between two
// keyframes. Each keyframe's mapping (local mapping, the modules' new landmarks, loop closing) and its log entry:
// KeyFrameMapping.cpp.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include <Eigen/Geometry>

#include "SlamParts.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/system/RunRecord.h"

namespace pslam::system {

class MappingScheduler {
 public:
  /// Threaded: wires the mapper's lock lending and the loop closer's asynchronous global BA, and starts the mapping
  /// thread. Both modes: loop corrections move the frames' books and the tracker's last frame.
  MappingScheduler(SlamParts& parts, RunRecord& record, bool threaded);
  ~MappingScheduler();
  MappingScheduler(const MappingScheduler&) = delete;
  MappingScheduler& operator=(const MappingScheduler&) = delete;

  bool threaded() const { return threaded_; }
  /// The map lock: held by tracking for a frame, by the mapping thread for a keyframe (threaded mode), and by
  /// every reader of the map.
  std::mutex& mapMutex() const { return mapMutex_; }
  void setMappingEnabled(bool enabled) { mappingEnabled_ = enabled; }

  /// Threaded, before a frame is tracked ([System] threadedTracking): waits for the queue as the mode says and
  /// tells the tracker whether local mapping is idle.
  void beforeTracking();
  /// The keyframes a frame made: mapped now (sequential) or queued (threaded).
  void mapKeyFrames(const std::vector<map::KeyFrameId>& keyFrames, bool measuredByTracking);
  /// ORB-SLAM's InterruptBA: the running local BA stops after its iteration (a keyframe waits for mapping).
  void interruptBundleAdjustment() { parts_.mapper->interruptBundleAdjustment(); }

  /// The waits tracking takes for the mapping thread after a frame: a weak keyframe's new points in the map, or
  /// mapping idle for an urgent keyframe.
  enum class Wait { None, WeakKeyFrame, Urgent };
  /// Takes `wait` now, or keeps it for after the next frame's extraction ([System] waitAfterNextExtraction).
  void afterTracking(Wait wait);
  /// Whether the last frame left a wait; takes it (timed into the tracking stages).
  bool hasPendingWait() const { return pendingWait_ != Wait::None; }
  void takePendingWait();
  /// Threaded: waits until every queued keyframe is mapped and, unless `localMappingOnly`, a loop's global BA is
  /// written back. No-op when sequential.
  void waitForMapping(bool localMappingOnly = false);
  /// A new map generation (a reset, a loaded map): the books forget the poses of the old map, loop closing its
  /// keyframes and a running global BA. Called with the map lock held.
  void newGeneration();

 private:
  /// Runs local mapping, the modules and loop closing on `kfs` (caller holds the map lock in threaded mode) and
  /// books each keyframe (KeyFrameMapping.cpp).
  void mapNow(const std::vector<map::KeyFrameId>& kfs, bool measuredByTracking);
  /// Loop closing moved keyframes (map lock held): the frames' books follow their reference keyframe's change of
  /// scale, and the tracker's last frame follows its reference keyframe.
  void onLoopKeyFramesMoved(const loopclosing::LoopReport& lr,
                            const std::map<map::KeyFrameId, Eigen::Isometry3d>& posesBefore);
  /// Threaded, on the mapping thread with the map lock held, between keyframes: writes a finished global BA back.
  void applyGlobalBa();
  /// Threaded, on the mapping thread (which holds the map lock): runs `computation`, which reads only copies of map
  /// data, with the lock released. False when tracking reset the map meanwhile (a new generation).
  bool runOutsideMapLock(const std::function<void()>& computation);
  /// Threaded: called on the global BA's thread when its result is ready; wakes the mapping thread.
  void onGlobalBaReady();
  void mappingLoop();
  void waitFor(Wait what);

  SlamParts& parts_;
  RunRecord& record_;
  const bool threaded_;
  bool mappingEnabled_ = true;
  mutable std::mutex mapMutex_;
  std::mutex queueMutex_;
  std::condition_variable queueCv_;
  struct QueuedKeyFrame {
    map::KeyFrameId keyFrame = map::kNoKeyFrame;
    bool measuredByTracking = false;
    std::uint64_t seq = 0;  ///< 1, 2, ... in the order tracking queued them
  };
  std::uint64_t queuedSeq_ = 0;       ///< seq of the last keyframe queued
  std::uint64_t mappingSeq_ = 0;      ///< seq of the keyframe being mapped
  std::uint64_t pointsReadySeq_ = 0;  ///< keyframes up to this seq have their new points in the map
  std::deque<std::pair<int, QueuedKeyFrame>> queue_;  ///< (generation, keyframe)
  std::unique_lock<std::mutex>* mappingLock_ = nullptr;  ///< the mapping thread's hold of mapMutex_
  bool busy_ = false;
  Wait pendingWait_ = Wait::None;  ///< the wait the last frame left for this one (tracking thread only)
  /// Threaded: a loop's global BA on its own thread (LoopCloser::setAsynchronousGlobalBa), guarded by queueMutex_.
  enum class GlobalBaState { None, Running, Ready };
  GlobalBaState globalBa_ = GlobalBaState::None;
  std::uint64_t globalBaSignals_ = 0;  ///< ready callbacks so far (queueMutex_)
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace pslam::system
