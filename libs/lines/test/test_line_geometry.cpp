// Image lines (eq. 2.58), two-view line triangulation against synthetic ground truth and its rejections, and the
// matching rules.
#include <gtest/gtest.h>

#include "pslam/lines/LineGeometry.h"
#include "pslam/lines/LineMatching.h"

using namespace pslam;
using namespace pslam::lines;

namespace {
geometry::PinholeCamera intrinsics() {
  geometry::PinholeCamera c;
  c.fx = c.fy = 500;
  c.cx = 320;
  c.cy = 240;
  c.width = 640;
  c.height = 480;
  return c;
}
Eigen::Isometry3d poseAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& axisAngle) {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  if (axisAngle.norm() > 0) T_world_cam.linear() = Eigen::AngleAxisd(axisAngle.norm(), axisAngle.normalized()).toRotationMatrix();
  T_world_cam.translation() = centre;
  return T_world_cam.inverse();
}
double distanceToLine(const Eigen::Vector3d& X, const Line3& l) {
  const Eigen::Vector3d d = (l.end - l.start).normalized();
  return ((X - l.start) - (X - l.start).dot(d) * d).norm();
}
}  // namespace

TEST(LineGeometry, ImageLineGivesSignedPixelDistances) {
  const Eigen::Vector3d l = imageLine({0, 0}, {10, 0});
  EXPECT_NEAR(l.head<2>().norm(), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(lineDistance(l, {5, 3})), 3.0, 1e-12);
  EXPECT_NEAR(lineDistance(l, {-7, 0}), 0.0, 1e-12);
  EXPECT_NEAR(lineDistance(l, {5, 3}), -lineDistance(l, {5, -3}), 1e-12);
}

TEST(LineGeometry, TriangulationRecoversTheGroundTruthLine) {
  const geometry::PinholeCamera cam = intrinsics();
  const Line3 truth{{-0.8, -0.3, 4.0}, {0.9, 0.4, 5.0}};
  const Eigen::Isometry3d T1 = poseAt({0, 0, 0}, {0, 0, 0});
  const Eigen::Isometry3d T2 = poseAt({0.3, -0.2, 0.1}, {0.02, -0.05, 0.01});
  const Eigen::Vector2d a1 = cam.project(T1 * truth.start), b1 = cam.project(T1 * truth.end);
  // The second view sees another part of the line (partial occlusion): endpoints are not corresponding.
  const Eigen::Vector3d A2 = truth.start + 0.2 * (truth.end - truth.start), B2 = truth.end + 0.3 * (truth.end - truth.start);
  const LineTriangulation t =
      triangulateLine(cam, T1, a1, b1, T2, cam.project(T2 * A2), cam.project(T2 * B2));
  ASSERT_TRUE(t.valid) << t.reason;
  // Endpoints are the first view's: equal to the true endpoints.
  EXPECT_LT((t.line.start - truth.start).norm(), 1e-9);
  EXPECT_LT((t.line.end - truth.end).norm(), 1e-9);
}

TEST(LineGeometry, TriangulationWithPixelNoiseStaysNearTheLine) {
  const geometry::PinholeCamera cam = intrinsics();
  const Line3 truth{{-1.0, 0.5, 3.0}, {1.0, 0.2, 3.5}};
  const Eigen::Isometry3d T1 = poseAt({0, 0, 0}, {0, 0, 0});
  const Eigen::Isometry3d T2 = poseAt({0.0, -0.4, 0.0}, {0.03, 0, 0});
  const Eigen::Vector2d n(0.3, -0.3);
  const LineTriangulation t = triangulateLine(cam, T1, cam.project(T1 * truth.start) + n, cam.project(T1 * truth.end) - n,
                                              T2, cam.project(T2 * truth.start) - n, cam.project(T2 * truth.end) + n);
  ASSERT_TRUE(t.valid) << t.reason;
  EXPECT_LT(distanceToLine(t.line.start, truth), 0.05);
  EXPECT_LT(distanceToLine(t.line.end, truth), 0.05);
}

