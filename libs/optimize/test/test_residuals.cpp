// Jacobians of every residual against numeric differentiation (ceres::GradientChecker, in the tangent
// space of the pose manifold), residual values against an independent computation, and the pose
// manifold's update rule.
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include <ceres/gradient_checker.h>

#include "SyntheticProblem.h"
#include "pslam/optimize/AnalyticJacobians.h"
#include "pslam/optimize/InverseDepthReprojectionError.h"
#include "pslam/optimize/ReprojectionError.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

namespace {

const PoseManifold kPoseManifold;

Eigen::Isometry3d randomPose(std::mt19937& rng) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  return perturb(T, 0.3, 0.5, rng);
}

void expectJacobiansMatch(const ceres::CostFunction& cost, const std::vector<const ceres::Manifold*>& manifolds,
                          std::vector<double*> parameters) {
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters.data(), 1e-7, &results)) << results.error_log;
  EXPECT_LT(results.maximum_relative_error, 1e-7);
}

}  // namespace

TEST(Residuals, ReprojectionJacobians) {
  std::mt19937 rng(3);
  const auto cam = testCamera();
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d T = randomPose(rng);
    const Eigen::Vector3d pc(0.4 * trial - 1.0, 0.3, 3.0 + trial);
    Eigen::Vector3d pw = T.inverse() * pc;
    PoseParameters pose = toPoseParameters(T);
    const Eigen::Vector2d observed = cam.project(pc) + Eigen::Vector2d(1.5, -0.7);
    std::unique_ptr<ceres::CostFunction> full(ReprojectionError::create(observed, 1.0 / 1.44, cam));
    expectJacobiansMatch(*full, {&kPoseManifold, nullptr}, {pose.data(), pw.data()});
    std::unique_ptr<ceres::CostFunction> poseOnly(PoseOnlyReprojectionError::create(pw, observed, 1.0 / 1.44, cam));
    expectJacobiansMatch(*poseOnly, {&kPoseManifold}, {pose.data()});

    // Value: whitened pixel difference.
    double r[2];
    const double* params[] = {pose.data(), pw.data()};
    full->Evaluate(params, r, nullptr);
    EXPECT_NEAR(r[0], -1.5 / 1.2, 1e-9);
    EXPECT_NEAR(r[1], 0.7 / 1.2, 1e-9);
  }
}

TEST(Residuals, InverseDepthJacobiansAndValue) {
  std::mt19937 rng(5);
  const auto cam = testCamera();
  for (double rho : {0.25, 0.1, 1e-4, 0.0}) {
    const Eigen::Isometry3d TA = randomPose(rng);
    const Eigen::Isometry3d TB = perturb(TA, 0.1, 0.4, rng);
    const Eigen::Vector3d bearing = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
    PoseParameters poseA = toPoseParameters(TA), poseB = toPoseParameters(TB);
    double rhoParam = rho;
    const Eigen::Vector2d observed(300.0, 200.0);
    const double invSigma2 = 1.0 / (1.2 * 1.2 * 1.2 * 1.2);
    std::unique_ptr<ceres::CostFunction> cost(InverseDepthReprojectionError::create(bearing, observed, invSigma2, cam));
    expectJacobiansMatch(*cost, {&kPoseManifold, &kPoseManifold, nullptr}, {poseA.data(), poseB.data(), &rhoParam});

    // Independent value: through the world point (or the rotated direction at infinity).
    Eigen::Vector3d pB;
    if (rho > 0.0)
      pB = TB * (TA.inverse() * (bearing / rho));
    else
      pB = TB.linear() * TA.linear().transpose() * bearing;
    const Eigen::Vector2d expected = std::sqrt(invSigma2) * (cam.project(pB) - observed);
    double r[2];
    const double* params[] = {poseA.data(), poseB.data(), &rhoParam};
    cost->Evaluate(params, r, nullptr);
    EXPECT_NEAR(r[0], expected.x(), 1e-9 * (1.0 + std::abs(expected.x())));
    EXPECT_NEAR(r[1], expected.y(), 1e-9 * (1.0 + std::abs(expected.y())));
  }
}

