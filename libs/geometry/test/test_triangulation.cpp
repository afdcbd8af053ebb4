// DLT triangulation (eq. 2.19-2.23), point checks and epipolar helpers against synthetic ground truth.
#include <gtest/gtest.h>

#include <random>

#include "SyntheticScene.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/geometry/Triangulation.h"

using namespace pslam::geometry;
using namespace pslam::geometry::test;

namespace {
struct View {
  Eigen::Matrix3d R;  // R_cam_world
  Eigen::Vector3d t;  // t_cam_world
};
std::vector<View> threeViews() {
  return {{rotationFromAxisAngle({0, 1, 0}, 5.0), Eigen::Vector3d(0.1, 0.0, 0.0)},
          {rotationFromAxisAngle({1, 0.5, 0}, -3.0), Eigen::Vector3d(-0.4, 0.05, 0.1)},
          {rotationFromAxisAngle({0, 0, 1}, 8.0), Eigen::Vector3d(0.3, -0.2, -0.1)}};
}
}  // namespace

TEST(Triangulation, NoiselessPointsAreExact) {
  const PinholeCamera cam = testCamera();
  const auto views = threeViews();
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d X(u(rng) * 2.0, u(rng) * 1.5, 5.0 + 3.0 * u(rng));
    std::vector<Matrix34d> P;
    std::vector<Eigen::Vector2d> px;
    for (const auto& v : views) {
      P.push_back(projectionMatrix(cam.K(), v.R, v.t));
      px.push_back(cam.project(v.R * X + v.t));
    }
    Eigen::Vector3d X2, X3;
    ASSERT_TRUE(triangulateDLT(P[0], px[0], P[1], px[1], X2));
    ASSERT_TRUE(triangulateDLT(P, px, X3));
    EXPECT_LT((X2 - X).norm(), 1e-9 * X.norm());
    Eigen::Vector3d X2n;  // the fixed-size two-view path equals the N-view path
    ASSERT_TRUE(triangulateDLT(std::vector<Matrix34d>{P[0], P[1]}, std::vector<Eigen::Vector2d>{px[0], px[1]}, X2n));
    EXPECT_LT((X2 - X2n).norm(), 1e-9 * X.norm());
    EXPECT_LT((X3 - X).norm(), 1e-9 * X.norm());
    for (const auto& v : views) {
      EXPECT_TRUE(hasPositiveDepth(v.R, v.t, X3));
      EXPECT_LT(reprojectionErrorSquared(cam.K(), v.R, v.t, X3, cam.project(v.R * X + v.t)), 1e-16);
    }
  }
}

TEST(Triangulation, NoisyPointsWithinFirstOrderBound) {
  // Two cameras 0.5 m apart looking along z; point depth Z. First-order depth std for disparity noise
  // sqrt(2) sigma is sigma_Z = Z^2 / (f b) * sqrt(2) sigma. Check the RMS depth error over many points
  // against it (within 30 %, the spread expected from 500 samples plus second-order terms).
  const PinholeCamera cam = testCamera();
  const View a{Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()};
  const View b{Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.5, 0.0, 0.0)};
  const double sigma = 0.7, Z = 6.0;
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double sumSq = 0.0;
  const int n = 500;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d X(u(rng), u(rng), Z);
    const Eigen::Vector2d pa = cam.project(X) + Eigen::Vector2d(noise(rng), noise(rng));
    const Eigen::Vector2d pb = cam.project(X + b.t) + Eigen::Vector2d(noise(rng), noise(rng));
    Eigen::Vector3d Xh;
    ASSERT_TRUE(triangulateDLT(projectionMatrix(cam.K(), a.R, a.t), pa, projectionMatrix(cam.K(), b.R, b.t), pb, Xh));
    sumSq += (Xh.z() - Z) * (Xh.z() - Z);
    // DLT minimizes an algebraic error, close to the geometric one: re-projection stays at noise level.
    EXPECT_LT(std::sqrt(reprojectionErrorSquared(cam.K(), a.R, a.t, Xh, pa)), 5.0 * sigma);
  }
  const double rms = std::sqrt(sumSq / n);
  const double predicted = Z * Z / (cam.fx * 0.5) * std::sqrt(2.0) * sigma;
  std::cout << "depth RMS error " << rms << " m, first-order prediction " << predicted << " m\n";
  EXPECT_GT(rms, 0.7 * predicted);
  EXPECT_LT(rms, 1.3 * predicted);
}

