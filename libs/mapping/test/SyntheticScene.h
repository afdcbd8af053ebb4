#pragma once
// Synthetic scenes with known geometry for the local-mapping tests and the timing app: keypoints are the
// exact projections of known 3D points (octave 0), each point has its own random descriptor (one bit
// flipped per view) and keypoint angle; keyframes move along a lateral track.
#include <random>
#include <vector>

#include "pslam/map/Map.h"

namespace pslam::mapping::testing {

using map::KeyFrame;
using map::KeyFrameId;
using map::MapPointId;

inline geometry::PinholeCamera camera() { return {500.0, 500.0, 320.0, 240.0, 640, 480}; }

struct Scene {
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Mat> descriptors;
  std::vector<float> angles;
  std::vector<MapPointId> mapPointOf;  ///< scene index -> map point (kNoMapPoint if none)
  std::vector<std::vector<int>> keypointOf;  ///< [keyframe slot][scene index] -> keypoint or -1
  std::vector<KeyFrameId> keyframes;  ///< slot -> id
  std::vector<std::vector<int>> sceneOfKeypoint;  ///< [keyframe slot][keypoint] -> scene index
  double pixelNoise = 0.0;  ///< std-dev (px) of Gaussian noise added to each keypoint position
};

inline Scene makeScene(int numPoints, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-2.0, 4.0), uy(-1.5, 1.5), uz(4.0, 8.0);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_real_distribution<float> angle(0.f, 360.f);
  Scene s;
  for (int i = 0; i < numPoints; ++i) {
    s.points.emplace_back(ux(rng), uy(rng), uz(rng));
    cv::Mat d(1, 32, CV_8UC1);
    for (int b = 0; b < 32; ++b) d.at<uchar>(0, b) = static_cast<uchar>(byte(rng));
    s.descriptors.push_back(d);
    s.angles.push_back(angle(rng));
  }
  s.mapPointOf.assign(numPoints, map::kNoMapPoint);
  return s;
}

/// Camera `slot` of a lateral track: 0.25 m steps along x with a slight yaw.
inline Eigen::Isometry3d poseOf(int slot) {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  T_world_cam.translation() = Eigen::Vector3d(0.25 * slot, 0.01 * slot, 0.0);
  T_world_cam.linear() = Eigen::AngleAxisd(0.02 * slot, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T_world_cam.inverse();
}

/// Inserts a keyframe seeing every scene point in `visible` (empty = all) that projects into the image.
inline KeyFrameId addKeyFrame(map::Map& map, Scene& s, int slot, std::mt19937& rng, const std::vector<int>& visible = {}) {
  KeyFrame kf;
  kf.timestamp = slot;
  kf.T_cam_world = poseOf(slot);
  kf.camera = camera();
  kf.setPyramid(8, 1.2);
  std::vector<int> keypointOf(s.points.size(), -1);
  std::vector<cv::Mat> rows;
  std::uniform_int_distribution<int> bit(0, 255);
  std::vector<int> which = visible;
  if (which.empty())
    for (int i = 0; i < static_cast<int>(s.points.size()); ++i) which.push_back(i);
  for (int i : which) {
    const Eigen::Vector3d pc = kf.T_cam_world * s.points[i];
    if (pc.z() <= 0.1) continue;
    Eigen::Vector2d px = kf.camera.project(pc);
    if (s.pixelNoise > 0.0) {
      std::normal_distribution<double> noise(0.0, s.pixelNoise);
      px += Eigen::Vector2d(noise(rng), noise(rng));
    }
    if (!kf.camera.inImage(px)) continue;
    keypointOf[i] = static_cast<int>(kf.keypoints.size());
    kf.keypoints.emplace_back(cv::Point2f(float(px.x()), float(px.y())), 31.f, s.angles[i], 1.f, 0);
    cv::Mat d = s.descriptors[i].clone();
    const int flip = bit(rng);
    d.at<uchar>(0, flip / 8) ^= static_cast<uchar>(1 << (flip % 8));
    rows.push_back(d);
  }
  cv::vconcat(rows, kf.descriptors);
  const KeyFrameId id = map.addKeyFrame(std::move(kf));
  if (static_cast<int>(s.keypointOf.size()) <= slot) s.keypointOf.resize(slot + 1);
  s.keypointOf[slot] = keypointOf;
  if (static_cast<int>(s.sceneOfKeypoint.size()) <= slot) s.sceneOfKeypoint.resize(slot + 1);
  s.sceneOfKeypoint[slot].assign(rows.size(), -1);
  for (std::size_t i = 0; i < keypointOf.size(); ++i)
    if (keypointOf[i] >= 0) s.sceneOfKeypoint[slot][keypointOf[i]] = static_cast<int>(i);
  if (static_cast<int>(s.keyframes.size()) <= slot) s.keyframes.resize(slot + 1, map::kNoKeyFrame);
  s.keyframes[slot] = id;
  return id;
}

/// Creates map points for scene indices [begin, end) at their true position, anchored in `anchorSlot` and
/// observed by every slot in `observers` that sees them (the tracker's initial map).
inline std::vector<MapPointId> addTruePoints(map::Map& map, Scene& s, int begin, int end, int anchorSlot,
                                      const std::vector<int>& observers) {
  std::vector<MapPointId> ids;
  for (int i = begin; i < end; ++i) {
    const int k = s.keypointOf[anchorSlot][i];
    if (k < 0) continue;
    const MapPointId id = map.addMapPoint(s.keyframes[anchorSlot], k, s.points[i]);
    for (int o : observers)
      if (o != anchorSlot && s.keypointOf[o][i] >= 0) map.addObservation(id, s.keyframes[o], s.keypointOf[o][i]);
    map.computeDistinctiveDescriptor(id);
    map.updateNormalAndDepth(id);
    s.mapPointOf[i] = id;
    ids.push_back(id);
  }
  return ids;
}

/// The tracker's part for a new keyframe: link keypoints of scene points that already have a map point.
inline void trackKeyFrame(map::Map& map, Scene& s, int slot) {
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const int k = s.keypointOf[slot][i];
    const MapPointId id = s.mapPointOf[i];
    if (k >= 0 && id != map::kNoMapPoint && map.hasMapPoint(id)) map.addObservation(id, s.keyframes[slot], k);
  }
}

/// Scene index of a map point through its anchor keypoint (-1 if none matches).
inline int sceneIndexOf(const map::Map& map, const Scene& s, MapPointId id) {
  const map::MapPoint& p = map.mapPoint(id);
  for (std::size_t slot = 0; slot < s.keyframes.size() && slot < s.sceneOfKeypoint.size(); ++slot)
    if (s.keyframes[slot] == p.anchorKeyFrame && p.anchorKeypoint < s.sceneOfKeypoint[slot].size())
      return s.sceneOfKeypoint[slot][p.anchorKeypoint];
  return -1;
}

/// The tracker learns which scene point a new map point is through its anchor keypoint (so it can link it
/// in the next keyframe); scene points whose map point was fused or culled take the survivor.
inline void learnMapPoints(const map::Map& map, Scene& s) {
  for (const auto& [id, p] : map.mapPoints()) {
    const int i = sceneIndexOf(map, s, id);
    if (i >= 0 && (s.mapPointOf[i] == map::kNoMapPoint || !map.hasMapPoint(s.mapPointOf[i]))) s.mapPointOf[i] = id;
  }
}

}  // namespace pslam::mapping::testing
