// PinholeCamera: intrinsics checks, projection and its Jacobian, undistortion (thesis §2.3.1).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <mrpt/config/CConfigFileMemory.h>
#include <opencv2/calib3d.hpp>

#include "SyntheticScene.h"
#include "pslam/core/Error.h"
#include "pslam/geometry/PinholeCamera.h"

using namespace pslam::geometry;

namespace {
void expectErrorMentioning(const PinholeCamera& cam, const std::string& key) {
  try {
    cam.check();
    FAIL() << "expected pslam::Error mentioning " << key;
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}
// A TUM freiburg1-like camera with noticeable radial-tangential distortion.
PinholeCamera distortedCamera() {
  return PinholeCamera(517.3, 516.5, 318.6, 255.3, 640, 480, {{0.2624, -0.9531, -0.0054, 0.0026, 1.1633}});
}
}  // namespace

TEST(PinholeCamera, CheckRejectsNonsense) {
  EXPECT_NO_THROW(test::testCamera().check());
  PinholeCamera c = test::testCamera();
  c.fx = std::numeric_limits<double>::quiet_NaN();
  expectErrorMentioning(c, "fx");
  c = test::testCamera();
  c.fy = 0.0;
  expectErrorMentioning(c, "fy");
  c = test::testCamera();
  c.width = 0;
  expectErrorMentioning(c, "width");
  c = test::testCamera();
  c.height = -3;
  expectErrorMentioning(c, "height");
  c = test::testCamera();
  c.cx = 700.0;
  expectErrorMentioning(c, "cx");
  c = test::testCamera();
  c.distortion[3] = std::numeric_limits<double>::infinity();
  expectErrorMentioning(c, "p2");
}

TEST(PinholeCamera, FromAndToTCamera) {
  const PinholeCamera d = distortedCamera();
  const mrpt::img::TCamera t = d.toTCamera();
  EXPECT_EQ(t.distortion, mrpt::img::DistortionModel::plumb_bob);
  const PinholeCamera back = PinholeCamera::fromTCamera(t);
  EXPECT_EQ(back.fx, d.fx);
  EXPECT_EQ(back.cy, d.cy);
  EXPECT_EQ(back.width, 640);
  EXPECT_EQ(back.distortion, d.distortion);

  mrpt::img::TCamera rational = t;
  rational.dist[5] = 0.01;  // k4 of the rational model
  EXPECT_THROW(PinholeCamera::fromTCamera(rational), pslam::Error);
  mrpt::img::TCamera fisheye = t;
  fisheye.distortion = mrpt::img::DistortionModel::kannala_brandt;
  EXPECT_THROW(PinholeCamera::fromTCamera(fisheye), pslam::Error);
  mrpt::img::TCamera bad = t;
  bad.fx(-1.0);
  EXPECT_THROW(PinholeCamera::fromTCamera(bad), pslam::Error);
}

TEST(PinholeCamera, LoadFromConfigFile) {
  mrpt::config::CConfigFileMemory cfg;
  distortedCamera().toTCamera().saveToConfigFile("CAMERA", cfg);
  const PinholeCamera loaded = PinholeCamera::loadFromConfigFile(cfg, "CAMERA");
  EXPECT_NEAR(loaded.fx, 517.3, 1e-9);
  EXPECT_NEAR(loaded.distortion[4], 1.1633, 1e-9);
  EXPECT_THROW(PinholeCamera::loadFromConfigFile(cfg, "NO_SUCH_SECTION"), pslam::Error);
}

TEST(PinholeCamera, ProjectUnprojectRoundTrip) {
  const PinholeCamera cam = test::testCamera();
  const Eigen::Vector3d X(0.4, -0.3, 2.5);
  const Eigen::Vector2d px = cam.project(X);
  EXPECT_NEAR(px.x(), cam.fx * 0.4 / 2.5 + cam.cx, 1e-12);
  EXPECT_NEAR(px.y(), cam.fy * -0.3 / 2.5 + cam.cy, 1e-12);
  const Eigen::Vector3d bearing = cam.unprojectToBearing(px);
  EXPECT_NEAR(bearing.norm(), 1.0, 1e-12);
  EXPECT_GT(bearing.z(), 0.0);
  EXPECT_LT((bearing - X.normalized()).norm(), 1e-12);
  EXPECT_LT((cam.unprojectToPlane(px) - X / X.z()).norm(), 1e-12);
  EXPECT_LT((cam.K() * cam.Kinv() - Eigen::Matrix3d::Identity()).norm(), 1e-15);
}

TEST(PinholeCamera, ProjectionJacobianMatchesFiniteDifferences) {
  const PinholeCamera cam = test::testCamera();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d X(u(rng), u(rng), 1.5 + std::abs(u(rng)) * 5.0);
    Eigen::Matrix<double, 2, 3> J;
    const Eigen::Vector2d px = cam.project(X, J);
    EXPECT_LT((px - cam.project(X)).norm(), 1e-12);
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d plus = X, minus = X;
      plus(k) += h;
      minus(k) -= h;
      const Eigen::Vector2d numeric = (cam.project(plus) - cam.project(minus)) / (2 * h);
      EXPECT_LT((numeric - J.col(k)).norm(), 1e-5 * (1.0 + J.col(k).norm())) << "column " << k;
    }
  }
}

