#pragma once
// Intensity images for the photometric error (thesis §2.3.2.3, eq. 2.64): a grey image as floats in [0, 1]
// (the range in which Table 3.2 states the direct-feature thresholds), its pyramid for the coarse-to-fine
// alignment of §3.4.2, and bilinear sampling with the derivative of the interpolant (the image gradient the
// analytic Jacobians use). Works for doubles and ceres::Jet, so automatic differentiation sees the same
// interpolant as the analytic Jacobians.
//
// Pyramid: level l+1 is the mean of 2x2 blocks of level l (DSO's pyramid), so pixel centres map as
//   x_l = (x_0 + 0.5) / 2^l - 0.5      and the intrinsics as fx_l = fx / 2^l, cx_l = (cx + 0.5) / 2^l - 0.5.
#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <ceres/jet.h>
#include <opencv2/core.hpp>

#include "pslam/map/Types.h"

namespace pslam::optimize {

class ImagePyramid {
 public:
  ImagePyramid() = default;
  /// Builds `levels` (>= 1) levels from a grey CV_8UC1 image (intensity / 255) or a CV_32FC1 image already in
  /// [0, 1]. An odd last row/column is dropped when halving. Throws pslam::Error on an empty or other-type
  /// image, levels < 1, or a level that would be smaller than 8 x 8 pixels.
  ImagePyramid(const cv::Mat& grey, int levels);

  int levels() const { return static_cast<int>(levels_.size()); }
  /// Level l as CV_32FC1 in [0, 1] (level 0 = full resolution). Throws pslam::Error for a bad level.
  const cv::Mat& level(int l) const;

 private:
  std::vector<cv::Mat> levels_;
};

/// Intrinsics of pyramid level `level` (see the header comment).
geometry::PinholeCamera levelCamera(const geometry::PinholeCamera& camera, int level);
/// A level-0 pixel in level-`level` pixels.
Eigen::Vector2d levelPixel(const Eigen::Vector2d& pixel0, int level);

/// True when bilinear interpolation at (x, y) uses pixels of the image only: 0 <= x <= cols-1, same for y.
inline bool insideBilinear(const cv::Mat& image, double x, double y) {
  return x >= 0.0 && y >= 0.0 && x <= image.cols - 1.0 && y <= image.rows - 1.0;
}

/// Bilinear intensity of a CV_32FC1 image at (x, y), pixel centres at integer coordinates, the coordinates
/// clamped into the image (beyond the border the value is constant and its derivative zero). When `dIdx` is
/// given, the derivative of the interpolant: ((1-fy)(I10-I00) + fy(I11-I01), (1-fx)(I01-I00) + fx(I11-I10)).
inline double sampleBilinear(const cv::Mat& image, double x, double y, Eigen::Vector2d* dIdx = nullptr) {
  const double maxX = image.cols - 1.0, maxY = image.rows - 1.0;
  const bool clampX = !(x > 0.0 && x < maxX), clampY = !(y > 0.0 && y < maxY);
  if (clampX) x = x > 0.0 ? maxX : 0.0;  // NaN goes to 0
  if (clampY) y = y > 0.0 ? maxY : 0.0;
  int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  if (x0 >= image.cols - 1) x0 = image.cols - 2;  // x == maxX: interpolate in the last cell with fx = 1
  if (y0 >= image.rows - 1) y0 = image.rows - 2;
  const double fx = x - x0, fy = y - y0;
  const float* r0 = image.ptr<float>(y0) + x0;
  const float* r1 = image.ptr<float>(y0 + 1) + x0;
  const double i00 = r0[0], i10 = r0[1], i01 = r1[0], i11 = r1[1];
  if (dIdx) {
    dIdx->x() = clampX ? 0.0 : (1.0 - fy) * (i10 - i00) + fy * (i11 - i01);
    dIdx->y() = clampY ? 0.0 : (1.0 - fx) * (i01 - i00) + fx * (i11 - i10);
  }
  return (1.0 - fy) * ((1.0 - fx) * i00 + fx * i10) + fy * ((1.0 - fx) * i01 + fx * i11);
}

/// The same for ceres::Jet coordinates: value at the scalar parts, derivative by the chain rule.
template <typename T, int N>
ceres::Jet<T, N> sampleBilinear(const cv::Mat& image, const ceres::Jet<T, N>& x, const ceres::Jet<T, N>& y) {
  Eigen::Vector2d g;
  const double v = sampleBilinear(image, x.a, y.a, &g);
  ceres::Jet<T, N> out(v);
  out.v = g.x() * x.v + g.y() * y.v;
  return out;
}

}  // namespace pslam::optimize
