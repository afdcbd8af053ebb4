#pragma once
// ORB-SLAM's SearchByProjection (ORBmatcher.cc): map points are projected with a predicted pose into the frame,
// keypoints are looked up in a window whose radius grows with the pyramid level, the best descriptor (Hamming,
// eq. 2.18) is accepted under TH_HIGH and a ratio test, and a rotation histogram keeps only matches whose
// keypoint-angle change agrees with the majority (a frame-to-frame rotation is one angle for all points).
#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pslam/features/Matching.h"
#include "pslam/map/Map.h"
#include "pslam/tracking/Frame.h"

namespace pslam::tracking {

/// One map point to search for.
struct ProjectionCandidate {
  map::MapPointId id = map::kNoMapPoint;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  cv::Mat descriptor;        ///< 1 x 32 CV_8U
  int predictedLevel = 0;    ///< pyramid level the point should be seen at
  int minLevel = 0, maxLevel = 0;  ///< octave range of acceptable keypoints
  float radius = 0.f;        ///< search radius in level-0 pixels (already scaled by level)
  float referenceAngle = -1.f;  ///< keypoint angle where last seen (deg), < 0 = no rotation check for it
};

struct ProjectionSearchParams {
  int maxDistance = features::kOrbThHigh;  ///< TH_HIGH
  /// Ratio between best and second best; ORB-SLAM applies it (0.8) only when both lie on the same level in
  /// the local-map search, and not at all in the frame-to-frame search (ratio >= 1 disables it).
  float ratio = 1.0f;
  bool ratioOnlySameLevel = true;
  bool checkOrientation = true;  ///< rotation histogram (30 bins, three largest kept)
  int histogramBins = 30;
};

/// Matches candidates to the still unmatched keypoints of `frame` at pose T_cam_world (frame.T_cam_world is
/// not used). New matches are written into frame.mapPointIds (outlier flags cleared); a keypoint keeps its
/// first, best-scoring match only. Returns the number of new matches. Deterministic: candidates are processed
/// in the given order and ties keep the lowest keypoint index.
int searchByProjection(Frame& frame, const Eigen::Isometry3d& T_cam_world,
                       const std::vector<ProjectionCandidate>& candidates, const ProjectionSearchParams& params);

/// ORB-SLAM's PredictScale: level at which a point with scale-invariance maximum distance `maxDistance` is seen
/// at `distance`, clamped to [0, numLevels-1].
int predictLevel(double distance, double maxDistance, double scaleFactor, int numLevels);

/// ORB-SLAM's RadiusByViewingCos: wider windows for points seen obliquely.
float radiusByViewingCos(double viewCos);

}  // namespace pslam::tracking