TEST(Residuals, InverseDepthMatchesWorldPointResidual) {
  // The same point through residual (a) and residual (b) gives the same numbers.
  std::mt19937 rng(8);
  const auto cam = testCamera();
  const Eigen::Isometry3d TA = randomPose(rng), TB = perturb(TA, 0.05, 0.3, rng);
  const Eigen::Vector3d pA(0.3, 0.2, 4.0);
  Eigen::Vector3d pw = TA.inverse() * pA;
  PoseParameters poseA = toPoseParameters(TA), poseB = toPoseParameters(TB);
  double rho = 1.0 / pA.norm();
  const Eigen::Vector2d observed(321.0, 250.0);
  std::unique_ptr<ceres::CostFunction> a(ReprojectionError::create(observed, 0.5, cam));
  std::unique_ptr<ceres::CostFunction> b(InverseDepthReprojectionError::create(pA.normalized(), observed, 0.5, cam));
  double ra[2], rb[2];
  const double* pa[] = {poseB.data(), pw.data()};
  const double* pb[] = {poseA.data(), poseB.data(), &rho};
  a->Evaluate(pa, ra, nullptr);
  b->Evaluate(pb, rb, nullptr);
  EXPECT_NEAR(ra[0], rb[0], 1e-9);
  EXPECT_NEAR(ra[1], rb[1], 1e-9);
}

TEST(Residuals, AnchorObservationIsConstant) {
  // Observed in the anchor itself, the point projects to pi(bearing) whatever rho and the anchor pose:
  // identical residuals for any rho, zero when the bearing is the keypoint's ray.
  const auto cam = testCamera();
  const Eigen::Vector2d keypoint(400.0, 100.0);
  const Eigen::Vector3d bearing = cam.unprojectToBearing(keypoint);
  EXPECT_NEAR(anchorResidual(bearing, keypoint, 1.0, cam).norm(), 0.0, 1e-9);
  const Eigen::Vector3d tilted = (bearing + Eigen::Vector3d(0.002, 0.0, 0.0)).normalized();
  const Eigen::Vector2d r = anchorResidual(tilted, keypoint, 1.0, cam);
  EXPECT_GT(r.norm(), 0.5);
  // Residual (b) with A == B (same pose values in both blocks) reproduces it for any rho.
  PoseParameters pose = toPoseParameters(arcPose(1, 4));
  std::unique_ptr<ceres::CostFunction> cost(InverseDepthReprojectionError::create(tilted, keypoint, 1.0, cam));
  for (double rho : {0.05, 0.5, 2.0}) {
    double res[2];
    const double* p[] = {pose.data(), pose.data(), &rho};
    cost->Evaluate(p, res, nullptr);
    EXPECT_NEAR(res[0], r.x(), 1e-9);
    EXPECT_NEAR(res[1], r.y(), 1e-9);
  }
}

TEST(Residuals, PoseManifoldIsLeftRotationIncrement) {
  std::mt19937 rng(11);
  const Eigen::Isometry3d T = randomPose(rng);
  const PoseParameters x = toPoseParameters(T);
  const double delta[6] = {0.01, -0.02, 0.03, 0.1, 0.2, -0.3};
  PoseParameters y;
  ASSERT_TRUE(kPoseManifold.Plus(x.data(), delta, y.data()));
  const Eigen::Isometry3d Ty = fromPoseParameters(y.data());
  const Eigen::Vector3d w(delta[0], delta[1], delta[2]);
  // Ceres' quaternion increment [cos|d|, sin|d| d/|d|] is a rotation by the angle 2|d| about d.
  const Eigen::Matrix3d expectedR = Eigen::AngleAxisd(2.0 * w.norm(), w.normalized()).toRotationMatrix() * T.linear();
  EXPECT_NEAR((Ty.linear() - expectedR).norm(), 0.0, 1e-12);
  EXPECT_NEAR((Ty.translation() - T.translation() - Eigen::Vector3d(0.1, 0.2, -0.3)).norm(), 0.0, 1e-12);
  EXPECT_EQ(kPoseManifold.AmbientSize(), kPoseSize);
  EXPECT_EQ(kPoseManifold.TangentSize(), kPoseTangentSize);
  // Round trip through the parameter block.
  EXPECT_NEAR((fromPoseParameters(x.data()).matrix() - T.matrix()).norm(), 0.0, 1e-12);
}

