// NORMALS channel encoding round trip and the normal-accuracy metrics of §4.5.3 (eqs. 4.3-4.7).
#include <gtest/gtest.h>

#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/priors/NormalMap.h"

using namespace pslam::priors;

TEST(NormalMap, EncodeDecodeRoundTripWithinQuantization) {
  cv::Mat n(4, 5, CV_32FC3, cv::Scalar::all(0));
  cv::Mat mask(4, 5, CV_8UC1, cv::Scalar(255));
  for (int i = 0; i < 20; ++i) {
    const double a = 0.3 * i, b = 0.17 * i - 1.5;
    n.at<cv::Vec3f>(i / 5, i % 5) = cv::Vec3f(float(std::cos(a) * std::cos(b)), float(std::sin(b)),
                                              float(std::sin(a) * std::cos(b)));
  }
  n.at<cv::Vec3f>(0, 0) = cv::Vec3f(0, 0, 0);  // no normal
  mask.at<uchar>(0, 1) = 0;                    // not planar
  const cv::Mat enc = encodeNormalMap(n, mask);
  const cv::Mat dec = decodeNormalMap(enc);
  EXPECT_EQ(enc.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(enc.at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 0));
  for (int i = 2; i < 20; ++i) {
    const auto a = n.at<cv::Vec3f>(i / 5, i % 5), b = dec.at<cv::Vec3f>(i / 5, i % 5);
    // per component the step is 2/255; the angular error stays below ~0.5 degrees
    EXPECT_LT(normalAngleDeg(a, b), 0.5) << i;
  }
  EXPECT_EQ(collectNormals(dec).size(), 18u);
  EXPECT_EQ(collectNormals(dec, 2).size(), 5u);  // rows 0,2 x cols 0,2,4 minus (0,0)
  EXPECT_THROW(decodeNormalMap(cv::Mat(2, 2, CV_8UC1)), pslam::Error);
}

TEST(NormalAccuracy, MatchesHandComputedStatistics) {
  NormalErrorAccumulator acc;
  for (double e : {5.0, 10.0, 20.0, 40.0, 25.0}) acc.add(e);
  const NormalAccuracy s = acc.summary();
  EXPECT_EQ(s.count, 5u);
  EXPECT_NEAR(s.meanDeg, 20.0, 1e-12);
  EXPECT_NEAR(s.rmseDeg, std::sqrt((25.0 + 100 + 400 + 1600 + 625) / 5.0), 1e-12);
  EXPECT_NEAR(s.medianDeg, 20.0, 0.01);
  EXPECT_NEAR(s.under11_25, 0.4, 1e-12);
  EXPECT_NEAR(s.under22_5, 0.6, 1e-12);
  EXPECT_NEAR(s.under30, 0.8, 1e-12);
  EXPECT_TRUE(std::isnan(NormalErrorAccumulator().summary().meanDeg));
  EXPECT_THROW(acc.add(std::nan("")), pslam::Error);
}

TEST(NormalAccuracy, MapsCompareOnlyPixelsValidInBoth) {
  cv::Mat a(1, 3, CV_32FC3, cv::Scalar::all(0)), b(1, 3, CV_32FC3, cv::Scalar::all(0));
  a.at<cv::Vec3f>(0, 0) = {0, 0, -1};
  b.at<cv::Vec3f>(0, 0) = {0, float(std::sin(0.1)), -float(std::cos(0.1))};
  a.at<cv::Vec3f>(0, 1) = {1, 0, 0};  // b has no normal there
  NormalErrorAccumulator acc;
  acc.addMaps(a, b);
  EXPECT_EQ(acc.summary().count, 1u);
  EXPECT_NEAR(acc.summary().meanDeg, 0.1 * 180 / M_PI, 1e-4);
  EXPECT_THROW(acc.addMaps(a, cv::Mat(2, 3, CV_32FC3)), pslam::Error);
}
