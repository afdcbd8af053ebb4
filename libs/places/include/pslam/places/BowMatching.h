#pragma once
// Matching guided by the vocabulary's direct index (ORB-SLAM's SearchByBoW): only features that fall into the
// same vocabulary node are compared, instead of every pair.
#include <cstddef>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/features/Matching.h"
#include "pslam/places/BowTypes.h"

namespace pslam::places {

struct NodeMatchParams {
  int maxDistance = features::kOrbThLow;  ///< ORB-SLAM: TH_LOW
  float ratio = 0.75f;                    ///< best < ratio x second best (ORB-SLAM: 0.75 relocalization, 0.7 tracking)
  bool checkOrientation = true;           ///< rotation-histogram consistency (three largest bins)
  /// Throws pslam::Error naming the field: maxDistance in [0, 256], ratio in (0, 1].
  void check() const;
};

/// For every feature i of set 1 with use1(i) (in ascending node order, then ascending index), the best and second
/// best set-2 feature j of the same node with use2(j) that is not matched yet; accepted when the best distance is
/// <= maxDistance and < ratio x the second best, then j is taken. With checkOrientation, matches outside the three
/// largest bins of keypoint angle differences are dropped. Returns the matches sorted by i1. `use1` / `use2` may
/// be empty (all features). Throws pslam::Error when a feature index is outside its descriptors or keypoints.
std::vector<features::IndexMatch> matchByVocabularyNode(
    const FeatureVector& nodes1, const cv::Mat& descriptors1, const std::vector<cv::KeyPoint>& keypoints1,
    const FeatureVector& nodes2, const cv::Mat& descriptors2, const std::vector<cv::KeyPoint>& keypoints2,
    const NodeMatchParams& params, const std::function<bool(std::size_t)>& use1 = {},
    const std::function<bool(std::size_t)>& use2 = {});

}  // namespace pslam::places