namespace {

// Residuals and Jacobians (ambient parameters) of two cost functions at the same point.
void expectSameEvaluation(const ceres::CostFunction& a, const ceres::CostFunction& b,
                          const std::vector<double*>& parameters) {
  const auto& sizes = a.parameter_block_sizes();
  ASSERT_EQ(sizes, b.parameter_block_sizes());
  std::vector<std::vector<double>> ja(sizes.size()), jb(sizes.size());
  std::vector<double*> pa, pb;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    ja[i].assign(2 * sizes[i], 0.0);
    jb[i].assign(2 * sizes[i], 0.0);
    pa.push_back(ja[i].data());
    pb.push_back(jb[i].data());
  }
  double ra[2], rb[2];
  ASSERT_TRUE(a.Evaluate(parameters.data(), ra, pa.data()));
  ASSERT_TRUE(b.Evaluate(parameters.data(), rb, pb.data()));
  EXPECT_NEAR(ra[0], rb[0], 1e-10);
  EXPECT_NEAR(ra[1], rb[1], 1e-10);
  for (std::size_t i = 0; i < sizes.size(); ++i)
    for (std::size_t k = 0; k < ja[i].size(); ++k)
      EXPECT_NEAR(ja[i][k], jb[i][k], 1e-8 * (1.0 + std::abs(ja[i][k]))) << "block " << i << " entry " << k;
}

}  // namespace

TEST(Residuals, AnalyticJacobiansMatchAutodiffAndNumeric) {
  std::mt19937 rng(17);
  const auto cam = testCamera();
  for (double rho : {0.3, 0.12, 1e-3, 0.0}) {
    const Eigen::Isometry3d TA = randomPose(rng);
    const Eigen::Isometry3d TB = perturb(TA, 0.2, 0.5, rng);
    const Eigen::Vector3d bearing = Eigen::Vector3d(-0.2, 0.1, 1.0).normalized();
    PoseParameters poseA = toPoseParameters(TA), poseB = toPoseParameters(TB);
    double rhoParam = rho;
    const Eigen::Vector2d observed(310.0, 230.0);
    const double invSigma2 = 1.0 / 1.44;
    std::unique_ptr<ceres::CostFunction> autodiff(
        InverseDepthReprojectionError::create(bearing, observed, invSigma2, cam));
    InverseDepthReprojectionCost analytic(bearing, observed, invSigma2, cam);
    expectSameEvaluation(*autodiff, analytic, {poseA.data(), poseB.data(), &rhoParam});
    expectJacobiansMatch(analytic, {&kPoseManifold, &kPoseManifold, nullptr}, {poseA.data(), poseB.data(), &rhoParam});

    const Eigen::Vector3d pw = TA.inverse() * Eigen::Vector3d(0.5, -0.3, 4.0 + rho);
    std::unique_ptr<ceres::CostFunction> poseAuto(PoseOnlyReprojectionError::create(pw, observed, invSigma2, cam));
    PoseOnlyReprojectionCost poseAnalytic(pw, observed, invSigma2, cam);
    expectSameEvaluation(*poseAuto, poseAnalytic, {poseA.data()});
    expectJacobiansMatch(poseAnalytic, {&kPoseManifold}, {poseA.data()});
  }
}