TEST(LineGeometry, TriangulationRejectsDegenerateConfigurations) {
  const geometry::PinholeCamera cam = intrinsics();
  const Eigen::Isometry3d T1 = poseAt({0, 0, 0}, {0, 0, 0});
  // A line parallel to the baseline lies in the epipolar planes: both views span the same plane.
  const Line3 alongBaseline{{-1.0, 0.3, 4.0}, {1.0, 0.3, 4.0}};
  const Eigen::Isometry3d T2 = poseAt({0.5, 0, 0}, {0, 0, 0});
  LineTriangulation t =
      triangulateLine(cam, T1, cam.project(T1 * alongBaseline.start), cam.project(T1 * alongBaseline.end), T2,
                      cam.project(T2 * alongBaseline.start), cam.project(T2 * alongBaseline.end));
  EXPECT_FALSE(t.valid);
  EXPECT_EQ(t.reason, "planes almost parallel");
  // No baseline.
  const Line3 vertical{{0.2, -1.0, 4.0}, {0.2, 1.0, 4.0}};
  t = triangulateLine(cam, T1, cam.project(T1 * vertical.start), cam.project(T1 * vertical.end), T1,
                      cam.project(T1 * vertical.start), cam.project(T1 * vertical.end));
  EXPECT_FALSE(t.valid);
  // Degenerate segment.
  t = triangulateLine(cam, T1, {100, 100}, {100, 100}, T2, {10, 10}, {50, 60});
  EXPECT_FALSE(t.valid);
  // A tiny baseline puts the endpoints beyond maxDepthRatio baselines.
  const Eigen::Isometry3d Tnear = poseAt({0.001, 0, 0}, {0, 0, 0.05});
  t = triangulateLine(cam, T1, cam.project(T1 * vertical.start), cam.project(T1 * vertical.end), Tnear,
                      cam.project(Tnear * vertical.start), cam.project(Tnear * vertical.end));
  EXPECT_FALSE(t.valid);
}

TEST(LineMatching, OverlapAndProjectionGates) {
  const LineSegment a{{0, 0}, {100, 0}};
  EXPECT_NEAR(segmentOverlap(a, {{50, 2}, {150, 2}}), 0.5, 1e-12);
  EXPECT_NEAR(segmentOverlap(a, {{20, 0}, {40, 0}}), 1.0, 1e-12);
  EXPECT_EQ(segmentOverlap(a, {{120, 0}, {140, 0}}), 0.0);

  cv::Mat d1(1, 32, CV_8U, cv::Scalar(0)), d2(1, 32, CV_8U, cv::Scalar(255)), d1near = d1.clone();
  d1near.at<uchar>(0, 0) = 0x0F;  // 4 bits
  LineFeatures frame;
  frame.segments = {{{10, 5}, {90, 6}}, {{10, 40}, {90, 40}}, {{50, -50}, {50, 50}}};
  frame.descriptors = cv::Mat(3, 32, CV_8U);
  d1near.copyTo(frame.descriptors.row(0));
  d1.copyTo(frame.descriptors.row(1));  // same descriptor, too far from the projection
  d1.copyTo(frame.descriptors.row(2));  // same descriptor, perpendicular
  LineMatchParams p;
  const std::vector<int> m = matchByProjection({{a, d1}, {{{0, 200}, {100, 200}}, d2}}, frame, p);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], 0);
  EXPECT_EQ(m[1], -1);
  EXPECT_EQ(hamming(d1, d2), 256);
}

TEST(LineMatching, DescriptorMatchesAreMutualBest) {
  cv::Mat a(2, 32, CV_8U, cv::Scalar(0)), b(2, 32, CV_8U, cv::Scalar(0));
  a.row(1).setTo(cv::Scalar(255));
  b.row(0).setTo(cv::Scalar(255));
  b.at<uchar>(0, 0) = 0xFE;  // b0 ~ a1 (1 bit), b1 == a0
  LineMatchParams p;
  const auto m = matchByDescriptor(a, b, p);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(0, 1));
  EXPECT_EQ(m[1], std::make_pair(1, 0));
  const auto only = matchByDescriptor(a, b, p, {false, true});
  ASSERT_EQ(only.size(), 1u);
  EXPECT_EQ(only[0], std::make_pair(1, 0));
}
