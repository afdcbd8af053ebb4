#pragma once
// A small synthetic map for the tests: keyframes on a line looking along +z at random points, every
// keypoint the exact projection of a point, random descriptors (with a few flipped bits per observation).
#include <random>
#include <vector>

#include "pslam/map/Map.h"

namespace pslam::map::testing {

inline geometry::PinholeCamera testCamera() { return {500.0, 500.0, 320.0, 240.0, 640, 480}; }

struct SyntheticScene {
  std::vector<Eigen::Vector3d> points;                 // world positions, by scene index
  std::vector<std::vector<int>> keypointOfPoint;       // [kf][scene index] -> keypoint or -1
  std::vector<KeyFrameId> keyframeIds;
  std::vector<MapPointId> mapPointOfScene;             // scene index -> map point id
};

inline Eigen::Isometry3d poseOnLine(int i) {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  T_world_cam.translation() = Eigen::Vector3d(0.3 * i, 0.02 * i, 0.0);
  T_world_cam.linear() = Eigen::AngleAxisd(0.03 * i, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T_world_cam.inverse();
}

/// Keyframes on a bend (the line's poses with a sideways and forward offset growing with i^2): their centres are not
/// collinear, so a Sim(3) alignment of them is determined.
inline Eigen::Isometry3d poseOnCurve(int i) {
  Eigen::Isometry3d T_world_cam = poseOnLine(i).inverse();
  T_world_cam.translation() += Eigen::Vector3d(0.0, 0.03 * i * i, 0.05 * i * i);
  return T_world_cam.inverse();
}

/// Builds `numKeyFrames` keyframes and `numPoints` points; every point is created by the first keyframe
/// that sees it and observed by every later one that sees it.
inline Map buildSyntheticMap(int numKeyFrames, int numPoints, SyntheticScene& scene, unsigned seed = 7,
                             Eigen::Isometry3d (*pose)(int) = poseOnLine) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-3.0, 4.0), uy(-2.0, 2.0), uz(4.0, 9.0);
  std::uniform_int_distribution<int> byte(0, 255), level(0, 7), bit(0, 255);
  const geometry::PinholeCamera cam = testCamera();
  scene.points.clear();
  std::vector<cv::Mat> baseDesc;
  for (int i = 0; i < numPoints; ++i) {
    scene.points.emplace_back(ux(rng), uy(rng), uz(rng));
    cv::Mat d(1, 32, CV_8UC1);
    for (int b = 0; b < 32; ++b) d.at<uchar>(0, b) = static_cast<uchar>(byte(rng));
    baseDesc.push_back(d);
  }
  Map map;
  scene.keypointOfPoint.assign(numKeyFrames, std::vector<int>(numPoints, -1));
  scene.mapPointOfScene.assign(numPoints, kNoMapPoint);
  scene.keyframeIds.clear();
  for (int f = 0; f < numKeyFrames; ++f) {
    KeyFrame kf;
    kf.timestamp = f * 0.5;
    kf.T_cam_world = pose(f);
    kf.camera = cam;
    kf.setPyramid(8, 1.2);
    std::vector<cv::Mat> rows;
    for (int i = 0; i < numPoints; ++i) {
      const Eigen::Vector3d pc = kf.T_cam_world * scene.points[i];
      if (pc.z() <= 0.1) continue;
      const Eigen::Vector2d px = cam.project(pc);
      if (!cam.inImage(px)) continue;
      scene.keypointOfPoint[f][i] = static_cast<int>(kf.keypoints.size());
      kf.keypoints.emplace_back(cv::Point2f(float(px.x()), float(px.y())), 31.f, 0.f, 1.f, level(rng));
      cv::Mat d = baseDesc[i].clone();
      const int flip = bit(rng);  // one flipped bit per observation: descriptors differ, medians matter
      d.at<uchar>(0, flip / 8) ^= static_cast<uchar>(1 << (flip % 8));
      rows.push_back(d);
    }
    if (!rows.empty()) cv::vconcat(rows, kf.descriptors);
    const KeyFrameId id = map.addKeyFrame(std::move(kf));
    scene.keyframeIds.push_back(id);
    for (int i = 0; i < numPoints; ++i) {
      const int k = scene.keypointOfPoint[f][i];
      if (k < 0) continue;
      if (scene.mapPointOfScene[i] == kNoMapPoint)
        scene.mapPointOfScene[i] = map.addMapPoint(id, k, scene.points[i]);
      else
        map.addObservation(scene.mapPointOfScene[i], id, k);
    }
    for (int i = 0; i < numPoints; ++i)
      if (scene.mapPointOfScene[i] != kNoMapPoint && scene.keypointOfPoint[f][i] >= 0) {
        map.computeDistinctiveDescriptor(scene.mapPointOfScene[i]);
        map.updateNormalAndDepth(scene.mapPointOfScene[i]);
      }
    map.connectToSpanningTree(id);
  }
  return map;
}

}  // namespace pslam::map::testing
