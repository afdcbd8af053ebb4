#pragma once
// Sub-pixel alignment of a keypoint to the image patch of its reference observation (SVO's "feature alignment",
// Forster et al. 2014, §5.2). A keypoint detected independently in two images sits on each image's pixel grid:
// between two views of one corner its position moves by about 0.8 pixels RMS at the keypoint's pyramid level
// (doc/features.md, match-oracle). Aligning the patch around the keypoint of one view to the other view, with the
// affine warp the two poses and the point's depth predict held fixed, measures the second position relative to the
// first to a fraction of a pixel: both observations then describe the same scene point.
//
// The model (forward-additive Gauss-Newton on the position p and a brightness offset o):
//   min_{p, o}  sum_y ( I(p + y) - T(y) - o )^2,   T(y) = I_ref(c_ref + A^-1 y),
// y over a (2h) x (2h) grid of the image's pixels around p, A = d(image level px) / d(reference level px).
// Pyramid levels are built by cv::resize (INTER_AREA) from level 0: level coordinates follow the resize's pixel-
// centre convention, x_level = (x_0 + 0.5) / ratio - 0.5.
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"

namespace pslam::features {

struct PatchAlignmentParams {
  int halfPatch = 4;             ///< h: the patch is 2h x 2h pixels (SVO: 8 x 8)
  int maxIterations = 10;        ///< Gauss-Newton iterations
  double convergence = 0.01;     ///< stop when the position update is below this (level pixels)
  double maxShift = 2.0;         ///< reject if the result is farther than this from the start (level pixels)
  double minZncc = 0.8;          ///< reject if the aligned patches correlate less (zero-mean NCC)
  double maxWarpScale = 2.0;     ///< reject if the warp's area scale |det A| is outside [1/this, this]

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, halfPatch, inClosed(2, 16), "half the patch side (pixels at the keypoint's level)");
    PSLAM_FIELD(v, maxIterations, atLeast(1), "Gauss-Newton iterations");
    PSLAM_FIELD(v, convergence, greaterThan(0), "stop below this position update (level px)");
    PSLAM_FIELD(v, maxShift, greaterThan(0), "largest accepted move from the detected position (level px)");
    PSLAM_FIELD(v, minZncc, inClosed(-1, 1), "smallest accepted zero-mean NCC of the aligned patches");
    PSLAM_FIELD(v, maxWarpScale, atLeast(1), "largest accepted area scale of the predicted warp (or its inverse)");
  }
};

/// An image and its pyramid levels at the ORB scale factors (level 0 = the image), with the exact level / level-0
/// coordinate maps. (optimize::ImagePyramid is the photometric error's float pyramid of halvings.)
class ScalePyramid {
 public:
  ScalePyramid() = default;
  /// `grey` CV_8UC1; level l is resized by 1 / scaleFactors[l] (scaleFactors[0] = 1). Throws pslam::Error on an
  /// empty or non-CV_8UC1 image or a scale factor < 1.
  ScalePyramid(const cv::Mat& grey, const std::vector<double>& scaleFactors);

  int numLevels() const { return static_cast<int>(levels_.size()); }
  const cv::Mat& level(int l) const { return levels_.at(l); }
  Eigen::Vector2d toLevel(const Eigen::Vector2d& level0, int l) const;
  Eigen::Vector2d toLevel0(const Eigen::Vector2d& atLevel, int l) const;
  /// Bytes of pixel data (all levels).
  std::size_t bytes() const;

 private:
  std::vector<cv::Mat> levels_;
  std::vector<Eigen::Vector2d> ratios_;  ///< level-0 pixels per level pixel, per axis
};

struct PatchAlignmentResult {
  bool accepted = false;      ///< converged, within maxShift, zncc >= minZncc, the patch inside the image
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< in the image's level pixels
  double zncc = 0.0;
  int iterations = 0;
};

/// The affine warp of a patch: where its centre lands in the image and A = d(image level px) / d(reference level px).
struct PatchWarp {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Matrix2d A = Eigen::Matrix2d::Identity();
};

/// Maps a reference level pixel to the image's level pixels; empty when it does not project (behind the camera).
using PixelTransfer = std::function<std::optional<Eigen::Vector2d>(const Eigen::Vector2d&)>;

/// The warp `transfer` predicts for the patch around `centre`, by forward differences over `step` reference pixels
/// (the patch's half side, so A describes the patch, not the point's infinitesimal neighbourhood). Empty when any
/// of the three pixels does not project.
std::optional<PatchWarp> patchWarpOf(const PixelTransfer& transfer, const Eigen::Vector2d& centre, double step);

/// Aligns the patch of `reference` (a pyramid level) around `referenceCentre` to `image`, starting at `start`,
/// with the affine warp `A` (image level px per reference level px) held fixed. Both images CV_8UC1.
PatchAlignmentResult alignPatch(const cv::Mat& reference, const Eigen::Vector2d& referenceCentre,
                                const Eigen::Matrix2d& A, const cv::Mat& image, const Eigen::Vector2d& start,
                                const PatchAlignmentParams& params);

}  // namespace pslam::features
