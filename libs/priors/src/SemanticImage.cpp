#include "pslam/priors/SemanticImage.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::priors {

cv::Mat semanticFromLabels(const cv::Mat& labels, const SemanticClassMap& map) {
  if (labels.empty() || labels.type() != CV_8UC1)
    throw Error("semanticFromLabels: label image must be a non-empty 8-bit single-channel image");
  // One 3-channel lookup: label v -> 255 in the channel of its group, 0 elsewhere (one-hot).
  cv::Mat lut(1, 256, CV_8UC3, cv::Scalar::all(0));
  for (int v = 0; v < 256; ++v) lut.at<cv::Vec3b>(v)[static_cast<int>(map.groupOf(v))] = 255;
  cv::Mat labels3, semantic;
  cv::merge(std::vector<cv::Mat>{labels, labels, labels}, labels3);
  cv::LUT(labels3, lut, semantic);
  return semantic;
}

cv::Mat groupProbabilitiesFromScores(const cv::Mat& scores, const SemanticClassMap& map, bool applySoftmax) {
  if (scores.dims != 4 || scores.size[0] != 1 || scores.type() != CV_32F)
    throw Error("groupProbabilitiesFromScores: expected a 1 x C x H x W CV_32F blob");
  const int C = scores.size[1], H = scores.size[2], W = scores.size[3];
  if (C != map.numClasses())
    throw Error("groupProbabilitiesFromScores: network has " + std::to_string(C) + " output classes, class map '" +
                map.name + "' has " + std::to_string(map.numClasses()));
  // Whole-plane OpenCV operations (vectorized): softmax shifted by the per-pixel maximum score, so exp never
  // overflows; without softmax the (non-negative) outputs are only normalized.
  std::vector<cv::Mat> planes(C);
  for (int c = 0; c < C; ++c)
    planes[c] = cv::Mat(H, W, CV_32F, const_cast<float*>(scores.ptr<float>()) + std::size_t(c) * H * W);
  cv::Mat maxScore = planes[0].clone();
  for (int c = 1; c < C; ++c) cv::max(maxScore, planes[c], maxScore);
  std::vector<cv::Mat> group(kNumSemanticGroups);
  for (auto& g : group) g = cv::Mat(H, W, CV_32F, cv::Scalar(0));
  cv::Mat sum(H, W, CV_32F, cv::Scalar(0)), e;
  for (int c = 0; c < C; ++c) {
    if (applySoftmax) {
      cv::subtract(planes[c], maxScore, e);
      cv::exp(e, e);
    } else {
      cv::max(planes[c], 0.0, e);
    }
    sum += e;
    group[static_cast<int>(map.groups[c])] += e;
  }
  if (!cv::checkRange(sum) || !cv::checkRange(maxScore))
    throw Error("groupProbabilitiesFromScores: non-finite network scores");
  double minSum = 0;
  cv::minMaxLoc(sum, &minSum);
  if (!(minSum > 0)) throw Error("groupProbabilitiesFromScores: all-zero class scores at some pixel");
  for (auto& g : group) cv::divide(g, sum, g);
  cv::Mat probs;
  cv::merge(group, probs);
  return probs;
}

std::vector<double> argmaxClassHistogram(const cv::Mat& scores) {
  if (scores.dims != 4 || scores.size[0] != 1 || scores.type() != CV_32F)
    throw Error("argmaxClassHistogram: expected a 1 x C x H x W CV_32F blob");
  const int C = scores.size[1];
  const std::size_t plane = std::size_t(scores.size[2]) * scores.size[3];
  const float* data = scores.ptr<float>();
  std::vector<double> hist(C, 0.0);
  for (std::size_t i = 0; i < plane; ++i) {
    int best = 0;
    for (int c = 1; c < C; ++c)
      if (data[c * plane + i] > data[best * plane + i]) best = c;
    hist[best] += 1.0;
  }
  for (double& h : hist) h /= double(plane);
  return hist;
}

cv::Mat encodeSemantic(const cv::Mat& groupProbabilities, cv::Size size) {
  if (groupProbabilities.empty() || groupProbabilities.type() != CV_32FC3)
    throw Error("encodeSemantic: expected CV_32FC3 group probabilities");
  cv::Mat resized;
  if (groupProbabilities.size() == size)
    resized = groupProbabilities;
  else
    cv::resize(groupProbabilities, resized, size, 0, 0, cv::INTER_LINEAR);
  cv::Mat semantic;
  resized.convertTo(semantic, CV_8UC3, 255.0);  // saturate_cast rounds to nearest: round(255 p)
  return semantic;
}

std::array<double, kNumSemanticGroups> semanticHistogram(const cv::Mat& semantic) {
  if (semantic.empty() || semantic.type() != CV_8UC3)
    throw Error("semanticHistogram: SEMANTIC channel must be a non-empty CV_8UC3 image");
  const cv::Scalar mean = cv::mean(semantic);
  return {mean[0] / 255.0, mean[1] / 255.0, mean[2] / 255.0};
}

cv::Mat semanticOverlay(const cv::Mat& image, const cv::Mat& semantic, double opacity) {
  if (semantic.empty() || semantic.type() != CV_8UC3)
    throw Error("semanticOverlay: SEMANTIC channel must be a non-empty CV_8UC3 image");
  if (image.empty() || image.size() != semantic.size() || image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3))
    throw Error("semanticOverlay: image must be 8-bit grey or BGR of the SEMANTIC channel's size");
  cv::Mat bgr;
  if (image.channels() == 1)
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  else
    bgr = image;
  // Colour of a pixel = sum_k P(k) * colour_k with BGR colours static = green, dynamic = red, invalid = blue.
  const cv::Matx33f toBgr(0, 0, 1,   // B <- invalid
                          1, 0, 0,   // G <- static
                          0, 1, 0);  // R <- dynamic
  cv::Mat colour;
  cv::transform(semantic, colour, toBgr);
  cv::Mat out;
  cv::addWeighted(bgr, 1.0 - opacity, colour, opacity, 0.0, out);
  return out;
}

}  // namespace pslam::priors
