// The point-to-line error of eq. 2.59: residual values, the pose factor's analytic Jacobian against central
// differences of the left perturbation, the BA cost against ceres::GradientChecker (pose and endpoint
// manifolds), the endpoint manifold, and both factors in their optimizers (pose from lines, local BA).
#include <random>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "pslam/lines/LineFactors.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/PoseOptimizer.h"

using namespace pslam;
using namespace pslam::lines;

namespace {
geometry::PinholeCamera anisotropicIntrinsics() {
  geometry::PinholeCamera c;
  c.fx = 520;
  c.fy = 510;
  c.cx = 320;
  c.cy = 240;
  c.width = 640;
  c.height = 480;
  return c;
}
Eigen::Isometry3d pose(const Eigen::Vector3d& axisAngle, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (axisAngle.norm() > 0) T.linear() = Eigen::AngleAxisd(axisAngle.norm(), axisAngle.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}
// Random lines 2..6 m in front of the identity camera, spread over the image.
std::vector<Line3> randomLines(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), z(2.0, 6.0);
  std::vector<Line3> out;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d c(1.5 * u(rng), 1.0 * u(rng), z(rng));
    const Eigen::Vector3d d = Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng)).normalized();
    out.push_back({c - 0.5 * d, c + 0.5 * d});
  }
  return out;
}
}  // namespace

TEST(LineFactors, ResidualIsTheEndpointDistanceToTheObservedLine) {
  const geometry::PinholeCamera cam = anisotropicIntrinsics();
  const Line3 line{{-0.5, 0.1, 3.0}, {0.6, -0.2, 4.0}};
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Observed: the true projection shifted 3 px along the normal of the segment, other endpoints along the line.
  const Eigen::Vector2d a = cam.project(line.start), b = cam.project(line.end);
  const Eigen::Vector2d n = Eigen::Vector2d(-(b - a).y(), (b - a).x()).normalized();
  const LinePoseFactor f(line, a + 0.3 * (b - a) + 3.0 * n, a + 1.4 * (b - a) + 3.0 * n, cam, 2.0);
  Eigen::VectorXd r;
  ASSERT_TRUE(f.evaluate(T, r, nullptr));
  ASSERT_EQ(r.size(), 2);
  EXPECT_NEAR(std::abs(r[0]), 1.5, 1e-9);  // 3 px / sigma 2
  EXPECT_NEAR(std::abs(r[1]), 1.5, 1e-9);
  EXPECT_EQ(f.kind(), "line");
  EXPECT_DOUBLE_EQ(f.chi2Threshold(), 5.991);
  EXPECT_NEAR(f.huberDelta(), std::sqrt(5.991), 1e-12);
  // Behind the camera: not valid.
  EXPECT_FALSE(f.evaluate(pose({0, M_PI, 0}, {0, 0, 0}), r, nullptr));
}

TEST(LineFactors, PoseJacobianMatchesCentralDifferences) {
  const geometry::PinholeCamera cam = anisotropicIntrinsics();
  std::mt19937 rng(7);
  const Eigen::Isometry3d T = pose({0.05, -0.1, 0.02}, {0.1, -0.05, 0.2});
  for (const Line3& line : randomLines(20, rng)) {
    const Eigen::Vector2d a = cam.project(T * line.start) + Eigen::Vector2d(1.5, -2.0);
    const Eigen::Vector2d b = cam.project(T * line.end) + Eigen::Vector2d(-1.0, 2.5);
    const LinePoseFactor f(line, a, b, cam, 1.3);
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    ASSERT_TRUE(f.evaluate(T, r, &J));
    ASSERT_EQ(J.rows(), 2);
    ASSERT_EQ(J.cols(), 6);
    Eigen::MatrixXd Jn(2, 6);
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      xi[k] = h;
      Eigen::VectorXd rp, rm;
      ASSERT_TRUE(f.evaluate(optimize::retractPoseLeft(xi, T), rp, nullptr));
      ASSERT_TRUE(f.evaluate(optimize::retractPoseLeft(-xi, T), rm, nullptr));
      Jn.col(k) = (rp - rm) / (2 * h);
    }
    EXPECT_LT((J - Jn).norm(), 1e-5 * std::max(1.0, J.norm())) << "analytic\n" << J << "\nnumeric\n" << Jn;
  }
}

