#pragma once
// ORB features as extracted by ORB-SLAM (thesis §2.3.2.1, Table 3.2): a scale pyramid, FAST corners found per
// ~30 px grid cell with an initial threshold and a lower fallback threshold, a quadtree that spreads the
// corners evenly over each level (keeping the strongest corner per node), the intensity-centroid orientation
// (eqs. 2.13-2.14) and the 256-bit steered BRIEF descriptor (eq. 2.15) on the Gaussian-blurred level image.
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "pslam/core/Params.h"

namespace pslam::features {

/// Extractor parameters ([ORB]). Defaults are ORB-SLAM's (and Table 3.2 apart from N_F, which the thesis raises
/// to 5000).
struct OrbParams {
  int nFeatures = 2000;
  double scaleFactor = 1.2;
  int nLevels = 8;
  int iniThFAST = 20;
  int minThFAST = 7;
  int edgeThreshold = 19;
  int patchSize = 31;
  int cellSize = 30;
  /// Per-level budget: false = ORB-SLAM's geometric series with ratio 1/scaleFactor; true = ratio
  /// 1/scaleFactor^2 (strictly proportional to the level area).
  bool levelBudgetByArea = false;
  /// true: one cv::FAST call per cell exactly as ORB-SLAM (reference, slower); false: one FAST call per level
  /// at iniThFAST, per-cell fallback to minThFAST only in cells without a corner (same thresholds per cell).
  bool literalCellFast = false;
  /// Threads that share out the pyramid levels (detection, orientation, descriptors; 1 = the calling thread
  /// only). The output does not depend on it: each level is computed alone and the levels are joined in order.
  int threads = 2;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    // The upper bound keeps featureFactor x nFeatures (the initializer's budget) and the per-level budgets
    // within int.
    PSLAM_FIELD(v, nFeatures, inClosed(1, 1000000), "target number of keypoints over all levels (N_F^Descr)");
    PSLAM_FIELD(v, scaleFactor, inOpen(1, 4), "scale between consecutive pyramid levels (s_L^Descr)");
    PSLAM_FIELD(v, nLevels, inClosed(1, 32), "number of pyramid levels (N_L^Descr)");
    PSLAM_FIELD(v, iniThFAST, inOpen(0, 255), "FAST threshold tried first in every cell (tau_init^Descr)");
    PSLAM_FIELD(v, minThFAST, satisfies([this](int t) { return t > 0 && t <= iniThFAST; }, "must be in (0, iniThFAST]"),
                "FAST threshold of a cell where the initial one finds nothing (tau_min^Descr)");
    // Keypoints keep edgeThreshold-3 px from the level edge and the padding is edgeThreshold px: the circular
    // orientation patch (radius 15) must fit inside the level and the rotated BRIEF tests (reach <= 19 px incl.
    // the 7x7 blur) inside level + padding.
    PSLAM_FIELD(v, edgeThreshold,
                satisfies([this](int e) { return e >= patchSize / 2 + 4; }, "must be >= patchSize / 2 + 4"),
                "border (px) padded around each level; keypoints keep edgeThreshold-3 px from the edge");
    // The learned rBRIEF test pattern is defined on a 31x31 patch; other sizes would silently rescale it.
    PSLAM_FIELD(v, patchSize, satisfies([](int p) { return p == 31; }, "must be 31, the size of the rBRIEF pattern"),
                "orientation/descriptor patch (px)");
    PSLAM_FIELD(v, cellSize, atLeast(8), "FAST grid cell size in level pixels (ORB-SLAM's W)");
    PSLAM_FIELD(v, levelBudgetByArea, anyValue, "per-level budget proportional to the level area");
    PSLAM_FIELD(v, literalCellFast, anyValue, "one cv::FAST call per cell as ORB-SLAM (reference, slower)");
    PSLAM_FIELD(v, threads, inClosed(1, 64), "threads sharing out the pyramid levels (the output is the same for any)");
  }
  PSLAM_PARAMS("ORB")
};

