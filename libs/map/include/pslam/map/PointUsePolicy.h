#pragma once
// The one decision "may this map point be used now?" of the map-point models compared in thesis §3.5.5.1
// (heuristic ORB-SLAM* bookkeeping, semantic masking, the probabilistic keypoint model of §3.3). Tracking
// (projection searches, pose optimization, the keyframe decision), the local BA window and map-point culling
// all ask the same policy object, so a point the model deactivates is never used anywhere (§3.4.2-3.4.3).
// The implementation for the three models is pslam::mapping::MapPointModelPolicy.
#include <string>

#include "pslam/map/MapPoint.h"
#include "pslam/map/Types.h"

namespace pslam::map {

class PointUsePolicy {
 public:
  virtual ~PointUsePolicy() = default;
  virtual std::string name() const = 0;
  /// Use the point for tracking and bundle adjustment now? Never true for a bad point.
  virtual bool mayUse(const MapPoint& point) const = 0;
  /// Remove the point from the map (MapPointCulling when keyframe `currentKeyFrame` is mapped)?
  virtual bool shouldCull(const MapPoint& point, KeyFrameId currentKeyFrame) const = 0;
  /// True when mayUse(p) == !p.bad for every point (ORB-SLAM*): callers may then skip per-point calls.
  virtual bool usesEveryGoodPoint() const { return false; }
};

/// ORB-SLAM*'s answer without any model: every point that is not bad is used; nothing is culled here.
class EveryGoodPointPolicy : public PointUsePolicy {
 public:
  std::string name() const override { return "every-good-point"; }
  bool mayUse(const MapPoint& point) const override { return !point.bad; }
  bool shouldCull(const MapPoint& point, KeyFrameId) const override { return point.bad; }
  bool usesEveryGoodPoint() const override { return true; }
};

}  // namespace pslam::map
