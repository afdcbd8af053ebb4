#include "pslam/system/SlamSystem.h"

#include <chrono>
#include <cmath>

#include "pslam/core/Error.h"

namespace pslam::system {

SlamSystem::SlamSystem(const SlamParams& params, const geometry::PinholeCamera& camera, std::uint32_t seed,
                       bool threaded)
    : params_(params),
      camera_(camera),
      extractor_(params.orb),
      initExtractor_([&] {
        features::OrbParams p = params.orb;
        p.nFeatures = static_cast<int>(std::lround(params.initializer.featureFactor * p.nFeatures));
        return p;
      }()),
      threaded_(threaded) {
  params_.check();
  params_.mapping.ba = params_.bundleAdjustment;
  params_.mapping.pointModel = params_.pointModel;
  tracker_ = std::make_unique<tracking::Tracker>(
      map_, camera_, params_.tracking, params_.initializer, params_.bundleAdjustment,
      std::make_unique<tracking::FullPoseSolver>(params_.poseOptimization), seed);
  mapper_ = makeKeyFrameMapper("mapping", map_, params_.mapping);
  mapperName_ = mapper_->name();
  if (threaded_) worker_ = std::thread([this] { mappingLoop(); });
}

SlamSystem::~SlamSystem() {
  if (worker_.joinable()) {
    {
      std::lock_guard<std::mutex> lk(queueMutex_);
      stop_ = true;
    }
    queueCv_.notify_all();
    worker_.join();
  }
}

void SlamSystem::mapKeyFrames(const std::vector<map::KeyFrameId>& kfs, StageTimings& timings) {
  for (map::KeyFrameId kf : kfs) {
    if (!map_.hasKeyFrame(kf)) continue;  // erased meanwhile
    const MappingStepReport r = mapper_->processKeyFrame(kf, {});
    mappingLog_.push_back({{"generation", generation_}, {"keyframe", kf}, {"new_points", r.newPoints},
                           {"culled_points", r.culledPoints}, {"culled_keyframes", r.culledKeyFrames}, {"ba_observations_erased", r.baObservationsErased}, {"fused", r.fused},
                           {"map_points", map_.numMapPoints()}, {"keyframes", map_.numKeyFrames()}});
    timings.add("triangulation", r.triangulationMs);
    timings.add("local_ba", r.localBaMs);
    timings.add("fusion", r.fusionMs);
    ++keyFramesMapped_;
  }
}

void SlamSystem::mappingLoop() {
  for (;;) {
    std::pair<int, map::KeyFrameId> item;
    {
      std::unique_lock<std::mutex> lk(queueMutex_);
      queueCv_.wait(lk, [&] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stop requested and nothing left
      item = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    {
      std::lock_guard<std::mutex> mk(mapMutex_);
      // Keyframe ids restart after a reset: a queued id of an older map generation is stale.
      if (item.first == generation_) mapKeyFrames({item.second}, mappingTimings_);
    }
    {
      std::lock_guard<std::mutex> lk(queueMutex_);
      busy_ = false;
    }
    queueCv_.notify_all();
  }
}

tracking::Tracker::Result SlamSystem::processFrame(const datasets::Frame& input) {
  const std::string context = "frame " + std::to_string(input.index) + " (t=" + std::to_string(input.timestamp) + ")";
  tracking::Tracker::Result res;
  {
    // tracking_total = extraction + tracking without local mapping (ORB-SLAM's per-frame tracking time).
    ScopedStage total(trackingTimings_, "tracking_total");
    tracking::Frame frame;
    {
      ScopedStage st(trackingTimings_, "extraction");
      frame = tracking::makeFrame(input, camera_, tracker_->initialized() ? extractor_ : initExtractor_, context);
    }
    if (threaded_) {
      std::lock_guard<std::mutex> lk(queueMutex_);
      tracker_->setLocalMappingIdle(queue_.empty() && !busy_);
    }
    std::unique_lock<std::mutex> mk(mapMutex_, std::defer_lock);
    if (threaded_) mk.lock();
    res = tracker_->track(std::move(frame), trackingTimings_);
    if (res.mapWasReset) {
      mapper_->reset();
      ++generation_;
    }
  }
  if (!threaded_) {
    mapKeyFrames(res.newKeyFrames, mappingTimings_);
    return res;
  }
  if (!res.newKeyFrames.empty()) {
    std::lock_guard<std::mutex> lk(queueMutex_);
    for (map::KeyFrameId kf : res.newKeyFrames) queue_.emplace_back(generation_, kf);
  }
  queueCv_.notify_all();
  return res;
}

void SlamSystem::finish() {
  if (!threaded_) return;
  std::unique_lock<std::mutex> lk(queueMutex_);
  queueCv_.wait(lk, [&] { return queue_.empty() && !busy_; });
}

nlohmann::json SlamSystem::mappingLog() const {
  std::lock_guard<std::mutex> mk(mapMutex_);
  return mappingLog_;
}

StageTimings SlamSystem::timings() const {
  std::lock_guard<std::mutex> mk(mapMutex_);
  StageTimings all = trackingTimings_;
  for (const auto& [stage, samples] : mappingTimings_.samples())
    for (double v : samples) all.add(stage, v);
  return all;
}

}  // namespace pslam::system