TEST(PinholeCamera, UndistortInvertsOpenCvDistortion) {
  const PinholeCamera cam = distortedCamera();
  // Ideal pixels -> normalized rays -> distorted pixels with cv::projectPoints -> back.
  std::vector<cv::Point3d> rays;
  std::vector<Eigen::Vector2d> ideal;
  for (double x = 40; x < 620; x += 70) {
    for (double y = 40; y < 460; y += 60) {
      ideal.emplace_back(x, y);
      const Eigen::Vector3d r = cam.unprojectToPlane(ideal.back());
      rays.emplace_back(r.x(), r.y(), 1.0);
    }
  }
  std::vector<cv::Point2d> distorted;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.cvK(), cam.cvDistortion(), distorted);
  std::vector<cv::KeyPoint> keypoints;
  for (std::size_t i = 0; i < distorted.size(); ++i) {
    keypoints.emplace_back(cv::Point2f(static_cast<float>(distorted[i].x), static_cast<float>(distorted[i].y)), 31.f,
                           static_cast<float>(i), 0.5f, static_cast<int>(i % 8), static_cast<int>(i));
  }
  const std::vector<cv::KeyPoint> undistorted = cam.undistortKeyPoints(keypoints);
  ASSERT_EQ(undistorted.size(), keypoints.size());
  double maxError = 0.0, maxShift = 0.0;
  for (std::size_t i = 0; i < undistorted.size(); ++i) {
    maxError = std::max(maxError, std::hypot(undistorted[i].pt.x - ideal[i].x(), undistorted[i].pt.y - ideal[i].y()));
    maxShift = std::max(maxShift, std::hypot(distorted[i].x - ideal[i].x(), distorted[i].y - ideal[i].y()));
    EXPECT_EQ(undistorted[i].octave, keypoints[i].octave);
    EXPECT_EQ(undistorted[i].angle, keypoints[i].angle);
    EXPECT_EQ(undistorted[i].class_id, keypoints[i].class_id);
  }
  EXPECT_GT(maxShift, 5.0) << "the test distortion must matter";
  // cv::undistortPoints iterates a fixed number of times; float keypoints add ~1e-4 px.
  EXPECT_LT(maxError, 0.05);
  // Without distortion the points are returned unchanged.
  const std::vector<cv::Point2f> same = test::testCamera().undistortPoints({{10.5f, 20.25f}});
  EXPECT_EQ(same[0], cv::Point2f(10.5f, 20.25f));
}

TEST(PinholeCamera, UndistortedBounds) {
  const ImageBounds plain = test::testCamera().undistortedBounds();
  EXPECT_EQ(plain.minX, 0.0);
  EXPECT_EQ(plain.maxX, 640.0);
  EXPECT_EQ(plain.maxY, 480.0);
  EXPECT_TRUE(plain.contains(0.0, 0.0));
  EXPECT_FALSE(plain.contains(640.0, 10.0));
  const PinholeCamera cam = distortedCamera();
  const ImageBounds b = cam.undistortedBounds();
  const auto corners = cam.undistortPoints({{0.f, 0.f}, {640.f, 0.f}, {0.f, 480.f}, {640.f, 480.f}});
  for (const auto& c : corners) {
    EXPECT_GE(c.x, b.minX);
    EXPECT_LE(c.x, b.maxX);
    EXPECT_GE(c.y, b.minY);
    EXPECT_LE(c.y, b.maxY);
  }
  EXPECT_LT(b.minX, b.maxX);
  EXPECT_LT(b.minY, b.maxY);
  EXPECT_NE(b.minX, 0.0);  // distortion moves the corners
}
