#pragma once
// DSO-style selection of direct (photometric) points (thesis §2.3.2.3, Algorithm 3): pixels with a large
// intensity gradient relative to their neighbourhood, chosen block by block so that they cover the image,
// with lower thresholds for larger blocks so that weak-gradient regions still contribute.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/core/Params.h"

namespace pslam::features {

struct DirectSelectorParams {
  int targetPoints = 2000;
  /// W of Algorithm 3 for the first attempt; adapted to reach targetPoints. 0 = automatic: sqrt(area / target),
  /// the size at which one point per block gives the target (textured images fill nearly every block).
  int initialBlockSize = 0;
  float thresholdOffset = 7.f;
  float thresholdDecay = 0.75f;
  /// Re-runs with W rescaled by sqrt(found/target) while off by > 15 %; the W whose count is closest to the
  /// target is kept.
  int adaptIterations = 3;
  int border = 4;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, targetPoints, atLeast(1), "wanted number of points (N_F^Direct; Table 3.2 uses 5000)");
    PSLAM_FIELD(v, initialBlockSize, atLeast(0), "W of the first attempt (px); 0 = automatic");
    PSLAM_FIELD(v, thresholdOffset, atLeast(0), "delta_W: gradient (grey levels/px) above the block mean at size W");
    PSLAM_FIELD(v, thresholdDecay, inLeftOpen(0, 1), "delta_2W = decay * delta_W, delta_4W = decay^2 * delta_W");
    PSLAM_FIELD(v, adaptIterations, atLeast(0), "re-runs with a rescaled W");
    PSLAM_FIELD(v, border, atLeast(1), "pixels kept free at the image border (photometric pattern support)");
  }
  PSLAM_PARAMS("DirectPoints")
};

struct DirectPoint {
  cv::Point2i pixel;
  float gradient = 0;  ///< |grad I| (central differences) at the pixel
  int blockLevel = 0;  ///< 0: chosen in a W block, 1: in a 2W block, 2: in a 4W block
};

class DirectPointSelector {
 public:
  explicit DirectPointSelector(const DirectSelectorParams& params = {});
  /// Selects points in a grey CV_8UC1 image (colour is converted). Deterministic. Throws pslam::Error on empty
  /// or non-8-bit input. Points are ordered by block (row-major over the 4W blocks).
  std::vector<DirectPoint> select(const cv::Mat& image) const { return select(image, params_.targetPoints); }
  /// Same with an explicit target count.
  std::vector<DirectPoint> select(const cv::Mat& image, int targetPoints) const;
  /// Algorithm 3 over a pyramid (e.g. OrbExtractor::pyramid()): level l gets a share of targetPoints proportional
  /// to its area (sum over levels = targetPoints, at least 1 per level); points are in level-l pixels.
  std::vector<std::vector<DirectPoint>> selectPyramid(const std::vector<cv::Mat>& levels) const;
  /// One pass of Algorithm 3 with a fixed block size W (exposed for tests).
  std::vector<DirectPoint> selectWithBlockSize(const cv::Mat& gradient, const cv::Mat& gradientIntegral,
                                               int blockSize) const;
  /// |grad I| by central differences (CV_32FC1, 0 on the outermost pixel ring).
  static cv::Mat gradientMagnitude(const cv::Mat& grey);
  /// Block size actually used by the last select() call.
  int lastBlockSize() const { return lastBlockSize_; }
  const DirectSelectorParams& params() const { return params_; }

 private:
  DirectSelectorParams params_;
  mutable int lastBlockSize_ = 0;
};

}  // namespace pslam::features