TEST(LineFactors, BACostPassesTheGradientChecker) {
  const geometry::PinholeCamera cam = anisotropicIntrinsics();
  std::mt19937 rng(3);
  const Eigen::Isometry3d T = pose({-0.03, 0.08, 0.01}, {0.2, 0.1, -0.1});
  for (const Line3& line : randomLines(10, rng)) {
    auto lm = std::make_shared<LineLandmark>();
    lm->set(line);
    const LineBAFactor f(lm, 4, cam.project(T * line.start) + Eigen::Vector2d(2, 1),
                         cam.project(T * line.end) + Eigen::Vector2d(-1, 3), cam, 1.0);
    optimize::PoseParameters p = optimize::toPoseParameters(T);
    std::unique_ptr<ceres::CostFunction> cost(f.newCostFunction());
    optimize::PoseManifold poseManifold;
    std::unique_ptr<ceres::Manifold> lineManifold(f.newLandmarkManifold(0));
    const std::vector<const ceres::Manifold*> manifolds{&poseManifold, lineManifold.get()};
    ceres::NumericDiffOptions nd;
    ceres::GradientChecker checker(cost.get(), &manifolds, nd);
    ceres::GradientChecker::ProbeResults results;
    const double* params[2] = {p.data(), lm->endpoints.data()};
    EXPECT_TRUE(checker.Probe(params, 1e-7, &results)) << results.error_log;
    // The residual is the pose factor's.
    const LinePoseFactor pf(line, cam.project(T * line.start) + Eigen::Vector2d(2, 1),
                            cam.project(T * line.end) + Eigen::Vector2d(-1, 3), cam, 1.0);
    Eigen::VectorXd r;
    ASSERT_TRUE(pf.evaluate(T, r, nullptr));
    EXPECT_NEAR(results.residuals[0], r[0], 1e-9);
    EXPECT_NEAR(results.residuals[1], r[1], 1e-9);
  }
}

TEST(LineFactors, EndpointManifoldMovesPerpendicularToTheLine) {
  const LineEndpointsManifold m;
  const double x[6] = {0.1, 0.2, 3.0, 1.0, -0.5, 4.0};
  const Eigen::Vector3d d = (Eigen::Vector3d(x[3], x[4], x[5]) - Eigen::Vector3d(x[0], x[1], x[2])).normalized();
  const double delta[4] = {0.01, -0.02, 0.03, 0.005};
  double y[6], back[4];
  ASSERT_TRUE(m.Plus(x, delta, y));
  ASSERT_TRUE(m.Minus(y, x, back));
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(back[k], delta[k], 1e-12);
  EXPECT_NEAR((Eigen::Vector3d(y[0], y[1], y[2]) - Eigen::Vector3d(x[0], x[1], x[2])).dot(d), 0.0, 1e-12);
  EXPECT_NEAR((Eigen::Vector3d(y[3], y[4], y[5]) - Eigen::Vector3d(x[3], x[4], x[5])).dot(d), 0.0, 1e-12);
  double J[24], Jm[24];
  ASSERT_TRUE(m.PlusJacobian(x, J));
  ASSERT_TRUE(m.MinusJacobian(x, Jm));
  // MinusJacobian * PlusJacobian = I (4 x 4).
  const Eigen::Map<const Eigen::Matrix<double, 6, 4, Eigen::RowMajor>> P(J);
  const Eigen::Map<const Eigen::Matrix<double, 4, 6, Eigen::RowMajor>> M(Jm);
  EXPECT_LT((M * P - Eigen::Matrix4d::Identity()).norm(), 1e-12);
  // Plus Jacobian against differences.
  for (int k = 0; k < 4; ++k) {
    double dp[4] = {0, 0, 0, 0}, yp[6], ym[6];
    dp[k] = 1e-6;
    m.Plus(x, dp, yp);
    dp[k] = -1e-6;
    m.Plus(x, dp, ym);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR((yp[i] - ym[i]) / 2e-6, P(i, k), 1e-8);
  }
  const double degenerate[6] = {1, 1, 1, 1, 1, 1};
  EXPECT_FALSE(m.Plus(degenerate, delta, y));
}

