// Matching accuracies (eq. 3.2, 3.4-3.5) and the measurement variance (eq. 2.24-2.29) against direct
// computations and brute-force ray intersection.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/core/Error.h"
#include "pslam/landmarks/MatchingAccuracy.h"
#include "pslam/landmarks/MeasurementVariance.h"

using namespace pslam::landmarks;

TEST(MatchingAccuracy, HammingEq32) {
  EXPECT_DOUBLE_EQ(matchingAccuracyFromHamming(0, 100), 1.0);
  EXPECT_DOUBLE_EQ(matchingAccuracyFromHamming(25, 100), 0.75);
  EXPECT_DOUBLE_EQ(matchingAccuracyFromHamming(180, 100), 0.0);
  EXPECT_THROW(matchingAccuracyFromHamming(-1, 100), pslam::Error);
  EXPECT_THROW(matchingAccuracyFromHamming(1, 0), pslam::Error);
  // 32-byte descriptors differing in a known number of bits.
  cv::Mat di(1, 32, CV_8U, cv::Scalar(0)), dj = di.clone();
  dj.at<uchar>(0, 0) = 0xFF;  // 8 bits
  dj.at<uchar>(0, 5) = 0x03;  // 2 bits
  EXPECT_DOUBLE_EQ(matchingAccuracyFromDescriptors(di, dj, 100), 0.9);
  EXPECT_THROW(matchingAccuracyFromDescriptors(di, cv::Mat(1, 16, CV_8U, cv::Scalar(0)), 100), pslam::Error);
}

TEST(MatchingAccuracy, PhotometricSsdWithAffineExposureEq35) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> grey(20, 200);
  cv::Mat pi(3, 3, CV_64F);
  for (int i = 0; i < 9; ++i) pi.at<double>(i) = grey(rng);
  const AffineExposure ei{0.1, 5.0}, ej{-0.2, -3.0};
  // Patch j seen through exposure j renders the same radiance as patch i through exposure i.
  cv::Mat pj = (pi * std::exp(ei.a) + ei.b - ej.b) / std::exp(ej.a);
  cv::Mat fi, fj;
  pi.convertTo(fi, CV_32F);
  pj.convertTo(fj, CV_32F);
  EXPECT_NEAR(photometricSsd(fi, ei, fj, ej), 0.0, 1e-6);
  EXPECT_NEAR(matchingAccuracyFromSsd(photometricSsd(fi, ei, fj, ej), 3600), 1.0, 1e-9);
  // A constant offset of 10 grey levels after correction: SSD = 9 * 100.
  cv::Mat pk = pj + 10.0 / std::exp(ej.a);
  cv::Mat fk;
  pk.convertTo(fk, CV_32F);
  EXPECT_NEAR(photometricSsd(fi, ei, fk, ej), 900.0, 1e-2);
  EXPECT_NEAR(matchingAccuracyFromSsd(900, 3600), 0.75, 1e-12);
  EXPECT_EQ(matchingAccuracyFromSsd(1e6, 3600), 0.0);
  EXPECT_THROW(photometricSsd(fi, ei, cv::Mat(), ej), pslam::Error);
  EXPECT_THROW(photometricSsd(fi, ei, cv::Mat(4, 4, CV_32F), ej), pslam::Error);
}

TEST(MatchingAccuracy, PhotometricOnImagesAtSubpixelPositions) {
  cv::Mat img(40, 40, CV_8U);
  cv::randu(img, 0, 255);
  const cv::Mat shifted = img(cv::Rect(3, 2, 30, 30)).clone();  // shifted(y, x) = img(y+2, x+3)
  EXPECT_NEAR(matchingAccuracyPhotometric(img, {20.f, 20.f}, {}, shifted, {17.f, 18.f}, {}, 2, 2, 3600), 1.0, 1e-9);
  EXPECT_LT(matchingAccuracyPhotometric(img, {20.f, 20.f}, {}, shifted, {10.f, 10.f}, {}, 2, 2, 3600), 0.5);
}

namespace {
// Brute force: rotate the current ray by the pixel angle in the epipolar plane (away from the baseline) and
// intersect it with the reference ray by least squares.
double bruteForceRangePlus(const Eigen::Vector3d& f, double range, const Eigen::Vector3d& t, double angle) {
  const Eigen::Vector3d X = f * range;
  Eigen::Vector3d u = (X - t).normalized();
  Eigen::Vector3d axis = u.cross(-t).normalized();  // rotating about it by -angle increases the angle to -t
  Eigen::Vector3d up = Eigen::AngleAxisd(-angle, axis) * u;
  if (std::acos(up.dot(-t.normalized())) < std::acos(u.dot(-t.normalized()))) up = Eigen::AngleAxisd(angle, axis) * u;
  Eigen::Matrix<double, 3, 2> A;
  A.col(0) = f;
  A.col(1) = -up;
  const Eigen::Vector2d sr = A.colPivHouseholderQr().solve(t);
  return sr(0);
}
}  // namespace

TEST(MeasurementVariance, MatchesBruteForceRayIntersection) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  const double focal = 500.0;
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d f = Eigen::Vector3d(0.3 * u(rng), 0.3 * u(rng), 1.0).normalized();
    const double range = 2.0 + 8.0 * (u(rng) + 1);
    const Eigen::Vector3d t(0.5 * u(rng), 0.1 * u(rng), 0.3 * u(rng));
    const DepthUncertainty du = depthUncertainty(f, range, t, focal, 1.0);
    if (!du.valid) continue;
    ++checked;
    const double rangePlus = bruteForceRangePlus(f, range, t, std::atan(1.0 / focal));
    EXPECT_NEAR(du.tauRange, rangePlus - range, 1e-6 * range);
    // Inverse z-depth: half the width of the image of [z - tau_z, z + tau_z].
    const double z = range * f.z(), tz = du.tauRange * f.z();
    EXPECT_NEAR(du.tauInverseDepth, 0.5 * (1 / (z - tz) - 1 / (z + tz)), 1e-12);
    EXPECT_GT(du.tauInverseDepth, 0);
  }
  EXPECT_GT(checked, 150);
}

TEST(MeasurementVariance, ScalesWithBaselineAndNoise) {
  const Eigen::Vector3d f(0, 0, 1);
  const double tauSmall = depthUncertainty(f, 10, {0.1, 0, 0}, 500, 1).tauRange;
  const double tauLarge = depthUncertainty(f, 10, {1.0, 0, 0}, 500, 1).tauRange;
  EXPECT_GT(tauSmall, 5 * tauLarge);  // ~ z^2 / (b f): ten times the baseline, ~ten times smaller
  EXPECT_GT(depthUncertainty(f, 10, {1.0, 0, 0}, 500, 2).tauRange, 1.9 * tauLarge);
  // Pure forward motion along the ray: no parallax, no usable depth.
  EXPECT_FALSE(depthUncertainty(f, 10, {0, 0, 1}, 500, 1).valid);
  EXPECT_THROW(depthUncertainty(f, 10, {0, 0, 0}, 500, 1), pslam::Error);
  EXPECT_THROW(depthUncertainty({0, 0, 2}, 10, {1, 0, 0}, 500, 1), pslam::Error);
}
