#include "pslam/geometry/Triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "pslam/geometry/Epipolar.h"

namespace pslam::geometry {

Matrix34d projectionMatrix(const Eigen::Matrix3d& K, const Eigen::Matrix3d& R_cam_world,
                           const Eigen::Vector3d& t_cam_world) {
  Matrix34d Rt;
  Rt.leftCols<3>() = R_cam_world;
  Rt.col(3) = t_cam_world;
  return K * Rt;
}

Eigen::Vector3d cameraCenter(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world) {
  return -R_cam_world.transpose() * t_cam_world;
}

bool triangulateDLT(const std::vector<Matrix34d>& projections, const std::vector<Eigen::Vector2d>& pixels,
                    Eigen::Vector3d& X_world) {
  const std::size_t n = projections.size();
  if (n < 2 || pixels.size() != n) return false;
  Eigen::Matrix<double, Eigen::Dynamic, 4> A(2 * n, 4);
  for (std::size_t i = 0; i < n; ++i) {
    const Matrix34d& P = projections[i];
    const double x = pixels[i].x(), y = pixels[i].y();
    // First two rows of [x]_x P (eq. 2.21): -P(2) + y P(3) and P(1) - x P(3), written with the sign
    // flipped on the first row (same null space).
    A.row(2 * i) = P.row(1) - y * P.row(2);
    A.row(2 * i + 1) = P.row(0) - x * P.row(2);
  }
  if (!A.allFinite()) return false;
  // eq. 2.22-2.23: right singular vector of the smallest singular value.
  Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 4>> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (!h.allFinite() || std::abs(h(3)) <= 1e-12 * h.norm()) return false;
  X_world = h.head<3>() / h(3);
  return X_world.allFinite();
}

bool triangulateDLT(const Matrix34d& P1, const Eigen::Vector2d& pixel1, const Matrix34d& P2,
                    const Eigen::Vector2d& pixel2, Eigen::Vector3d& X_world) {
  // Same system as the N-view version with fixed sizes (no heap allocation: local mapping calls this
  // for every candidate match).
  Eigen::Matrix4d A;
  A.row(0) = P1.row(1) - pixel1.y() * P1.row(2);
  A.row(1) = P1.row(0) - pixel1.x() * P1.row(2);
  A.row(2) = P2.row(1) - pixel2.y() * P2.row(2);
  A.row(3) = P2.row(0) - pixel2.x() * P2.row(2);
  if (!A.allFinite()) return false;
  Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  if (!h.allFinite() || std::abs(h(3)) <= 1e-12 * h.norm()) return false;
  X_world = h.head<3>() / h(3);
  return X_world.allFinite();
}

double depthInCamera(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world,
                     const Eigen::Vector3d& X_world) {
  return R_cam_world.row(2).dot(X_world) + t_cam_world.z();
}

bool hasPositiveDepth(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world,
                      const Eigen::Vector3d& X_world) {
  return depthInCamera(R_cam_world, t_cam_world, X_world) > 0.0;
}

double parallaxCosine(const Eigen::Vector3d& X_world, const Eigen::Vector3d& center1,
                      const Eigen::Vector3d& center2) {
  const Eigen::Vector3d ray1 = X_world - center1;
  const Eigen::Vector3d ray2 = X_world - center2;
  const double norms = ray1.norm() * ray2.norm();
  if (norms <= 0.0) return 1.0;
  return std::clamp(ray1.dot(ray2) / norms, -1.0, 1.0);
}

double parallaxAngle(const Eigen::Vector3d& X_world, const Eigen::Vector3d& center1,
                     const Eigen::Vector3d& center2) {
  // atan2 of |cross| and dot is accurate for the tiny angles that matter here (acos is not near 1).
  const Eigen::Vector3d ray1 = X_world - center1;
  const Eigen::Vector3d ray2 = X_world - center2;
  return std::atan2(ray1.cross(ray2).norm(), ray1.dot(ray2));
}

double reprojectionErrorSquared(const Eigen::Matrix3d& K, const Eigen::Matrix3d& R_cam_world,
                                const Eigen::Vector3d& t_cam_world, const Eigen::Vector3d& X_world,
                                const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d X_cam = R_cam_world * X_world + t_cam_world;
  if (!(X_cam.z() > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d h = K * X_cam;
  return (h.head<2>() / h.z() - pixel).squaredNorm();
}

bool passesReprojectionTest(double errorSquared, double sigma2, double chi2Threshold) {
  return errorSquared <= chi2Threshold * sigma2;
}

// ---- Epipolar helpers (Epipolar.h)

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d essentialFromRelativePose(const Eigen::Matrix3d& R_12, const Eigen::Vector3d& t_12) {
  return skew(t_12) * R_12;
}

Eigen::Matrix3d fundamentalFromPoses(const Eigen::Matrix3d& K1, const Eigen::Matrix3d& R_1w,
                                     const Eigen::Vector3d& t_1w, const Eigen::Matrix3d& K2,
                                     const Eigen::Matrix3d& R_2w, const Eigen::Vector3d& t_2w) {
  const Eigen::Matrix3d R_12 = R_1w * R_2w.transpose();
  const Eigen::Vector3d t_12 = t_1w - R_12 * t_2w;
  return K1.inverse().transpose() * essentialFromRelativePose(R_12, t_12) * K2.inverse();
}

double epipolarDistanceSquared(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2, const Eigen::Matrix3d& F12) {
  const Eigen::Vector3d line2 = F12.transpose() * Eigen::Vector3d(x1.x(), x1.y(), 1.0);
  const double den = line2.x() * line2.x() + line2.y() * line2.y();
  if (den <= 0.0) return std::numeric_limits<double>::infinity();
  const double num = line2.x() * x2.x() + line2.y() * x2.y() + line2.z();
  return num * num / den;
}

bool checkDistEpipolarLine(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2, const Eigen::Matrix3d& F12,
                           double sigma2, double chi2Threshold) {
  return epipolarDistanceSquared(x1, x2, F12) < chi2Threshold * sigma2;
}

}  // namespace pslam::geometry