/// Milliseconds spent in one extract() call. The pyramid and the whole per-level part (`levels`) as wall-clock
/// time and as CPU time of the whole process (all threads, incl. OpenCV's workers; on a loaded machine a better
/// estimate of the unloaded cost). The levels are shared out over OrbParams::threads, so the three per-level
/// stages are the work summed over the levels: wall-clock time each level spent in the stage on its thread, and
/// that thread's CPU time; with one thread they add up to `levels`.
struct OrbStageTimes {
  double pyramidMs = 0;      ///< building the padded scale pyramid
  double levelsMs = 0;       ///< detection, orientation and descriptors of all levels, wall-clock
  double detectMs = 0;       ///< per-cell FAST + quadtree distribution, summed over the levels
  double orientationMs = 0;  ///< intensity-centroid angles, summed over the levels
  double descriptorMs = 0;   ///< Gaussian blur + steered BRIEF, summed over the levels
  double pyramidCpuMs = 0, levelsCpuMs = 0;                      ///< process CPU
  double detectCpuMs = 0, orientationCpuMs = 0, descriptorCpuMs = 0;  ///< CPU of the threads doing the stage
  double totalMs() const { return pyramidMs + levelsMs; }
  double totalCpuMs() const { return pyramidCpuMs + levelsCpuMs; }
};

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbParams& params = OrbParams());

  /// Extracts keypoints and descriptors from a grey (CV_8UC1) or colour (CV_8UC3 BGR / CV_8UC4 BGRA) image.
  /// Keypoints are in level-0 pixel coordinates, grouped by level (level 0 first); `octave` = pyramid level,
  /// `angle` in degrees [0,360) in image axes (x right, y down), `size` = patchSize * scaleFactor(level),
  /// `response` = FAST score. descriptors: CV_8UC1, N x 32, row i belongs to keypoint i.
  /// Deterministic: the same image always gives the same output, for any number of threads. Throws pslam::Error
  /// on empty or unsupported images. Not thread-safe (reuses its pyramid buffers); use one extractor per thread.
  void extract(const cv::Mat& image, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
               OrbStageTimes* times = nullptr);

  const OrbParams& params() const { return params_; }
  /// scale of level l relative to level 0 (scaleFactor^l); level-0 coordinates = level coordinates * scale.
  const std::vector<float>& scaleFactors() const { return scale_; }
  const std::vector<float>& inverseScaleFactors() const { return invScale_; }
  /// Measurement variance factor per level, sigma^2 = scale^2 (used to weight reprojection errors).
  const std::vector<float>& levelSigma2() const { return sigma2_; }
  const std::vector<float>& inverseLevelSigma2() const { return invSigma2_; }
  /// Target number of keypoints per level (sums to nFeatures).
  const std::vector<int>& featuresPerLevel() const { return featuresPerLevel_; }
  /// Level images of the last extract() call (views into padded buffers, so each has an edgeThreshold
  /// border of reflected pixels available around it). Size of level l = round(size0 / scale_l).
  const std::vector<cv::Mat>& pyramid() const { return pyramid_; }

  /// ORB-SLAM's quadtree distribution (exposed for tests): keeps at most ~`target` keypoints spread over the
  /// rectangle [minX,maxX) x [minY,maxY), one per quadtree leaf, the one with the largest response. Keypoint
  /// coordinates must be relative to (minX, minY). Ties are broken by position, so the result is deterministic.
  static std::vector<cv::KeyPoint> distributeQuadtree(const std::vector<cv::KeyPoint>& keypoints, int minX,
                                                      int maxX, int minY, int maxY, int target);

  /// Intensity-centroid orientation (eqs. 2.13-2.14) in degrees [0,360) of the circular patch of radius
  /// patchSize/2 centred at integer pixel `pt` of `image` (CV_8UC1); the patch must lie inside the image
  /// memory (pyramid levels have a border for this).
  float intensityCentroidAngle(const cv::Mat& image, cv::Point2f pt) const;

 private:
  void buildPyramid(const cv::Mat& grey);
  void detectLevel(int level, std::vector<cv::KeyPoint>& out) const;
  struct LevelOutput;
  /// Detection, orientation and descriptors of one level (keypoints in level-0 pixels); reads only the
  /// pyramid, so levels can be processed on different threads, each with its own describer.
  void processLevel(int level, cv::ORB& describer, LevelOutput& out) const;

  OrbParams params_;
  std::vector<float> scale_, invScale_, sigma2_, invSigma2_;
  std::vector<int> featuresPerLevel_;
  std::vector<int> umax_;  ///< half-width of the circular patch per row offset v (ORB-SLAM's umax)
  std::vector<cv::Mat> padded_;
  std::vector<cv::Mat> pyramid_;
  /// OpenCV's steered-BRIEF code, fed our keypoints and angles: one per thread (OpenCV does not promise that
  /// one cv::ORB may compute on two threads at once).
  std::vector<cv::Ptr<cv::ORB>> describers_;
};

}  // namespace pslam::features
