#include "MappingScheduler.h"

#include <algorithm>

#include "pslam/core/StageTimer.h"

namespace pslam::system {

MappingScheduler::MappingScheduler(SlamParts& parts, RunRecord& record, bool threaded)
    : parts_(parts), record_(record), threaded_(threaded) {
  if (parts_.loopCloser) {
    parts_.loopCloser->setKeyFramesMoved(
        [this](const loopclosing::LoopReport& lr, const std::map<map::KeyFrameId, Eigen::Isometry3d>& before) {
          onLoopKeyFramesMoved(lr, before);
        });
    // Threaded: the global BA of a closed loop runs on a thread of its own; the mapping thread writes it back.
    if (threaded_) parts_.loopCloser->setAsynchronousGlobalBa([this] { onGlobalBaReady(); });
  }
  if (!threaded_) return;
  // Local mapping holds the map lock except while it searches keyframe pairs for triangulation and solves local BA:
  // those run on copies, with the lock released so tracking goes on. A reset meanwhile (a new map generation) ends
  // that keyframe's mapping.
  parts_.mapper->setOutsideMapLock(
      [this](const std::function<void()>& computation) { return runOutsideMapLock(computation); });
  parts_.mapper->setNewPointsReady([this](map::KeyFrameId) {
    {
      std::lock_guard<std::mutex> lk(queueMutex_);
      pointsReadySeq_ = mappingSeq_;
    }
    queueCv_.notify_all();
  });
  worker_ = std::thread([this] { mappingLoop(); });
}

MappingScheduler::~MappingScheduler() {
  if (worker_.joinable()) {
    {
      std::lock_guard<std::mutex> lk(queueMutex_);
      stop_ = true;
    }
    queueCv_.notify_all();
    worker_.join();
  }
  // Global BAs a later loop stopped may still be ending their iteration; their callback takes queueMutex_, which is
  // destroyed before the loop closer.
  if (parts_.loopCloser) parts_.loopCloser->reset();
}

bool MappingScheduler::runOutsideMapLock(const std::function<void()>& computation) {
  const int before = record_.generation();
  struct Relock {
    std::unique_lock<std::mutex>& lock;
    ~Relock() { lock.lock(); }
  };
  mappingLock_->unlock();
  {
    Relock relock{*mappingLock_};
    computation();
  }
  return record_.generation() == before;
}

void MappingScheduler::onGlobalBaReady() {
  {
    std::lock_guard<std::mutex> lk(queueMutex_);
    globalBa_ = GlobalBaState::Ready;
    ++globalBaSignals_;
  }
  queueCv_.notify_all();
}

void MappingScheduler::beforeTracking() {
  if (!threaded_) return;
  StageTimings& timings = record_.trackingTimings();
  std::unique_lock<std::mutex> lk(queueMutex_);
  if (parts_.params.system.threadedTracking == "afterNewPoints") {
    // The frame is tracked once the last keyframe's new points are in the map (its triangulation and fusion done):
    // this frame's extraction overlaps with them, tracking with that keyframe's local BA and culling; a keyframe may
    // be made whenever none waits for the mapping thread.
    {
      ScopedStage wait(timings, "wait_for_mapping_queue");
      queueCv_.wait(lk, [&] { return pointsReadySeq_ >= queuedSeq_; });
    }
    parts_.tracker->setLocalMappingIdle(queue_.empty());
  } else {
    // live (ORB-SLAM's): tracking goes on while a keyframe is mapped and makes a keyframe only when the mapping
    // thread is idle (AcceptKeyFrames) or maxFrames have passed; a keyframe made meanwhile waits until the mapping
    // thread takes it, so tracking is never more than one keyframe ahead.
    {
      ScopedStage wait(timings, "wait_for_mapping_queue");
      queueCv_.wait(lk, [&] { return queue_.empty(); });
    }
    parts_.tracker->setLocalMappingIdle(!busy_);
  }
}

void MappingScheduler::mapKeyFrames(const std::vector<map::KeyFrameId>& keyFrames, bool measuredByTracking) {
  if (!mappingEnabled_ || keyFrames.empty()) return;
  if (!threaded_) {
    mapNow(keyFrames, measuredByTracking);
    return;
  }
  const int generation = record_.generation();
  {
    std::lock_guard<std::mutex> lk(queueMutex_);
    for (map::KeyFrameId kf : keyFrames)
      queue_.emplace_back(generation, QueuedKeyFrame{kf, measuredByTracking, ++queuedSeq_});
  }
  queueCv_.notify_all();
}

void MappingScheduler::afterTracking(Wait wait) {
  // Both waits are for the next frame's tracking: taken here, or after the next frame's extraction.
  if (parts_.params.system.waitAfterNextExtraction)
    pendingWait_ = wait;
  else
    waitFor(wait);
}

void MappingScheduler::waitFor(Wait what) {
  if (what == Wait::WeakKeyFrame) {
    ScopedStage wait(record_.trackingTimings(), "wait_for_weak_keyframe");
    std::unique_lock<std::mutex> lk(queueMutex_);
    queueCv_.wait(lk, [&] { return pointsReadySeq_ >= queuedSeq_; });
  } else if (what == Wait::Urgent) {
    ScopedStage wait(record_.trackingTimings(), "wait_for_mapping_urgent");
    waitForMapping(true);
  }
}

void MappingScheduler::takePendingWait() {
  waitFor(pendingWait_);
  pendingWait_ = Wait::None;
}

void MappingScheduler::waitForMapping(bool localMappingOnly) {
  if (!threaded_) return;
  std::unique_lock<std::mutex> lk(queueMutex_);
  queueCv_.wait(lk, [&] { return queue_.empty() && !busy_ && (localMappingOnly || globalBa_ == GlobalBaState::None); });
}

void MappingScheduler::newGeneration() {
  record_.newGeneration();
  if (parts_.loopCloser) {
    parts_.loopCloser->reset();  // waits for a running global BA and drops it
    std::lock_guard<std::mutex> lk(queueMutex_);
    globalBa_ = GlobalBaState::None;
  }
  queueCv_.notify_all();
}

void MappingScheduler::mappingLoop() {
  for (;;) {
    std::pair<int, QueuedKeyFrame> item;
    {
      std::unique_lock<std::mutex> lk(queueMutex_);
      queueCv_.wait(lk, [&] {
        return globalBa_ == GlobalBaState::Ready || !queue_.empty() || (stop_ && globalBa_ == GlobalBaState::None);
      });
      if (globalBa_ == GlobalBaState::Ready) {
        // A loop's global BA finished: written back between two keyframes, with the map lock held.
        const std::uint64_t signalsSeen = globalBaSignals_;
        busy_ = true;
        lk.unlock();
        bool stale = false;
        {
          std::lock_guard<std::mutex> mk(mapMutex_);
          // Unless the Ready came from a BA that a later loop stopped (LoopCloser::abortGlobalBundleAdjustment, a race
          // the stop can lose) while the later loop's BA still runs: never wait on the solver here.
          stale = parts_.loopCloser && parts_.loopCloser->globalBaPending() && !parts_.loopCloser->globalBaFinished();
          if (!stale) applyGlobalBa();
        }
        lk.lock();
        busy_ = false;
        if (!stale)
          globalBa_ = GlobalBaState::None;  // new BAs start on this thread only: none signalled meanwhile
        else if (globalBaSignals_ == signalsSeen)
          globalBa_ = GlobalBaState::Running;  // else the running BA signalled meanwhile: Ready stays
        lk.unlock();
        queueCv_.notify_all();
        continue;
      }
      if (queue_.empty()) return;  // stop requested and nothing left
      item = queue_.front();
      queue_.pop_front();
      busy_ = true;
      mappingSeq_ = item.second.seq;
    }
    queueCv_.notify_all();  // tracking may wait for the queue to shrink
    {
      std::unique_lock<std::mutex> mk(mapMutex_);
      mappingLock_ = &mk;  // released by the mapper around its computations on copies (setOutsideMapLock)
      // Keyframe ids restart after a reset: a queued id of an older map generation is stale.
      if (item.first == record_.generation() && mappingEnabled_)
        mapNow({item.second.keyFrame}, item.second.measuredByTracking);
      mappingLock_ = nullptr;
    }
    {
      std::lock_guard<std::mutex> lk(queueMutex_);
      busy_ = false;
      pointsReadySeq_ = std::max(pointsReadySeq_, item.second.seq);  // skipped, stopped early or done
    }
    queueCv_.notify_all();
  }
}

}  // namespace pslam::system
