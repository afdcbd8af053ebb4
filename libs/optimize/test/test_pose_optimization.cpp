// Motion-only optimization: convergence from a perturbed pose on a synthetic scene with noisy observations
// and 20 % gross outliers, outlier flags, determinism, input validation, parameters.
#include <gtest/gtest.h>

#include <random>

#include <mrpt/config/CConfigFileMemory.h>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/PoseOptimizer.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

namespace {

struct PoseScene {
  Eigen::Isometry3d T_true;
  std::vector<PoseObservation> observations;
  std::vector<bool> isOutlier;
};

PoseScene makeScene(int n, double outlierFraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-3.0, 3.0), uy(-2.0, 2.0), uz(3.0, 10.0), u01(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const auto cam = testCamera();
  PoseScene s;
  s.T_true = arcPose(2, 5);
  while (static_cast<int>(s.observations.size()) < n) {
    const Eigen::Vector3d pw = s.T_true.inverse() * Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    const Eigen::Vector2d px = cam.project(s.T_true * pw);
    if (!cam.inImage(px)) continue;
    const double sigma = std::pow(1.2, level(rng));
    PoseObservation o;
    o.p_world = pw;
    o.invSigma2 = 1.0 / (sigma * sigma);
    const bool outlier = u01(rng) < outlierFraction;
    if (outlier) {
      const double r = 20.0 + 60.0 * u01(rng), a = 6.283185307 * u01(rng);
      o.pixel = px + Eigen::Vector2d(r * std::cos(a), r * std::sin(a));
    } else {
      o.pixel = px + sigma * Eigen::Vector2d(gauss(rng), gauss(rng));
    }
    s.observations.push_back(o);
    s.isOutlier.push_back(outlier);
  }
  return s;
}

}  // namespace

TEST(PoseOptimization, ConvergesAndFlagsOutliers) {
  const PoseScene s = makeScene(400, 0.2, 21);
  std::mt19937 rng(4);
  const Eigen::Isometry3d start = perturb(s.T_true, 3.0 * M_PI / 180.0, 0.15, rng);
  const PoseOptimizationResult r = optimizePose(start, testCamera(), s.observations);

  EXPECT_LT(rotationErrorRad(r.T_cam_world, s.T_true), 0.1 * M_PI / 180.0);
  EXPECT_LT(centreError(r.T_cam_world, s.T_true), 0.02);
  EXPECT_GT(rotationErrorRad(start, s.T_true), 2.9 * M_PI / 180.0);

  int trueOutliers = 0, caught = 0, inliersLost = 0;
  for (std::size_t i = 0; i < s.observations.size(); ++i) {
    trueOutliers += s.isOutlier[i];
    if (s.isOutlier[i] && r.outlier[i]) ++caught;
    if (!s.isOutlier[i] && r.outlier[i]) ++inliersLost;
  }
  EXPECT_EQ(caught, trueOutliers);  // 20-80 px off: every gross outlier must be rejected
  // chi2 at 95 %: about 5 % of the true inliers are expected above the threshold.
  EXPECT_LT(inliersLost, 0.1 * (s.observations.size() - trueOutliers));
  EXPECT_EQ(r.inliers, static_cast<int>(s.observations.size()) - caught - inliersLost);
  EXPECT_EQ(r.roundsRun, 4);
  // Mean chi2 of the inliers near its expectation for 2 DoF (2), truncated at 5.991.
  EXPECT_LT(r.finalChi2Sum / r.inliers, 2.0);
  EXPECT_GT(r.finalChi2Sum / r.inliers, 1.0);
}

