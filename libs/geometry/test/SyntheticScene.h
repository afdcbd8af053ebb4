#pragma once
// Synthetic two-view scenes with known ground truth for the geometry tests.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/geometry/PinholeCamera.h"

namespace pslam::geometry::test {

inline PinholeCamera testCamera() { return PinholeCamera(520.0, 515.0, 321.5, 238.7, 640, 480); }

inline Eigen::Matrix3d rotationFromAxisAngle(const Eigen::Vector3d& axis, double angleDeg) {
  return Eigen::AngleAxisd(angleDeg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

inline double rotationErrorDeg(const Eigen::Matrix3d& Ra, const Eigen::Matrix3d& Rb) {
  return Eigen::AngleAxisd(Ra.transpose() * Rb).angle() * 180.0 / M_PI;
}

inline double directionErrorDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

struct TwoViewScene {
  Eigen::Matrix3d R_cur_ref;
  Eigen::Vector3d t_cur_ref;
  std::vector<Eigen::Vector3d> points_ref;   ///< ground-truth 3-D points in the reference frame
  std::vector<cv::Point2f> pixels_ref, pixels_cur;  ///< noisy observations
  std::vector<bool> isOutlier;               ///< current pixel replaced by a random one
};

enum class SceneShape { General, Planar };

/// Points visible in both views: depth 4..8 m (general) or on a tilted plane about 5 m away (planar).
/// Pixel noise is Gaussian with std `noisePx`; a fraction `outlierFraction` of the current-frame pixels is
/// replaced by uniformly random pixels.
inline TwoViewScene makeScene(SceneShape shape, const Eigen::Matrix3d& R_cur_ref, const Eigen::Vector3d& t_cur_ref,
                              int numPoints, double noisePx, double outlierFraction, unsigned seed) {
  const PinholeCamera cam = testCamera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noisePx);
  TwoViewScene scene;
  scene.R_cur_ref = R_cur_ref;
  scene.t_cur_ref = t_cur_ref;
  while (static_cast<int>(scene.points_ref.size()) < numPoints) {
    const Eigen::Vector2d px(u01(rng) * cam.width, u01(rng) * cam.height);
    const Eigen::Vector3d ray = cam.unprojectToPlane(px);
    double depth;
    if (shape == SceneShape::General) {
      depth = 4.0 + 4.0 * u01(rng);
    } else {
      // Plane n^T X = d with n = normalized(0.3, -0.2, 1): depth along the ray = d / (n^T ray).
      const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
      depth = 5.0 / n.dot(ray);
    }
    const Eigen::Vector3d X = ray * depth;
    const Eigen::Vector3d Xc = R_cur_ref * X + t_cur_ref;
    if (Xc.z() <= 0.1) continue;
    const Eigen::Vector2d pc = cam.project(Xc);
    if (pc.x() < 0 || pc.y() < 0 || pc.x() >= cam.width || pc.y() >= cam.height) continue;
    scene.points_ref.push_back(X);
    scene.pixels_ref.emplace_back(static_cast<float>(px.x() + noise(rng)), static_cast<float>(px.y() + noise(rng)));
    const bool outlier = u01(rng) < outlierFraction;
    scene.isOutlier.push_back(outlier);
    if (outlier) {
      scene.pixels_cur.emplace_back(static_cast<float>(u01(rng) * cam.width), static_cast<float>(u01(rng) * cam.height));
    } else {
      scene.pixels_cur.emplace_back(static_cast<float>(pc.x() + noise(rng)), static_cast<float>(pc.y() + noise(rng)));
    }
  }
  return scene;
}

}  // namespace pslam::geometry::test
