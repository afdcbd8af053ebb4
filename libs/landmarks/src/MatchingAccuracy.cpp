#include "pslam/landmarks/MatchingAccuracy.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::landmarks {

PSLAM_DEFINE_PARAMS(MatchingAccuracyParams)

double matchingAccuracyFromHamming(double hammingDistance, double maxDistance) {
  if (!(hammingDistance >= 0)) throw Error("matchingAccuracyFromHamming: distance must be >= 0");
  if (!(maxDistance > 0)) throw Error("matchingAccuracyFromHamming: d_max must be > 0");
  return 1.0 - std::min(1.0, hammingDistance / maxDistance);  // eq. 3.2
}

double matchingAccuracyFromDescriptors(const cv::Mat& descriptorI, const cv::Mat& descriptorJ, double maxDistance) {
  if (descriptorI.empty() || descriptorJ.empty() || descriptorI.type() != CV_8UC1 ||
      descriptorI.size() != descriptorJ.size() || descriptorI.type() != descriptorJ.type() || descriptorI.rows != 1)
    throw Error("matchingAccuracyFromDescriptors: descriptors must be two non-empty 1xN CV_8U rows of equal size");
  return matchingAccuracyFromHamming(cv::norm(descriptorI, descriptorJ, cv::NORM_HAMMING), maxDistance);
}

double photometricSsd(const cv::Mat& patchI, AffineExposure exposureI, const cv::Mat& patchJ,
                      AffineExposure exposureJ) {
  if (patchI.empty() || patchJ.empty() || patchI.size() != patchJ.size() || patchI.channels() != 1 ||
      patchJ.channels() != 1)
    throw Error("photometricSsd: patches must be non-empty single-channel images of equal size");
  if (!(std::isfinite(exposureI.a) && std::isfinite(exposureI.b) && std::isfinite(exposureJ.a) &&
        std::isfinite(exposureJ.b)))
    throw Error("photometricSsd: exposure parameters must be finite");
  cv::Mat fi, fj;
  patchI.convertTo(fi, CV_64F, std::exp(exposureI.a), exposureI.b);  // e^{a_i} Phi_i + b_i (eq. 3.5)
  patchJ.convertTo(fj, CV_64F, std::exp(exposureJ.a), exposureJ.b);
  const double ssd = cv::norm(fi, fj, cv::NORM_L2SQR);
  if (!std::isfinite(ssd)) throw Error("photometricSsd: patch contains NaN/Inf");
  return ssd;
}

double matchingAccuracyFromSsd(double ssd, double maxSsd) {
  if (!(ssd >= 0)) throw Error("matchingAccuracyFromSsd: SSD must be >= 0");
  if (!(maxSsd > 0)) throw Error("matchingAccuracyFromSsd: SSD_max must be > 0");
  return 1.0 - std::min(1.0, ssd / maxSsd);  // eq. 3.4
}

double matchingAccuracyPhotometric(const cv::Mat& imageI, cv::Point2f pointI, AffineExposure exposureI,
                                   const cv::Mat& imageJ, cv::Point2f pointJ, AffineExposure exposureJ,
                                   int halfWidth, int halfHeight, double maxSsd) {
  if (imageI.empty() || imageJ.empty() || imageI.channels() != 1 || imageJ.channels() != 1)
    throw Error("matchingAccuracyPhotometric: images must be non-empty grey images");
  if (halfWidth < 0 || halfHeight < 0) throw Error("matchingAccuracyPhotometric: negative patch half size");
  const cv::Size size(2 * halfWidth + 1, 2 * halfHeight + 1);
  if ((imageI.depth() != CV_8U && imageI.depth() != CV_32F) || (imageJ.depth() != CV_8U && imageJ.depth() != CV_32F))
    throw Error("matchingAccuracyPhotometric: images must be CV_8U or CV_32F");
  cv::Mat pi, pj;
  cv::getRectSubPix(imageI, size, pointI, pi, CV_32F);  // bilinear, border replicated
  cv::getRectSubPix(imageJ, size, pointJ, pj, CV_32F);
  return matchingAccuracyFromSsd(photometricSsd(pi, exposureI, pj, exposureJ), maxSsd);
}

}  // namespace pslam::landmarks
