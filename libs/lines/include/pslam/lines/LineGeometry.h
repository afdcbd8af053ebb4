#pragma once
// Geometry of line segments (thesis §2.3.2.2): the normalized homogeneous image line through two endpoints
// (eq. 2.58), point-to-line distances (the terms of eq. 2.59) and the two-view triangulation of a 3D line as the
// intersection of the planes the two segments span with their camera centres.
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pslam/map/Types.h"

namespace pslam::lines {

/// l = (a, b, c) with a^2 + b^2 = 1 through pixels `a` and `b` (eq. 2.58 normalized so that l . (u, v, 1) is the
/// signed distance in pixels). Requires a != b.
Eigen::Vector3d imageLine(const Eigen::Vector2d& a, const Eigen::Vector2d& b);
/// Signed distance (pixels) of `pixel` to the normalized line `l`.
inline double lineDistance(const Eigen::Vector3d& l, const Eigen::Vector2d& pixel) {
  return l.x() * pixel.x() + l.y() * pixel.y() + l.z();
}

/// A 3D line as two world endpoints.
struct Line3 {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d end = Eigen::Vector3d::Zero();
};

struct LineTriangulationParams {
  double minPlaneAngleDeg = 1.0;   ///< the two back-projected planes must differ by at least this (parallax)
  double minRayPlaneSin = 0.005;   ///< |sin| of the angle between an endpoint ray of view 1 and plane 2
  double maxDepthRatio = 50.0;     ///< endpoint depth / baseline at most this (rays almost parallel)
};

struct LineTriangulation {
  bool valid = false;
  Line3 line;           ///< endpoints: the first view's segment endpoints on the 3D line
  std::string reason;   ///< why not valid
};

/// Triangulates the segment (a1, b1) of view 1 with the segment (a2, b2) of view 2 (undistorted pixels, camera
/// poses T_cam_world): the plane of segment 2 through camera centre 2 intersected with the rays of the endpoints
/// of segment 1. Rejected: degenerate segments, planes closer than minPlaneAngleDeg (the line lies near the
/// epipolar plane, no parallax), rays almost parallel to plane 2, endpoints behind either camera or beyond
/// maxDepthRatio baselines.
LineTriangulation triangulateLine(const geometry::PinholeCamera& camera, const Eigen::Isometry3d& T_cam1_world,
                                  const Eigen::Vector2d& a1, const Eigen::Vector2d& b1,
                                  const Eigen::Isometry3d& T_cam2_world, const Eigen::Vector2d& a2,
                                  const Eigen::Vector2d& b2, const LineTriangulationParams& params = {});

}  // namespace pslam::lines