TEST(Triangulation, DegenerateInputsFail) {
  const PinholeCamera cam = testCamera();
  const Matrix34d P1 = projectionMatrix(cam.K(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const Matrix34d P2 = projectionMatrix(cam.K(), Eigen::Matrix3d::Identity(), Eigen::Vector3d(-1.0, 0.0, 0.0));
  Eigen::Vector3d X(7, 7, 7);
  // Parallel rays through the principal point of both cameras: the point is at infinity.
  EXPECT_FALSE(triangulateDLT(P1, {cam.cx, cam.cy}, P2, {cam.cx, cam.cy}, X));
  EXPECT_EQ(X, Eigen::Vector3d(7, 7, 7));
  EXPECT_FALSE(triangulateDLT(std::vector<Matrix34d>{P1}, std::vector<Eigen::Vector2d>{{1.0, 2.0}}, X));
  EXPECT_FALSE(triangulateDLT({P1, P2}, {{1.0, 2.0}}, X));
  EXPECT_FALSE(triangulateDLT(P1, {std::nan(""), 2.0}, P2, {1.0, 2.0}, X));
}

TEST(Triangulation, ParallaxAndDepthChecks) {
  const Eigen::Vector3d c1(-0.25, 0, 0), c2(0.25, 0, 0), X(0, 0, 4.0);
  const double expected = 2.0 * std::atan(0.25 / 4.0);
  EXPECT_NEAR(parallaxAngle(X, c1, c2), expected, 1e-12);
  EXPECT_NEAR(parallaxCosine(X, c1, c2), std::cos(expected), 1e-12);
  EXPECT_NEAR(parallaxAngle(Eigen::Vector3d(0, 0, 1e-9), c1, c2), M_PI, 1e-6);
  EXPECT_EQ(parallaxCosine(c1, c1, c2), 1.0);
  // Tiny angles stay accurate (acos of a cosine would lose them).
  EXPECT_NEAR(parallaxAngle(Eigen::Vector3d(0, 0, 1e6), c1, c2), 0.5e-6, 1e-15);

  const Eigen::Matrix3d R = rotationFromAxisAngle({0, 1, 0}, 180.0);  // camera looking backwards
  EXPECT_TRUE(hasPositiveDepth(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), X));
  EXPECT_FALSE(hasPositiveDepth(R, Eigen::Vector3d::Zero(), X));
  EXPECT_NEAR(depthInCamera(R, Eigen::Vector3d::Zero(), X), -4.0, 1e-12);
  EXPECT_NEAR(cameraCenter(R, Eigen::Vector3d(1, 2, 3)).x(), 1.0, 1e-12);  // -R^T t, R = diag(-1, 1, -1)

  const PinholeCamera cam = testCamera();
  const Eigen::Vector2d px = cam.project(X) + Eigen::Vector2d(3.0, 4.0);
  const double e2 = reprojectionErrorSquared(cam.K(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), X, px);
  EXPECT_NEAR(e2, 25.0, 1e-9);
  EXPECT_TRUE(std::isinf(reprojectionErrorSquared(cam.K(), R, Eigen::Vector3d::Zero(), X, px)));
  EXPECT_FALSE(passesReprojectionTest(e2, 1.0));       // 25 > 5.991
  EXPECT_TRUE(passesReprojectionTest(e2, 4.5));        // coarse pyramid level: 25 < 5.991 * 4.5
}

TEST(Epipolar, FundamentalFromPosesAndDistanceCheck) {
  const PinholeCamera cam = testCamera();
  const auto views = threeViews();
  const View& v1 = views[0];
  const View& v2 = views[1];
  const Eigen::Matrix3d F12 = fundamentalFromPoses(cam.K(), v1.R, v1.t, cam.K(), v2.R, v2.t);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 30; ++trial) {
    const Eigen::Vector3d X(u(rng) * 2.0, u(rng), 6.0 + u(rng));
    const Eigen::Vector2d x1 = cam.project(v1.R * X + v1.t), x2 = cam.project(v2.R * X + v2.t);
    EXPECT_LT(epipolarDistanceSquared(x1, x2, F12), 1e-14);
    // Move x2 by d pixels perpendicular to its epipolar line: the squared distance is d^2.
    const Eigen::Vector3d line2 = F12.transpose() * x1.homogeneous();
    const Eigen::Vector2d normal = line2.head<2>().normalized();
    const double d = 1.5;
    EXPECT_NEAR(epipolarDistanceSquared(x1, x2 + d * normal, F12), d * d, 1e-6);
    // sigma^2 = 1: 1.5^2 = 2.25 < 3.84 accepted; at level sigma^2 = 0.5, 2.25 > 1.92 rejected.
    EXPECT_TRUE(checkDistEpipolarLine(x1, x2 + d * normal, F12, 1.0));
    EXPECT_FALSE(checkDistEpipolarLine(x1, x2 + d * normal, F12, 0.5));
    // Moving along the line does not change the distance.
    const Eigen::Vector2d along(-normal.y(), normal.x());
    EXPECT_LT(epipolarDistanceSquared(x1, x2 + 40.0 * along, F12), 1e-12);
  }
  // skew(v) w == v x w
  const Eigen::Vector3d a(1, -2, 3), b(0.5, 4, -1);
  EXPECT_LT((skew(a) * b - a.cross(b)).norm(), 1e-15);
}
