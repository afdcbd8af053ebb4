#pragma once
// A descriptive map point in the inverse-depth parameterization of thesis eq. 3.1: the point hangs on the
// ray of one keypoint of its anchor (reference) keyframe.
//
//   P_anchor = bearing / rho            (bearing: unit vector in the anchor camera, rho = 1 / distance)
//   P_world  = T_world_anchor * P_anchor
//
// Eq. 3.1 writes the same point with the pixel (x, y) and the inverse depth along the optical axis
// d = 1/z: P_c = K^-1 [x/d, y/d, 1/d]. Both describe one point: d = rho / bearing.z(), (x, y) = K bearing.
// We store the unit bearing (as SVO, [39]) because it is well defined for any viewing direction and its
// inverse range rho -> 0 represents points at infinity (still constraining rotation).
#include <cstddef>
#include <map>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/map/Types.h"

namespace pslam::map {

struct MapPoint {
  MapPointId id = kNoMapPoint;

  // ---- inverse-depth parameterization (eq. 3.1) ----
  KeyFrameId anchorKeyFrame = kNoKeyFrame;  ///< reference keyframe; always one of the observers
  std::size_t anchorKeypoint = 0;           ///< its keypoint the point was created from
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  ///< unit direction in the anchor camera
  double inverseDepth = 1.0;                ///< rho = 1 / distance from the anchor camera centre

  // ---- observations and appearance (ORB-SLAM) ----
  std::map<KeyFrameId, std::size_t> observations;  ///< keyframe -> keypoint index, ordered by id
  cv::Mat descriptor;             ///< 1 x 32 CV_8U: the observation descriptor with least median distance
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< mean unit viewing direction (point - centre)
  double minDistance = 0.0;       ///< scale-invariance range [min, max] of the distance to a camera
  double maxDistance = 0.0;
  int visibleCount = 1;           ///< frames in whose frustum the point was predicted
  int foundCount = 1;             ///< frames in which it was matched
  bool bad = false;               ///< culled, kept only until the caller erases it
  KeyFrameId firstKeyFrame = kNoKeyFrame;  ///< keyframe that created it (ORB-SLAM culling age)

  // ==== PROBABILISTIC STATE (thesis ch. 3.3) =================================================
  // Owned by pslam::landmarks: its per-point model (semantic Beta counts, depth Gaussian, inlier Beta,
  // ...) converts itself to / from this flat vector of doubles. The map stores and serializes it
  // verbatim and never interprets it. Empty = no probabilistic state yet.
  std::vector<double> landmarkState;
  // ===========================================================================================

  Eigen::Vector3d positionInAnchor() const { return bearing / inverseDepth; }
  Eigen::Vector3d worldPosition(const Eigen::Isometry3d& T_world_anchor) const {
    return T_world_anchor * positionInAnchor();
  }
  /// Inverse depth along the anchor's optical axis, `d` of eq. 3.1.
  double inverseDepthAlongZ() const { return inverseDepth / bearing.z(); }
  std::size_t numObservations() const { return observations.size(); }
  bool isObservedBy(KeyFrameId kf) const { return observations.count(kf) != 0; }
};

}  // namespace pslam::map
