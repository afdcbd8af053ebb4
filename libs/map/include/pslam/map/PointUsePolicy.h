#pragma once
// The one decision "may this map point be used now?" of the map-point models compared in thesis §3.5.5.1
// (heuristic ORB-SLAM* bookkeeping, semantic masking, the probabilistic keypoint model of §3.3). Tracking
// (projection searches, pose optimization, the keyframe decision), the local BA window and map-point culling
// all ask the same policy object, so a point the model deactivates is never used anywhere (§3.4.2-3.4.3).
// The implementation for the three models is pslam::mapping::MapPointModelPolicy.
#include <array>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/map/MapPoint.h"
#include "pslam/map/Types.h"

namespace pslam::map {

class Map;

/// One measurement of a map point in a view that is not its anchor (a tracked frame or a new keyframe): the
/// view's pose and camera, the matched keypoint and its descriptor, and its class probabilities when the view
/// has a SEMANTIC channel.
struct PointMeasurement {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  geometry::PinholeCamera camera;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  cv::Mat descriptor;                                      ///< 1 x 32 CV_8U row (may be empty)
  const std::array<float, 3>* classProbabilities = nullptr;  ///< P(static, dynamic, invalid) or null
};

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
  /// Does the policy keep a per-point model that every measurement updates (§3.4.2)? Callers skip observe()
  /// otherwise.
  virtual bool learnsFromMeasurements() const { return false; }
  /// Updates the model of `point` (which lives in `map`; its anchor keyframe is read from there) with one
  /// measurement. Returns true when a depth measurement was applied. The default does nothing.
  virtual bool observe(const Map& map, MapPoint& point, const PointMeasurement& measurement) const {
    (void)map, (void)point, (void)measurement;
    return false;
  }
};

}  // namespace pslam::map
