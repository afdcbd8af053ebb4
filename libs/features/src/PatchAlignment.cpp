#include "pslam/features/PatchAlignment.h"

#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::features {

ScalePyramid::ScalePyramid(const cv::Mat& grey, const std::vector<double>& scaleFactors) {
  const char* ctx = "ScalePyramid";
  require(!grey.empty() && grey.type() == CV_8UC1, ctx, "the image must be a non-empty CV_8UC1");
  require(!scaleFactors.empty(), ctx, "no pyramid levels");
  for (double s : scaleFactors) require(std::isfinite(s) && s >= 1.0, ctx, "a scale factor is not >= 1");
  for (double s : scaleFactors) {
    if (s == 1.0) {
      levels_.push_back(grey);
      ratios_.emplace_back(1.0, 1.0);
      continue;
    }
    const cv::Size size(std::max(1, static_cast<int>(std::lround(grey.cols / s))),
                        std::max(1, static_cast<int>(std::lround(grey.rows / s))));
    cv::Mat level;
    cv::resize(grey, level, size, 0, 0, cv::INTER_AREA);
    levels_.push_back(level);
    ratios_.emplace_back(double(grey.cols) / size.width, double(grey.rows) / size.height);
  }
}

Eigen::Vector2d ScalePyramid::toLevel(const Eigen::Vector2d& level0, int l) const {
  const Eigen::Vector2d& r = ratios_.at(l);
  return {(level0.x() + 0.5) / r.x() - 0.5, (level0.y() + 0.5) / r.y() - 0.5};
}

Eigen::Vector2d ScalePyramid::toLevel0(const Eigen::Vector2d& atLevel, int l) const {
  const Eigen::Vector2d& r = ratios_.at(l);
  return {(atLevel.x() + 0.5) * r.x() - 0.5, (atLevel.y() + 0.5) * r.y() - 0.5};
}

std::size_t ScalePyramid::bytes() const {
  std::size_t n = 0;
  for (const cv::Mat& m : levels_) n += m.total() * m.elemSize();
  return n;
}

namespace {

/// Bilinear sample of a CV_8UC1 image; the caller keeps (x, y) at least one pixel inside the border.
inline double sample(const cv::Mat& img, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  const std::uint8_t* r0 = img.ptr<std::uint8_t>(y0) + x0;
  const std::uint8_t* r1 = img.ptr<std::uint8_t>(y0 + 1) + x0;
  return (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
}

/// Can every sample of a patch of half side `reach` around (x, y), with a one-pixel gradient margin, be taken?
inline bool inside(const cv::Mat& img, double x, double y, double reach) {
  return x - reach - 1 >= 0 && y - reach - 1 >= 0 && x + reach + 2 < img.cols && y + reach + 2 < img.rows;
}

}  // namespace

std::optional<PatchWarp> patchWarpOf(const PixelTransfer& transfer, const Eigen::Vector2d& centre, double step) {
  require(step > 0, "patchWarpOf", "the difference step must be > 0");
  const std::optional<Eigen::Vector2d> c = transfer(centre);
  const std::optional<Eigen::Vector2d> x = transfer(centre + Eigen::Vector2d(step, 0));
  const std::optional<Eigen::Vector2d> y = transfer(centre + Eigen::Vector2d(0, step));
  if (!c || !x || !y) return std::nullopt;
  PatchWarp w;
  w.centre = *c;
  w.A.col(0) = (*x - *c) / step;
  w.A.col(1) = (*y - *c) / step;
  return w;
}

PatchAlignmentResult alignPatch(const cv::Mat& reference, const Eigen::Vector2d& referenceCentre,
                                const Eigen::Matrix2d& A, const cv::Mat& image, const Eigen::Vector2d& start,
                                const PatchAlignmentParams& params) {
  PatchAlignmentResult res;
  res.position = start;
  require(reference.type() == CV_8UC1 && image.type() == CV_8UC1, "alignPatch", "images must be CV_8UC1");
  const double det = A.determinant();
  if (!std::isfinite(det) || std::abs(det) > params.maxWarpScale || std::abs(det) < 1.0 / params.maxWarpScale)
    return res;
  const Eigen::Matrix2d Ainv = A.inverse();
  const int h = params.halfPatch, n = 2 * h;
  // The reference patch in the image's pixel grid: T(y) = I_ref(c + A^-1 y), y = (-h + 0.5 .. h - 0.5)^2 so the
  // patch is centred on the point.
  const double reach = h * Ainv.cwiseAbs().rowwise().sum().maxCoeff();
  if (!inside(reference, referenceCentre.x(), referenceCentre.y(), reach)) return res;
  std::vector<double> T(n * n);
  std::vector<Eigen::Vector2d> offsets(n * n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const Eigen::Vector2d y(c - h + 0.5, r - h + 0.5);
      const Eigen::Vector2d x = referenceCentre + Ainv * y;
      offsets[r * n + c] = y;
      T[r * n + c] = sample(reference, x.x(), x.y());
    }

  Eigen::Vector2d p = start;
  double offset = 0.0;
  bool converged = false;
  for (int it = 0; it < params.maxIterations; ++it) {
    if (!inside(image, p.x(), p.y(), h)) return res;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int k = 0; k < n * n; ++k) {
      const double x = p.x() + offsets[k].x(), y = p.y() + offsets[k].y();
      const double I = sample(image, x, y);
      const Eigen::Vector3d J(0.5 * (sample(image, x + 1, y) - sample(image, x - 1, y)),
                              0.5 * (sample(image, x, y + 1) - sample(image, x, y - 1)), -1.0);
      const double r = I - T[k] - offset;
      H += J * J.transpose();
      g += J * r;
    }
    const Eigen::Vector3d delta = H.ldlt().solve(-g);
    if (!delta.allFinite()) return res;
    p += delta.head<2>();
    offset += delta.z();
    res.iterations = it + 1;
    if (delta.head<2>().norm() < params.convergence) {
      converged = true;
      break;
    }
  }
  res.position = p;
  if (!converged || (p - start).norm() > params.maxShift || !inside(image, p.x(), p.y(), h)) return res;
  // Zero-mean normalized cross-correlation of the aligned patches.
  double sumT = 0, sumI = 0, sumTT = 0, sumII = 0, sumTI = 0;
  for (int k = 0; k < n * n; ++k) {
    const double I = sample(image, p.x() + offsets[k].x(), p.y() + offsets[k].y());
    sumT += T[k];
    sumI += I;
    sumTT += T[k] * T[k];
    sumII += I * I;
    sumTI += T[k] * I;
  }
  const double m = n * n;
  const double varT = sumTT - sumT * sumT / m, varI = sumII - sumI * sumI / m;
  res.zncc = (varT > 0 && varI > 0) ? (sumTI - sumT * sumI / m) / std::sqrt(varT * varI) : 0.0;
  res.accepted = res.zncc >= params.minZncc;
  return res;
}

}  // namespace pslam::features
