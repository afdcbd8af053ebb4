#pragma once
// A textured plane for the photometric tests: a smooth procedural texture (a sum of sinusoids, wavelengths
// 0.11-0.53 m, i.e. 14-66 pixels at the 4 m working distance and f = 500) on the plane Z = 4 + 0.1 X of the
// world, rendered exactly (ray-plane intersection, texture evaluated at the hit point) into 8-bit images with
// an affine exposure I = e^a T + b. Direct points are picked on a grid by gradient (one per cell) with their
// exact inverse depth. Deterministic, no randomness.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/map/Types.h"
#include "pslam/optimize/PhotometricError.h"

namespace pslam::optimize::testing {

inline geometry::PinholeCamera textureCamera() { return {500.0, 500.0, 319.5, 239.5, 640, 480}; }

/// Texture value in [0.22, 0.78] at plane coordinates (s, t) = world (X, Y).
inline double planeTexture(double s, double t) {
  constexpr double kTwoPi = 6.283185307179586;
  return 0.5 + 0.10 * std::sin(kTwoPi * s / 0.37 + 0.3) * std::cos(kTwoPi * t / 0.29) +
         0.08 * std::sin(kTwoPi * (s + t) / 0.23) + 0.06 * std::cos(kTwoPi * (s - 0.6 * t) / 0.53 + 1.1) +
         0.04 * std::sin(kTwoPi * (0.8 * s - t) / 0.11 + 0.7);
}

/// World point of pixel `px` of a camera at T_cam_world on the plane Z = 4 + 0.1 X.
inline Eigen::Vector3d planePoint(const Eigen::Isometry3d& T_cam_world, const geometry::PinholeCamera& cam,
                                  const Eigen::Vector2d& px) {
  const Eigen::Isometry3d T_world_cam = T_cam_world.inverse();
  const Eigen::Vector3d c = T_world_cam.translation();
  const Eigen::Vector3d d = T_world_cam.linear() * Eigen::Vector3d((px.x() - cam.cx) / cam.fx, (px.y() - cam.cy) / cam.fy, 1.0);
  const double lambda = (4.0 + 0.1 * c.x() - c.z()) / (d.z() - 0.1 * d.x());
  return c + lambda * d;
}

/// Renders the plane as CV_8UC1 with exposure I = e^a T + b (clamped to [0, 1], rounded to grey levels).
inline cv::Mat renderPlane(const Eigen::Isometry3d& T_cam_world, const geometry::PinholeCamera& cam,
                           AffineBrightness exposure = {}) {
  cv::Mat img(cam.height, cam.width, CV_8UC1);
  const double gain = std::exp(exposure.a);
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const Eigen::Vector3d p = planePoint(T_cam_world, cam, Eigen::Vector2d(u, v));
      const double I = std::clamp(gain * planeTexture(p.x(), p.y()) + exposure.b, 0.0, 1.0);
      img.at<unsigned char>(v, u) = static_cast<unsigned char>(std::lround(255.0 * I));
    }
  return img;
}

/// One host pixel per `cell` x `cell` block: the one with the largest central-difference gradient, at least
/// `margin` pixels from the border; with the exact inverse depth (1 / distance along the bearing).
struct HostSample {
  Eigen::Vector2d pixel;
  double inverseDepth;
};
inline std::vector<HostSample> pickHostPixels(const cv::Mat& grey, const Eigen::Isometry3d& T_host_world,
                                              const geometry::PinholeCamera& cam, int cell, int margin) {
  std::vector<HostSample> out;
  for (int y0 = margin; y0 + cell <= grey.rows - margin; y0 += cell)
    for (int x0 = margin; x0 + cell <= grey.cols - margin; x0 += cell) {
      int best = -1, bx = 0, by = 0;
      for (int y = y0; y < y0 + cell; ++y)
        for (int x = x0; x < x0 + cell; ++x) {
          const int gx = grey.at<unsigned char>(y, x + 1) - grey.at<unsigned char>(y, x - 1);
          const int gy = grey.at<unsigned char>(y + 1, x) - grey.at<unsigned char>(y - 1, x);
          if (gx * gx + gy * gy > best) {
            best = gx * gx + gy * gy;
            bx = x;
            by = y;
          }
        }
      const Eigen::Vector2d px(bx, by);
      const Eigen::Vector3d pc = T_host_world * planePoint(T_host_world, cam, px);
      out.push_back({px, 1.0 / pc.norm()});
    }
  return out;
}

/// T_cam_world of a camera at `centre` (world) rotated by the angle-axis `rotation` from the world axes.
inline Eigen::Isometry3d cameraAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& rotation) {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  if (rotation.norm() > 0) T_world_cam.linear() = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix();
  T_world_cam.translation() = centre;
  return T_world_cam.inverse();
}

}  // namespace pslam::optimize::testing
