#pragma once
// Conversions into the SEMANTIC channel of the rawlog contract (CV_8UC3, channel k = round(255 * P(class k)),
// k = static, dynamic, invalid) and views of it for inspection.
#include <array>

#include <opencv2/core.hpp>

#include "pslam/priors/SemanticClassMap.h"

namespace pslam::priors {

/// One-hot SEMANTIC image from an 8-bit label image (CV_8UC1) through `map`. Throws pslam::Error on an
/// empty or non-8-bit single-channel image.
cv::Mat semanticFromLabels(const cv::Mat& labels, const SemanticClassMap& map);

/// Group probabilities (CV_32FC3, HxW) from network scores, a 4-D blob 1 x C x H x W (CV_32F) with
/// C = map.numClasses(): optional softmax over the C classes, then the class probabilities are summed into
/// their Table 3.1 groups. Throws pslam::Error on a shape mismatch or non-finite scores.
cv::Mat groupProbabilitiesFromScores(const cv::Mat& scores, const SemanticClassMap& map, bool applySoftmax);

/// Per-class fraction of pixels whose arg-max over the C channels of `scores` is that class.
std::vector<double> argmaxClassHistogram(const cv::Mat& scores);

/// Resizes CV_32FC3 group probabilities to `size` (bilinear) and encodes round(255 p) as CV_8UC3.
cv::Mat encodeSemantic(const cv::Mat& groupProbabilities, cv::Size size);

/// Mean P(class k) over the image of a SEMANTIC channel (the soft class histogram).
std::array<double, kNumSemanticGroups> semanticHistogram(const cv::Mat& semantic);

/// Colour overlay for inspection: static green, dynamic red, invalid blue, each weighted by its probability,
/// blended with the (grey or colour) image with `opacity`. Returns CV_8UC3 BGR.
cv::Mat semanticOverlay(const cv::Mat& image, const cv::Mat& semantic, double opacity = 0.5);

}  // namespace pslam::priors
