#pragma once
// Depth inlier ratio DR (thesis eq. 2.104, the "percentage of correct depth" of Tateno et al.): the share of
// map points whose relative depth error |d_est - d_gt| / d_gt is below tau.
//
// Input: a run's map-point depths as a text file, one observation per line
//     timestamp u v depth
// timestamp in seconds (the CAMERA stamp of the frame observing the point), (u, v) the pixel (column, row,
// 0-based, may be sub-pixel) in that frame, depth the estimated depth along the optical axis in the run's
// units (monocular runs: arbitrary scale, see `scale`). Blank lines and '#' comments are skipped.
// Ground truth: the DEPTH channel of the rawlog frame with the nearest CAMERA stamp (|dt| <= maxTimeDifference),
// read at the rounded pixel; a zero (invalid) GT depth or a pixel outside the image leaves the observation
// out of N and counts it as `withoutGroundTruth`.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/eval/Metrics.h"

namespace pslam::eval {

struct DepthSample {
  double timestamp = 0.0;
  double u = 0.0, v = 0.0;
  double depth = 0.0;
};

/// Throws pslam::Error naming file:line on a malformed line, a NaN/Inf, or a depth <= 0.
std::vector<DepthSample> readDepthSamples(const std::filesystem::path& path);

struct DepthRatioOptions {
  double tau = 0.1;                  ///< inlier threshold on the relative depth error (eq. 2.104)
  double scale = 1.0;                ///< multiplies estimated depths (the Sim(3) scale for monocular runs)
  double maxTimeDifference = 1e-3;   ///< seconds between a sample stamp and a rawlog frame stamp

  /// Keys of slam-eval's section (pslam/core/Params.h): dr_tau, dr_scale, dr_max_time_difference.
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_KEY(v, "dr_tau", tau, greaterThan(0), "DR inlier threshold on the relative depth error (eq. 2.104)");
    PSLAM_KEY(v, "dr_scale", scale, greaterThan(0), "multiplies estimated depths");
    PSLAM_KEY(v, "dr_max_time_difference", maxTimeDifference, atLeast(0),
              "[s] between a depth sample's stamp and a rawlog frame's stamp");
  }
  /// check() throws params::ParamError naming the key: tau > 0, scale > 0 (finite), maxTimeDifference >= 0.
  PSLAM_PARAMS("slam_eval")
};

/// Ground-truth depth of one frame.
struct DepthFrame {
  double timestamp = 0.0;
  cv::Mat depth;            ///< CV_16UC1, 0 = invalid
  double depthUnits = 0.0;  ///< metres per unit
};

struct DepthRatioResult {
  double ratio = 0.0;                 ///< DR = inliers / evaluated
  std::size_t inliers = 0, evaluated = 0, withoutGroundTruth = 0;
  ErrorStatistics relativeError;      ///< of |d_est - d_gt| / d_gt over the evaluated samples
  nlohmann::json toJson() const;
};

/// DR against depth frames in memory (frames need not be sorted). Throws pslam::Error if a sample has no
/// frame within maxTimeDifference (naming its stamp), or if no sample has a valid ground truth.
DepthRatioResult computeDepthRatio(const std::vector<DepthSample>& samples, const std::vector<DepthFrame>& frames,
                                   const DepthRatioOptions& options);

/// The DEPTH frames of a rawlog whose stamps are within maxTimeDifference of one of `timestamps`, read in one
/// pass (several runs on one rawlog share them: slam-batch collect). Throws pslam::Error naming the rawlog and
/// frame when a wanted frame has no DEPTH observation.
std::vector<DepthFrame> readDepthFrames(const std::filesystem::path& rawlog, std::vector<double> timestamps,
                                        double maxTimeDifference);

/// DR against the DEPTH channel of a rawlog (pslam::datasets::RawlogReader). Throws pslam::Error naming the
/// rawlog if it has no DEPTH channel at the needed frames.
DepthRatioResult computeDepthRatio(const std::vector<DepthSample>& samples, const std::filesystem::path& rawlog,
                                   const DepthRatioOptions& options);

}  // namespace pslam::eval
