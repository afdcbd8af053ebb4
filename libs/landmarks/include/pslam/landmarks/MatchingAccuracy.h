#pragma once
// Matching accuracy alpha in [0, 1] of one correspondence (§3.2): it weighs each depth and semantic
// measurement in the keypoint model (eq. 3.7, 3.9).
#include <string>

#include <opencv2/core.hpp>

#include "pslam/core/Params.h"

namespace pslam::landmarks {

struct MatchingAccuracyParams {
  /// d_max of eq. 3.2 (bits). Default: ORB-SLAM's TH_HIGH = 100, the distance above which it rejects a match.
  double hammingMaxDistance = 100.0;
  /// Delta Phi_max of eq. 3.4 (grey levels^2 summed over the patch). Not given in the thesis; default
  /// 9 pixels x 20^2 (the 9-pixel DSO pattern of Table 3.2 at 20 grey levels RMS difference).
  double photometricMaxSsd = 9.0 * 20.0 * 20.0;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, hammingMaxDistance, greaterThan(0), "d_max of eq. 3.2 (bits)");
    PSLAM_FIELD(v, photometricMaxSsd, greaterThan(0), "Delta Phi_max of eq. 3.4 (grey levels^2 over the patch)");
  }
  PSLAM_PARAMS("PointModel")
};

/// eq. 3.2: alpha_desc = 1 - min(1, d / d_max). Throws pslam::Error for d < 0 or d_max <= 0.
double matchingAccuracyFromHamming(double hammingDistance, double maxDistance);
/// eq. 3.2 for two binary descriptors (1 x N CV_8U rows, e.g. 32-byte ORB); Hamming distance via cv::norm.
double matchingAccuracyFromDescriptors(const cv::Mat& descriptorI, const cv::Mat& descriptorJ, double maxDistance);

/// Affine brightness transfer of one frame (DSO, §2.3.2.3): I' = exp(a) * I + b.
struct AffineExposure {
  double a = 0.0;
  double b = 0.0;
};

/// eq. 3.5: SSD between the exposure-corrected patches, sum (e^{a_i} P_i + b_i - e^{a_j} P_j - b_j)^2.
/// Patches: same size, one channel, CV_8U or CV_32F. Throws pslam::Error on empty / mismatched patches.
double photometricSsd(const cv::Mat& patchI, AffineExposure exposureI, const cv::Mat& patchJ,
                      AffineExposure exposureJ);
/// eq. 3.4: alpha_dir = 1 - min(1, SSD / SSD_max).
double matchingAccuracyFromSsd(double ssd, double maxSsd);
/// Samples (2*halfWidth+1) x (2*halfHeight+1) patches centred at sub-pixel points of two grey images
/// (bilinear, cv::getRectSubPix) and returns eq. 3.4 of their eq. 3.5 SSD.
double matchingAccuracyPhotometric(const cv::Mat& imageI, cv::Point2f pointI, AffineExposure exposureI,
                                   const cv::Mat& imageJ, cv::Point2f pointJ, AffineExposure exposureJ,
                                   int halfWidth, int halfHeight, double maxSsd);

}  // namespace pslam::landmarks