TEST(PoseOptimization, DeterministicAndReChecksInitialOutliers) {
  const PoseScene s = makeScene(200, 0.2, 33);
  std::mt19937 rng(9);
  const Eigen::Isometry3d start = perturb(s.T_true, 0.02, 0.05, rng);
  const auto a = optimizePose(start, testCamera(), s.observations);
  const auto b = optimizePose(start, testCamera(), s.observations);
  EXPECT_EQ(a.T_cam_world.matrix(), b.T_cam_world.matrix());
  EXPECT_EQ(a.outlier, b.outlier);
  // Good correspondences marked as outliers at the start are recovered after the first round.
  std::vector<bool> initial(s.observations.size(), false);
  for (std::size_t i = 0; i < initial.size(); i += 3) initial[i] = !s.isOutlier[i];
  const auto c = optimizePose(start, testCamera(), s.observations, {}, initial);
  int recovered = 0, marked = 0;
  for (std::size_t i = 0; i < initial.size(); ++i)
    if (initial[i]) {
      ++marked;
      recovered += c.outlier[i] ? 0 : 1;
    }
  EXPECT_GT(recovered, 0.85 * marked);
  EXPECT_LT(rotationErrorRad(c.T_cam_world, s.T_true), 0.15 * M_PI / 180.0);
}

TEST(PoseOptimization, TooFewCorrespondencesAndBadInput) {
  const PoseScene s = makeScene(2, 0.0, 1);
  const auto r = optimizePose(s.T_true, testCamera(), s.observations);
  EXPECT_EQ(r.inliers, 0);
  EXPECT_EQ(r.T_cam_world.matrix(), s.T_true.matrix());

  PoseScene bad = makeScene(20, 0.0, 2);
  bad.observations[5].pixel.x() = std::nan("");
  EXPECT_THROW(optimizePose(bad.T_true, testCamera(), bad.observations), pslam::Error);
  bad.observations[5].pixel.x() = 1.0;
  bad.observations[6].invSigma2 = 0.0;
  EXPECT_THROW(optimizePose(bad.T_true, testCamera(), bad.observations), pslam::Error);
  EXPECT_THROW(optimizePose(bad.T_true, testCamera(), makeScene(20, 0.0, 2).observations, {}, {true, false}),
               pslam::Error);
}

TEST(PoseOptimization, ParamsLoadAndCheck) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("pose", "rounds", 3);
  cfg.write("pose", "chi2Threshold", 9.21);
  PoseOptimizationParams p;
  p.loadFromConfigFile(cfg, "pose");
  EXPECT_EQ(p.rounds, 3);
  EXPECT_DOUBLE_EQ(p.chi2Threshold, 9.21);
  EXPECT_EQ(p.iterationsPerRound, 10);  // untouched default
  mrpt::config::CConfigFileMemory out;
  p.saveToConfigFile(out, "pose");
  PoseOptimizationParams q;
  q.loadFromConfigFile(out, "pose");
  EXPECT_EQ(q.rounds, 3);
  cfg.write("pose", "huberDelta", -1.0);
  try {
    p.loadFromConfigFile(cfg, "pose");
    FAIL() << "negative huberDelta accepted";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("huberDelta"), std::string::npos) << e.what();
  }
}

// The solver's Jacobian (left perturbation of T_cam_world) against central differences through the retraction.
TEST(PoseOptimization, ResidualJacobianMatchesFiniteDifferences) {
  const PoseScene s = makeScene(50, 0.0, 5);
  std::mt19937 rng(9);
  const Eigen::Isometry3d T = perturb(s.T_true, 2.0 * M_PI / 180.0, 0.1, rng);
  const auto cam = testCamera();
  double worst = 0.0;
  for (const PoseObservation& o : s.observations) {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 6> J;
    ASSERT_TRUE(poseOnlyResidual(T, cam, o, r, &J));
    Eigen::Matrix<double, 2, 6> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      xi[k] = h;
      Eigen::Vector2d rp, rm;
      poseOnlyResidual(retractPoseLeft(xi, T), cam, o, rp, nullptr);
      poseOnlyResidual(retractPoseLeft(-xi, T), cam, o, rm, nullptr);
      numeric.col(k) = (rp - rm) / (2.0 * h);
    }
    worst = std::max(worst, (J - numeric).cwiseAbs().maxCoeff() / std::max(1.0, J.cwiseAbs().maxCoeff()));
  }
  EXPECT_LT(worst, 1e-6);
  // Behind the camera: reported, residual still finite.
  PoseObservation behind = s.observations.front();
  behind.p_world = T.inverse() * Eigen::Vector3d(0.1, 0.2, -3.0);
  Eigen::Vector2d r;
  EXPECT_FALSE(poseOnlyResidual(T, cam, behind, r, nullptr));
  EXPECT_TRUE(r.allFinite());
}