TEST(LineFactors, PoseFromLinesAloneRecoversTheTruePose) {
  const geometry::PinholeCamera cam = anisotropicIntrinsics();
  std::mt19937 rng(11);
  const Eigen::Isometry3d truth = pose({0.02, -0.04, 0.01}, {0.05, 0.02, -0.03});
  std::vector<std::shared_ptr<const optimize::PoseFactor>> factors;
  std::normal_distribution<double> noise(0.0, 0.5);
  for (const Line3& line : randomLines(40, rng)) {
    const Eigen::Vector2d a = cam.project(truth * line.start), b = cam.project(truth * line.end);
    // Observed endpoints slide along the line (partial detection) and carry pixel noise.
    factors.push_back(std::make_shared<LinePoseFactor>(
        line, a + 0.1 * (b - a) + Eigen::Vector2d(noise(rng), noise(rng)),
        a + 0.8 * (b - a) + Eigen::Vector2d(noise(rng), noise(rng)), cam, 1.0));
  }
  // Five gross outliers.
  for (int k = 0; k < 5; ++k)
    factors.push_back(std::make_shared<LinePoseFactor>(randomLines(1, rng)[0], Eigen::Vector2d(100 + 50 * k, 100),
                                                       Eigen::Vector2d(120 + 50 * k, 400), cam, 1.0));
  const optimize::PoseOptimizationResult r =
      optimize::optimizePose(Eigen::Isometry3d::Identity(), cam, {}, {}, {}, factors);
  EXPECT_LT((r.T_cam_world.translation() - truth.translation()).norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(r.T_cam_world.linear() * truth.linear().transpose()).angle(), 0.002);
  int outliers = 0;
  for (bool o : r.factorOutlier) outliers += o ? 1 : 0;
  EXPECT_GE(outliers, 5);
  EXPECT_LE(outliers, 8);
}

TEST(LineFactors, LocalBundleAdjustmentRefinesLinesAndAPose) {
  // Three keyframes, the first two fixed, the third perturbed; keypoints pin the gauge, lines are perturbed.
  const geometry::PinholeCamera cam = anisotropicIntrinsics();
  std::mt19937 rng(5);
  const std::vector<Eigen::Isometry3d> truth{pose({0, 0, 0}, {0, 0, 0}), pose({0, 0.05, 0}, {-0.3, 0, 0}),
                                             pose({0.02, -0.04, 0}, {0.25, 0.1, 0.05})};
  optimize::BAProblem problem;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    optimize::BAKeyFrame kf;
    kf.T_cam_world = truth[k];
    kf.camera = cam;
    kf.fixed = k < 2;
    problem.keyframes[k] = kf;
  }
  problem.keyframes[2].T_cam_world = pose({0.03, -0.03, 0.01}, {0.28, 0.08, 0.07});
  // A few keypoints so that the keypoint part of the problem is not empty.
  std::uniform_real_distribution<double> u(-1, 1);
  for (map::MapPointId id = 0; id < 30; ++id) {
    const Eigen::Vector3d X(1.5 * u(rng), u(rng), 4 + u(rng));
    optimize::BAPoint p;
    p.anchor = 0;
    p.bearing = X.normalized();
    p.inverseDepth = 1.0 / X.norm();
    p.fixed = true;
    problem.points[id] = p;
    for (map::KeyFrameId k = 0; k < 3; ++k)
      problem.observations.push_back({k, id, cam.project(truth[k] * X), 1.0});
  }
  std::vector<std::shared_ptr<LineLandmark>> landmarks;
  std::vector<Line3> lines = randomLines(30, rng);
  for (const Line3& l : lines) {
    auto lm = std::make_shared<LineLandmark>();
    lm->set({l.start + Eigen::Vector3d(0.05, -0.04, 0.1), l.end + Eigen::Vector3d(-0.03, 0.05, -0.08)});
    landmarks.push_back(lm);
    for (map::KeyFrameId k = 0; k < 3; ++k) {
      const Eigen::Vector2d a = cam.project(truth[k] * l.start), b = cam.project(truth[k] * l.end);
      problem.factors.push_back(std::make_shared<LineBAFactor>(lm, k, a + 0.05 * k * (b - a), b, cam, 1.0));
    }
  }
  const optimize::BAResult r = optimize::localBundleAdjustment(problem);
  EXPECT_TRUE(r.factorOutliers.empty());
  ASSERT_TRUE(r.poses.count(2));
  EXPECT_LT((r.poses.at(2).translation() - truth[2].translation()).norm(), 1e-3);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const Line3 est = landmarks[i]->line();
    const Eigen::Vector3d d = (lines[i].end - lines[i].start).normalized();
    for (const Eigen::Vector3d& X : {est.start, est.end}) {
      const Eigen::Vector3d v = X - lines[i].start;
      EXPECT_LT((v - v.dot(d) * d).norm(), 1e-3);
    }
  }
}
