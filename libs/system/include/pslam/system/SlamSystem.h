#pragma once
// The monocular SLAM system (ORB-SLAM*): owns the map, the tracker and local mapping.
//  * sequential mode (default, thesis §3.5.2): track a frame; if it made keyframes, run local mapping on them
//    to completion in the same thread. With the seed fixed, two runs give bit-identical results.
//  * threaded mode (live use): local mapping runs in a second thread fed by a keyframe queue; the map is
//    guarded by one mutex (tracking holds it while it reads/extends the map, mapping per keyframe).
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "pslam/core/StageTimer.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"
#include "pslam/system/KeyFrameMapper.h"
#include "pslam/system/SlamParams.h"
#include "pslam/tracking/Tracker.h"

namespace pslam::system {

class SlamSystem {
 public:
  /// Local mapping is libs/mapping's LocalMapper (behind KeyFrameMapper), configured by params.mapping.
  SlamSystem(const SlamParams& params, const geometry::PinholeCamera& camera, std::uint32_t seed, bool threaded);
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  /// Extracts features, tracks, and (sequential mode) maps. Throws pslam::Error on a frame that does not fit
  /// the camera (size) naming the frame.
  tracking::Tracker::Result processFrame(const datasets::Frame& frame);
  /// Threaded mode: waits until the keyframe queue is processed. No-op in sequential mode.
  void finish();

  /// The map (call finish() first in threaded mode).
  const map::Map& map() const { return map_; }
  /// Generation of the map: incremented by every reset, so poses of different maps are never mixed.
  int mapGeneration() const { return generation_; }
  /// Tracking-side timings (extraction, matching, pose_optimization, local_map, ...) and mapping timings
  /// (triangulation, local_ba) merged.
  StageTimings timings() const;
  const std::string& mapperName() const { return mapperName_; }
  std::string mapperConfig() const { return mapper_->configText(); }
  std::size_t keyFramesMapped() const { return keyFramesMapped_; }
  /// One entry per mapped keyframe: {keyframe, new_points, culled_points, ba_observations_erased, ...}.
  nlohmann::json mappingLog() const;

 private:
  void mapKeyFrames(const std::vector<map::KeyFrameId>& kfs, StageTimings& timings);
  void mappingLoop();

  SlamParams params_;
  geometry::PinholeCamera camera_;
  map::Map map_;
  features::OrbExtractor extractor_;
  features::OrbExtractor initExtractor_;  ///< featureFactor x nFeatures, used until the map is initialized
  std::unique_ptr<tracking::Tracker> tracker_;
  std::unique_ptr<KeyFrameMapper> mapper_;
  std::string mapperName_;
  StageTimings trackingTimings_;
  StageTimings mappingTimings_;
  int generation_ = 0;
  std::size_t keyFramesMapped_ = 0;
  nlohmann::json mappingLog_ = nlohmann::json::array();

  bool threaded_ = false;
  mutable std::mutex mapMutex_;
  std::mutex queueMutex_;
  std::condition_variable queueCv_;
  std::deque<std::pair<int, map::KeyFrameId>> queue_;  ///< (generation, keyframe)
  bool busy_ = false;
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace pslam::system
