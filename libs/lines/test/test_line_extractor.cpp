// LSD + LBD extraction on images with known edges: a drawn rectangle (every long segment lies on one of its four
// edges), the N-longest and minimum-length rules, undistorted endpoints, and the rendered corridor.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/lines/LineExtractor.h"
#include "pslam/lines/LineGeometry.h"
#include "pslam/synth/Renderer.h"
#include "pslam/synth/Scenarios.h"

using namespace pslam;
using namespace pslam::lines;

namespace {
geometry::PinholeCamera camera640() { return geometry::PinholeCamera(525, 525, 319.5, 239.5, 640, 480); }

// A dark rectangle (x 150..450, y 120..360) on a bright background, lightly blurred.
cv::Mat rectangleImage() {
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(200));
  cv::rectangle(img, cv::Point(150, 120), cv::Point(450, 360), cv::Scalar(50), cv::FILLED);
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  return img;
}

// Distance (px) of a point to the nearest rectangle edge line restricted to the edge's extent.
double distanceToRectangle(const Eigen::Vector2d& p) {
  const double x0 = 149.5, x1 = 450.5, y0 = 119.5, y1 = 360.5;  // step edges between the pixel centres
  double best = 1e9;
  if (p.y() >= y0 - 3 && p.y() <= y1 + 3) best = std::min({best, std::abs(p.x() - x0), std::abs(p.x() - x1)});
  if (p.x() >= x0 - 3 && p.x() <= x1 + 3) best = std::min({best, std::abs(p.y() - y0), std::abs(p.y() - y1)});
  return best;
}
}  // namespace

TEST(LineExtractor, SegmentsLieOnTheKnownEdges) {
  LineExtractorParams p;
  p.detectionScale = 1.0;
  const LineExtractor ex(p, camera640());
  const LineFeatures f = ex.extract(rectangleImage());
  ASSERT_GE(f.size(), 4u);
  EXPECT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  EXPECT_EQ(f.descriptors.cols, 32);
  EXPECT_EQ(f.descriptors.type(), CV_8U);
  double covered = 0.0;
  for (const LineSegment& s : f.segments) {
    EXPECT_LT(distanceToRectangle(s.start), 1.5) << s.start.transpose();
    EXPECT_LT(distanceToRectangle(s.end), 1.5) << s.end.transpose();
    covered += s.length();
  }
  EXPECT_GT(covered, 0.9 * 2 * (300 + 240));  // the four edges are found nearly whole
  for (std::size_t i = 1; i < f.size(); ++i) EXPECT_GE(f.segments[i - 1].length(), f.segments[i].length());
}

TEST(LineExtractor, HalfResolutionDetectionStaysOnTheEdges) {
  const LineExtractor ex(LineExtractorParams{}, camera640());  // detectionScale 0.5
  EXPECT_DOUBLE_EQ(ex.pixelSigma(), 2.0);
  const LineFeatures f = ex.extract(rectangleImage());
  ASSERT_GE(f.size(), 4u);
  EXPECT_DOUBLE_EQ(f.pixelSigma, 2.0);
  for (const LineSegment& s : f.segments) {
    EXPECT_LT(distanceToRectangle(s.start), 2.0);
    EXPECT_LT(distanceToRectangle(s.end), 2.0);
  }
}

TEST(LineExtractor, KeepsTheLongestAndDropsShortOnes) {
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(30));
  for (int k = 0; k < 10; ++k)  // bright bars of lengths 40 .. 400 px
    cv::rectangle(img, cv::Point(20 + 60 * k, 40), cv::Point(40 + 60 * k, 40 + 40 * (k + 1)), cv::Scalar(220), cv::FILLED);
  LineExtractorParams p;
  p.detectionScale = 1.0;
  p.maxLines = 4;
  LineFeatures f = LineExtractor(p, camera640()).extract(img);
  ASSERT_EQ(f.size(), 4u);
  for (const LineSegment& s : f.segments) EXPECT_GT(s.length(), 300.0);
  p.maxLines = 100;
  p.minLength = 150;
  f = LineExtractor(p, camera640()).extract(img);
  ASSERT_GT(f.size(), 4u);
  for (const LineSegment& s : f.segments) EXPECT_GE(s.length(), 150.0);
}

TEST(LineExtractor, EndpointsAreUndistorted) {
  geometry::PinholeCamera distorted = camera640();
  distorted.distortion = {-0.2, 0.05, 0.001, -0.001, 0.0};
  LineExtractorParams p;
  p.detectionScale = 1.0;
  const LineFeatures raw = LineExtractor(p, camera640()).extract(rectangleImage());
  const LineFeatures und = LineExtractor(p, distorted).extract(rectangleImage());
  ASSERT_EQ(raw.size(), und.size());
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const auto expected = distorted.undistortPoints(
        {cv::Point2f(static_cast<float>(raw.segments[i].start.x()), static_cast<float>(raw.segments[i].start.y()))});
    EXPECT_NEAR(und.segments[i].start.x(), expected[0].x, 1e-3);
    EXPECT_NEAR(und.segments[i].start.y(), expected[0].y, 1e-3);
  }
}

TEST(LineExtractor, RenderedCorridorHasItsLines) {
  const synth::Scenario sc = synth::makeScenario("corridor", 1, 2.0);
  const synth::Renderer renderer(synth::defaultRenderCamera(), synth::RenderOptions{});
  const synth::RenderedView view = renderer.render(sc.scene, sc.T_world_cam(0.0), 0.0);
  cv::Mat grey;
  view.radiance.convertTo(grey, CV_8U);
  const LineFeatures f = LineExtractor(LineExtractorParams{}, camera640()).extract(grey);
  EXPECT_EQ(f.size(), 40u);  // Table 4.1: 40 per frame, a corridor has many more
  EXPECT_EQ(f.descriptors.rows, 40);
}

TEST(LineExtractor, RejectsWrongImagesAndParams) {
  const LineExtractor ex(LineExtractorParams{}, camera640());
  EXPECT_THROW(ex.extract(cv::Mat()), Error);
  EXPECT_THROW(ex.extract(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0))), Error);
  LineExtractorParams bad;
  bad.detectionScale = 0.0;
  EXPECT_THROW(LineExtractor(bad, camera640()), std::exception);
}
