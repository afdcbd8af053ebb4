#pragma once
// Small helpers shared by the direct front end's sources (not installed).
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/optimize/PhotometricError.h"

namespace pslam::direct::detail {

/// Indices 0..n-1 thinned to at most `cap`, evenly (deterministic).
inline std::vector<std::size_t> evenSubset(std::size_t n, std::size_t cap) {
  std::vector<std::size_t> out;
  if (n <= cap) {
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = i;
    return out;
  }
  out.reserve(cap);
  for (std::size_t k = 0; k < cap; ++k) out.push_back(k * n / cap);
  return out;
}

/// Median (upper middle element) of a non-empty vector, which is reordered.
inline double medianOf(std::vector<double>& v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Median and median absolute deviation of `v` (reordered).
inline std::pair<double, double> medianAndMad(std::vector<double>& v) {
  const double med = medianOf(v);
  for (double& x : v) x = std::abs(x - med);
  return {med, medianOf(v)};
}

/// Sum over the pattern of the squared difference of the exposure-normalized intensities (eq. 3.5): host
/// intensities (level 0) against the target image sampled around `pixel`.
inline double patternSsdAt(const optimize::DirectLandmark& point, const optimize::AffineBrightness& hostAffine,
                    const cv::Mat& targetLevel0, const Eigen::Vector2d& pixel, const optimize::AffineBrightness& targetAffine) {
  if (!point.usableAt(0)) return std::numeric_limits<double>::infinity();
  double ssd = 0.0;
  for (int k = 0; k < optimize::kPatternSize; ++k) {
    const double x = pixel.x() + optimize::kDirectPattern[static_cast<std::size_t>(k)][0];
    const double y = pixel.y() + optimize::kDirectPattern[static_cast<std::size_t>(k)][1];
    if (!optimize::insideBilinear(targetLevel0, x, y)) return std::numeric_limits<double>::infinity();
    const double host = std::exp(-hostAffine.a) * (point.hostIntensities[0][static_cast<std::size_t>(k)] - hostAffine.b);
    const double target = std::exp(-targetAffine.a) * (optimize::sampleBilinear(targetLevel0, x, y) - targetAffine.b);
    ssd += (host - target) * (host - target);
  }
  return ssd;
}

}  // namespace pslam::direct::detail
