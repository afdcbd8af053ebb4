#pragma once
// Synthetic scenes with ground truth for the optimizer tests and benchmark: cameras on an arc looking at a
// box of points, observations = true projections + Gaussian noise scaled by the pyramid level, a fraction
// replaced by gross outliers. Deterministic for a given seed.
#include <cmath>
#include <random>
#include <vector>

#include "pslam/optimize/BundleAdjustment.h"

namespace pslam::optimize::testing {

inline geometry::PinholeCamera testCamera() { return {500.0, 500.0, 320.0, 240.0, 640, 480}; }

/// i-th camera on an arc around the scene centre (0, 0, 6), looking roughly at it.
inline Eigen::Isometry3d arcPose(int i, int n) {
  const double angle = n > 1 ? -0.25 + 0.5 * i / (n - 1) : 0.0;  // radians across the arc
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  T_world_cam.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_world_cam.translation() = Eigen::Vector3d(0, 0, 6) - T_world_cam.linear() * Eigen::Vector3d(0, 0, 6) +
                              Eigen::Vector3d(0, 0.05 * std::sin(1.3 * i), 0);
  return T_world_cam.inverse();
}

inline Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, double rotationRad, double translation, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  D.linear() = Eigen::AngleAxisd(rotationRad, axis).toRotationMatrix();
  D.translation() = translation * dir;
  return D * T;
}

inline double rotationErrorRad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle();
}
inline double centreError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}

struct SyntheticBA {
  BAProblem truth;      ///< exact poses and inverse depths; observations noisy
  BAProblem problem;    ///< same observations, perturbed free poses and inverse depths
  std::vector<bool> isOutlier;  ///< per observation: a gross outlier by construction
};

struct SyntheticOptions {
  int keyframes = 10;
  int fixedKeyFrames = 3;   ///< the first ones
  int points = 500;
  double noisePixels = 1.0; ///< std at level 0
  double outlierFraction = 0.05;
  double poseRotationNoise = 0.01;  ///< radians, on free keyframes
  double poseTranslationNoise = 0.05;
  double inverseDepthNoise = 0.1;   ///< relative
  double scaleFactor = 1.2;
  int levels = 8;
  int visibilityWindow = 0;  ///< > 0: a point is observed only by this many consecutive keyframes (ORB-like)
  unsigned seed = 1;
};

inline SyntheticBA makeSyntheticBA(const SyntheticOptions& opt) {
  std::mt19937 rng(opt.seed);
  std::uniform_real_distribution<double> ux(-3.0, 3.0), uy(-2.0, 2.0), uz(4.0, 9.0), u01(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 3);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const geometry::PinholeCamera cam = testCamera();
  SyntheticBA s;
  for (int i = 0; i < opt.keyframes; ++i) {
    BAKeyFrame kf;
    kf.T_cam_world = arcPose(i, opt.keyframes);
    kf.camera = cam;
    kf.fixed = i < opt.fixedKeyFrames;
    s.truth.keyframes[i] = kf;
  }
  for (int j = 0; j < opt.points; ++j) {
    const Eigen::Vector3d pw(ux(rng), uy(rng), uz(rng));
    // Anchor: a random keyframe that sees the point.
    std::vector<int> seenBy;
    for (int i = 0; i < opt.keyframes; ++i) {
      const Eigen::Vector3d pc = s.truth.keyframes[i].T_cam_world * pw;
      if (pc.z() > 0.5 && cam.inImage(cam.project(pc))) seenBy.push_back(i);
    }
    if (opt.visibilityWindow > 0 && static_cast<int>(seenBy.size()) > opt.visibilityWindow) {
      const int first = std::uniform_int_distribution<int>(0, int(seenBy.size()) - opt.visibilityWindow)(rng);
      seenBy = std::vector<int>(seenBy.begin() + first, seenBy.begin() + first + opt.visibilityWindow);
    }
    if (seenBy.size() < 2) continue;
    const int anchor = seenBy[std::uniform_int_distribution<int>(0, int(seenBy.size()) - 1)(rng)];
    const Eigen::Vector3d pa = s.truth.keyframes[anchor].T_cam_world * pw;
    BAPoint p;
    p.anchor = anchor;
    p.bearing = pa.normalized();
    p.inverseDepth = 1.0 / pa.norm();
    s.truth.points[j] = p;
    for (int i : seenBy) {
      BAObservation o;
      o.keyframe = i;
      o.point = j;
      const int l = level(rng);
      const double sigma = std::pow(opt.scaleFactor, l);
      o.invSigma2 = 1.0 / (sigma * sigma);
      const Eigen::Vector3d pc = s.truth.keyframes[i].T_cam_world * pw;
      if (i == anchor) {
        o.pixel = cam.project(pc);  // the anchor keypoint defines the bearing
        s.isOutlier.push_back(false);
      } else if (u01(rng) < opt.outlierFraction) {
        const double r = 15.0 + 40.0 * u01(rng), a = 6.283185307 * u01(rng);
        o.pixel = cam.project(pc) + Eigen::Vector2d(r * std::cos(a), r * std::sin(a));
        s.isOutlier.push_back(true);
      } else {
        o.pixel = cam.project(pc) + opt.noisePixels * sigma * Eigen::Vector2d(gauss(rng), gauss(rng));
        s.isOutlier.push_back(false);
      }
      s.truth.observations.push_back(o);
    }
  }
  s.problem = s.truth;
  for (auto& [id, kf] : s.problem.keyframes)
    if (!kf.fixed) kf.T_cam_world = perturb(kf.T_cam_world, opt.poseRotationNoise, opt.poseTranslationNoise, rng);
  for (auto& [id, p] : s.problem.points) p.inverseDepth *= 1.0 + opt.inverseDepthNoise * gauss(rng);
  return s;
}

}  // namespace pslam::optimize::testing
