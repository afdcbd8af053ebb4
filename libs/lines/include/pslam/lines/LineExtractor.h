#pragma once
// Line segments of one image (thesis §2.3.2.2, Table 4.1): LSD detection on one resolution level, the
// N_F^Line longest segments, a binary LBD descriptor per segment (eq. 2.56, 256 bits as in PL-SLAM), endpoints
// undistorted with the project's camera model (geometry::PinholeCamera) so that every geometric step works on
// the ideal pinhole projection of eq. 2.7.
//
// Detection and description run on one level, the image resampled by detectionScale (INTER_AREA): LSD at 640x480
// costs about 40 ms of one core, at half resolution about 5 ms, LBD of 40 segments about 8 ms on the full image and
// 2 ms on the half one (doc/slam.md); the endpoints are scaled back to full-resolution pixels and their noise is
// that of the detection level (pixelSigma()).
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam::lines {

/// Detection and description of the segments of one frame ([Lines] keys, flattened).
struct LineExtractorParams {
  int maxLines = 40;             ///< N_F^Line of Table 4.1: the longest segments kept per frame
  double minLength = 30.0;       ///< full-resolution pixels: shorter segments are dropped
  double detectionScale = 0.5;   ///< LSD runs on the image resized by this factor (1 = full resolution)
  int lbdBandWidth = 7;          ///< LBD band width W (pixels of the detection level)

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, maxLines, atLeast(1), "longest LSD segments kept per frame (Table 4.1: 40)");
    PSLAM_FIELD(v, minLength, atLeast(0), "minimum segment length (full-resolution pixels)");
    PSLAM_FIELD(v, detectionScale, inLeftOpen(0, 1), "LSD runs on the image resized by this factor");
    PSLAM_FIELD(v, lbdBandWidth, inClosed(3, 15), "LBD band width (pixels of the detection level)");
  }
  PSLAM_PARAMS("Lines")
};

/// One segment, endpoints in undistorted full-resolution pixels.
struct LineSegment {
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  double length() const { return (end - start).norm(); }
  /// Unit direction start -> end.
  Eigen::Vector2d direction() const { return (end - start).normalized(); }
  Eigen::Vector2d midpoint() const { return 0.5 * (start + end); }
};

/// The segments of one image and their descriptors (row i = segment i, N x 32 CV_8U), longest first.
struct LineFeatures {
  std::vector<LineSegment> segments;
  cv::Mat descriptors;
  double pixelSigma = 1.0;  ///< endpoint noise (pixels) of the detection level
  std::size_t size() const { return segments.size(); }
  bool empty() const { return segments.empty(); }
};

class LineExtractor {
 public:
  /// Checks `params` and `camera` (pslam::Error naming the key).
  LineExtractor(const LineExtractorParams& params, const geometry::PinholeCamera& camera);
  /// Segments of `grey` (CV_8UC1, the camera's size, distorted as recorded). Throws pslam::Error on a wrong image.
  LineFeatures extract(const cv::Mat& grey) const;
  /// Endpoint noise of the detection level: 1 / detectionScale pixels (the sigma of an octave, as for ORB).
  double pixelSigma() const { return 1.0 / params_.detectionScale; }
  const LineExtractorParams& params() const { return params_; }

 private:
  LineExtractorParams params_;
  geometry::PinholeCamera camera_;
};

}  // namespace pslam::lines
