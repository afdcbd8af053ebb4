#pragma once
// What the parts of tracking share (doc/architecture.md, "Tracking"): the map, the camera, the parameters, the
// point-use policy, the landmark modules, the reference keyframe and the stage timings of the frame being tracked.
// The Tracker owns it; its parts (FramePoseOptimizer, MotionTracking, LocalMapTracker, Relocalizer, ManhattanPath)
// read and update it.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pslam/core/StageTimer.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"
#include "pslam/map/PointUsePolicy.h"
#include "pslam/tracking/LandmarkModule.h"
#include "pslam/tracking/TrackingParams.h"

namespace pslam::tracking {

struct TrackingContext {
  TrackingContext(map::Map& m, const geometry::PinholeCamera& c, const TrackerParams& p)
      : map(m), camera(c), params(p) {}

  map::Map& map;
  geometry::PinholeCamera camera;
  TrackerParams params;
  /// Which map points tracking may use for a pose; null = every point that is not bad (ORB-SLAM*'s policy, which
  /// is the same as none: the per-point call is skipped).
  std::shared_ptr<const map::PointUsePolicy> policy;
  /// The landmark modules in the order they were registered (their factors follow one another in that order).
  std::vector<std::shared_ptr<LandmarkModule>> modules;
  /// false = localization only: no keyframes, no change to the map (not even the points' counters).
  bool mapUpdates = true;
  /// The keyframe tracking refers to (kNoKeyFrame before the first map).
  map::KeyFrameId referenceKeyFrame = map::kNoKeyFrame;
  /// Stage timings of the frame being tracked (null outside Tracker::track).
  StageTimings* timings = nullptr;

  /// May tracking use map point `id` for the pose (exists, not bad, allowed by the policy)?
  bool usable(map::MapPointId id) const {
    if (id == map::kNoMapPoint || !map.hasMapPoint(id)) return false;
    const map::MapPoint& p = map.mapPoint(id);
    return !p.bad && (!policy || policy->mayUse(p));
  }
  /// May tracking search and measure it (exists, not bad)? Matches of measurable points that are not usable never
  /// enter pose optimization; they stay matched when they agree with the estimated pose, so keyframes observe them
  /// and their model is updated (§3.4.2).
  bool measurable(map::MapPointId id) const {
    return id != map::kNoMapPoint && map.hasMapPoint(id) && !map.mapPoint(id).bad;
  }
  /// Can a module carry a frame without keypoint matches (LandmarkModule::tracksWithoutKeypoints)?
  bool moduleTracksWithoutKeypoints() const {
    for (const auto& m : modules)
      if (m->tracksWithoutKeypoints()) return true;
    return false;
  }
  /// Times `stage` of the frame being tracked into `scope` (nothing outside Tracker::track).
  void time(std::optional<ScopedStage>& scope, const std::string& stage) const {
    if (timings) scope.emplace(*timings, stage);
  }
};

}  // namespace pslam::tracking
