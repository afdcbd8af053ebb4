#include "pslam/lines/LineGeometry.h"

#include <cmath>

namespace pslam::lines {

Eigen::Vector3d imageLine(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d l = Eigen::Vector3d(a.x(), a.y(), 1.0).cross(Eigen::Vector3d(b.x(), b.y(), 1.0));
  return l / l.head<2>().norm();
}

LineTriangulation triangulateLine(const geometry::PinholeCamera& camera, const Eigen::Isometry3d& T_cam1_world,
                                  const Eigen::Vector2d& a1, const Eigen::Vector2d& b1,
                                  const Eigen::Isometry3d& T_cam2_world, const Eigen::Vector2d& a2,
                                  const Eigen::Vector2d& b2, const LineTriangulationParams& params) {
  LineTriangulation out;
  if ((b1 - a1).norm() < 1e-6 || (b2 - a2).norm() < 1e-6) {
    out.reason = "degenerate segment";
    return out;
  }
  const Eigen::Matrix3d Kinv = camera.K().inverse();
  const Eigen::Matrix3d R1t = T_cam1_world.linear().transpose(), R2t = T_cam2_world.linear().transpose();
  const Eigen::Vector3d C1 = -(R1t * T_cam1_world.translation()), C2 = -(R2t * T_cam2_world.translation());
  const double baseline = (C2 - C1).norm();
  if (!(baseline > 0.0)) {
    out.reason = "no baseline";
    return out;
  }
  // Rays of the endpoints (world directions) and the planes' unit normals (world).
  const Eigen::Vector3d ra1 = (R1t * (Kinv * Eigen::Vector3d(a1.x(), a1.y(), 1.0))).normalized();
  const Eigen::Vector3d rb1 = (R1t * (Kinv * Eigen::Vector3d(b1.x(), b1.y(), 1.0))).normalized();
  const Eigen::Vector3d ra2 = R2t * (Kinv * Eigen::Vector3d(a2.x(), a2.y(), 1.0));
  const Eigen::Vector3d rb2 = R2t * (Kinv * Eigen::Vector3d(b2.x(), b2.y(), 1.0));
  const Eigen::Vector3d n1 = ra1.cross(rb1).normalized();
  const Eigen::Vector3d n2 = ra2.cross(rb2).normalized();
  if (n1.cross(n2).norm() < std::sin(params.minPlaneAngleDeg * M_PI / 180.0)) {
    out.reason = "planes almost parallel";
    return out;
  }
  // X = C1 + lambda r with n2 . (X - C2) = 0.
  auto intersect = [&](const Eigen::Vector3d& r, Eigen::Vector3d& X) {
    const double den = n2.dot(r);
    if (std::abs(den) < params.minRayPlaneSin) {
      out.reason = "endpoint ray parallel to the plane";
      return false;
    }
    const double lambda = n2.dot(C2 - C1) / den;
    X = C1 + lambda * r;
    if (!(lambda > 0.0) || !((T_cam2_world * X).z() > 0.0) || !((T_cam1_world * X).z() > 0.0)) {
      out.reason = "endpoint behind a camera";
      return false;
    }
    if (lambda > params.maxDepthRatio * baseline) {
      out.reason = "endpoint too far for the baseline";
      return false;
    }
    return true;
  };
  Eigen::Vector3d A, B;
  if (!intersect(ra1, A) || !intersect(rb1, B)) return out;
  out.valid = true;
  out.line = {A, B};
  return out;
}

}  // namespace pslam::lines
