#pragma once
// A keyframe: pose, camera, undistorted ORB keypoints with descriptors, the keypoint -> map point
// association and the covisibility / spanning-tree links (ids only). The association and graph fields are
// maintained by pslam::map::Map; callers fill the measurement fields before Map::addKeyFrame().
#include <array>
#include <cstddef>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/map/Types.h"
#include "pslam/places/BowTypes.h"

namespace pslam::map {

struct KeyFrame {
  // ---- measurement state (set by the caller) ----
  KeyFrameId id = kNoKeyFrame;  ///< assigned by Map::addKeyFrame()
  double timestamp = 0.0;       ///< seconds
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();  ///< world -> camera
  geometry::PinholeCamera camera;
  std::vector<cv::KeyPoint> keypoints;  ///< undistorted pixel positions; `octave` = pyramid level
  cv::Mat descriptors;                  ///< keypoints.size() x 32, CV_8U (ORB)
  std::vector<double> scaleFactors;     ///< per pyramid level: s^level
  std::vector<double> levelSigma2;      ///< per pyramid level: (s^level)^2, variance of a keypoint position
  /// Optional per-keypoint P(static, dynamic, invalid) (Table 3.1 classes); empty when no semantics.
  std::vector<std::array<float, 3>> semanticProbabilities;

  /// The descriptors in the vocabulary of the run (libs/places), when it has one: the BoW vector
  /// (relocalization, place recognition) and the direct index (vocabulary-guided matching). Derived data: not
  /// saved with the map (recomputed from the descriptors after loading), not compared by Map::operator==.
  places::BowVector bow;
  places::FeatureVector bowFeatures;

  // ---- bookkeeping maintained by Map (do not edit directly) ----
  std::vector<MapPointId> mapPointIds;  ///< per keypoint, kNoMapPoint when unmatched
  /// Covisibility: number of map points shared with every other keyframe (> 0 only). The covisibility
  /// graph's edges are the entries >= Map::kCovisibilityThreshold (ORB-SLAM's rule).
  std::map<KeyFrameId, int> sharedPoints;
  KeyFrameId parent = kNoKeyFrame;  ///< spanning tree (kNoKeyFrame for the root / not yet connected)
  std::set<KeyFrameId> children;

  std::size_t numKeypoints() const { return keypoints.size(); }
  int numLevels() const { return static_cast<int>(scaleFactors.size()); }
  Eigen::Isometry3d T_world_cam() const { return T_cam_world.inverse(); }
  Eigen::Vector3d cameraCenter() const {
    return -(T_cam_world.linear().transpose() * T_cam_world.translation());
  }
  /// 1 / sigma^2 of the keypoint's pyramid level: the information weight of its reprojection error.
  double invSigma2(std::size_t keypoint) const { return 1.0 / levelSigma2.at(keypoints.at(keypoint).octave); }
  Eigen::Vector2d pixel(std::size_t keypoint) const {
    return {keypoints.at(keypoint).pt.x, keypoints.at(keypoint).pt.y};
  }

  /// Fills scaleFactors / levelSigma2 for an ORB pyramid (ORB-SLAM: s^l and s^2l).
  void setPyramid(int numLevels, double scaleFactor);

  /// Validates the measurement state (sizes, types, finite pose, octaves within the pyramid, semantic
  /// probabilities in [0,1]). Throws pslam::Error("<context>: ...").
  void check(const std::string& context) const;
};

}  // namespace pslam::map
