#pragma once
// One camera frame as tracking sees it (ORB-SLAM's Frame, thesis §2.4.1): undistorted ORB keypoints with
// descriptors indexed by a FeatureGrid, the pose estimate, the keypoint -> map point association with outlier
// flags, and optional per-keypoint class probabilities sampled from the SEMANTIC channel (Table 3.1).
#include <array>
#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/datasets/Rawlog.h"
#include "pslam/features/FeatureGrid.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"
#include "pslam/places/BowTypes.h"

namespace pslam::tracking {

struct Frame {
  std::size_t index = 0;   ///< position in the input sequence
  double timestamp = 0.0;  ///< seconds
  geometry::PinholeCamera camera;          ///< ideal pinhole camera of the undistorted keypoints (no distortion)
  geometry::ImageBounds bounds;          ///< undistorted image bounds (projections outside are not searched)
  std::vector<cv::KeyPoint> keypoints;   ///< undistorted; octave = pyramid level
  cv::Mat descriptors;                   ///< N x 32 CV_8U
  features::FeatureGrid grid;            ///< over the undistorted keypoints
  std::vector<double> scaleFactors;      ///< s^level
  std::vector<double> levelSigma2;       ///< s^(2 level)
  std::vector<std::array<float, 3>> semanticProbabilities;  ///< per keypoint, empty without SEMANTIC
  /// BoW vector and direct index in the run's vocabulary; computed on demand (relocalization, reference tracking).
  places::BowVector bow;
  places::FeatureVector bowFeatures;
  // Other channels of the rawlog frame (doc/architecture.md, "Data contracts"), registered to the raw image; empty when absent.
  cv::Mat grey;             ///< CV_8UC1 image the keypoints were extracted from (direct features, §3.3)
  cv::Mat semantic;         ///< SEMANTIC, CV_8UC3 P(static, dynamic, invalid) x 255 (direct points' class evidence)
  cv::Mat normals;          ///< NORMALS, CV_8UC3 (Manhattan frame, §4.4)
  cv::Mat depth;            ///< DEPTH, CV_16UC1
  double depthUnits = 0.0;  ///< metres per depth unit
  /// The frame's Manhattan frame (§4.4): the three axes in camera coordinates as columns (R_cam_mf of the
  /// mean-shift tracker, labels kept from frame to frame), set when its NORMALS gave a valid estimate.
  std::optional<Eigen::Matrix3d> R_cam_mf;
  /// Rotation prior R_cam_world for this frame (e.g. from its Manhattan frame), passed to the pose solver.
  std::optional<Eigen::Matrix3d> rotationPrior;

  bool hasPose = false;
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::vector<map::MapPointId> mapPointIds;  ///< per keypoint, map::kNoMapPoint when unmatched
  std::vector<bool> outlier;                 ///< per keypoint, set by pose optimization

  std::size_t size() const { return keypoints.size(); }
  int numLevels() const { return static_cast<int>(scaleFactors.size()); }
  /// Matched keypoints that are not flagged as outliers.
  int numMatchedInliers() const;
  /// Clears the association and outlier flags.
  void resetMatches();
  Eigen::Vector3d cameraCenter() const {
    return -(T_cam_world.linear().transpose() * T_cam_world.translation());
  }
  Eigen::Vector2d pixel(std::size_t i) const { return {keypoints[i].pt.x, keypoints[i].pt.y}; }
};

/// Builds a tracking frame: grey conversion (monocular), ORB extraction, undistortion, grid, semantics.
/// `camera` must match the image size. Throws pslam::Error naming `context` on an empty image or a size
/// mismatch between image and camera / semantic channel.
Frame makeFrame(const datasets::Frame& input, const geometry::PinholeCamera& camera, features::OrbExtractor& extractor,
                const std::string& context, features::OrbStageTimes* times = nullptr);

/// Same from already extracted (distorted) keypoints and descriptors (tests, synthetic frames).
Frame makeFrameFromFeatures(std::size_t index, double timestamp, const geometry::PinholeCamera& camera,
                            const std::vector<cv::KeyPoint>& distortedKeypoints, const cv::Mat& descriptors,
                            int numLevels, double scaleFactor, const cv::Mat& semantic = cv::Mat());

}  // namespace pslam::tracking
