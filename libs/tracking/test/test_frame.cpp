// tracking::Frame construction: undistortion, grid, pyramid scales, and SEMANTIC sampling at the raw keypoint.
#include <gtest/gtest.h>

#include "pslam/core/Error.h"
#include "pslam/tracking/Frame.h"

using namespace pslam;

TEST(TrackingFrame, SamplesSemanticProbabilitiesAndBuildsTheGrid) {
  const geometry::PinholeCamera camera(400, 400, 159.5, 119.5, 320, 240);
  std::vector<cv::KeyPoint> kps = {cv::KeyPoint(10.2f, 20.7f, 31.f, 0.f, 1.f, 0),
                                   cv::KeyPoint(300.f, 200.f, 31.f, 0.f, 1.f, 2)};
  cv::Mat desc(2, 32, CV_8U, cv::Scalar(0));
  cv::Mat semantic(240, 320, CV_8UC3, cv::Scalar(255, 0, 0));
  semantic.at<cv::Vec3b>(21, 10) = cv::Vec3b(0, 255, 0);    // rounded position of keypoint 0: dynamic
  semantic.at<cv::Vec3b>(200, 300) = cv::Vec3b(51, 0, 204);  // keypoint 1: 0.2 static, 0.8 invalid
  const tracking::Frame f = tracking::makeFrameFromFeatures(3, 0.5, camera, kps, desc, 8, 1.2, semantic);
  ASSERT_EQ(f.semanticProbabilities.size(), 2u);
  EXPECT_FLOAT_EQ(f.semanticProbabilities[0][1], 1.f);
  EXPECT_FLOAT_EQ(f.semanticProbabilities[0][0], 0.f);
  EXPECT_NEAR(f.semanticProbabilities[1][0], 0.2f, 1e-6);
  EXPECT_NEAR(f.semanticProbabilities[1][2], 0.8f, 1e-6);
  EXPECT_EQ(f.numLevels(), 8);
  EXPECT_NEAR(f.levelSigma2[2], 1.44 * 1.44, 1e-12);
  EXPECT_EQ(f.grid.featuresInRadius(300.f, 200.f, 1.f).size(), 1u);
  EXPECT_EQ(f.mapPointIds.size(), 2u);
  EXPECT_EQ(f.numMatchedInliers(), 0);
}

TEST(TrackingFrame, RejectsImagesThatDoNotFitTheCamera) {
  const geometry::PinholeCamera camera(400, 400, 159.5, 119.5, 320, 240);
  features::OrbExtractor orb;
  datasets::Frame in;
  in.image = cv::Mat(100, 100, CV_8UC1, cv::Scalar(0));
  try {
    tracking::makeFrame(in, camera, orb, "frame 7");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 7"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("100x100"), std::string::npos);
  }
  in.image = cv::Mat();
  EXPECT_THROW(tracking::makeFrame(in, camera, orb, "frame 8"), Error);
}
