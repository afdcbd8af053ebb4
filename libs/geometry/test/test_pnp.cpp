// PnP RANSAC for relocalization against synthetic 2D-3D correspondences with outliers.
#include <gtest/gtest.h>

#include <random>

#include <mrpt/config/CConfigFileMemory.h>

#include "SyntheticScene.h"
#include "pslam/core/Error.h"
#include "pslam/geometry/Pnp.h"

using namespace pslam::geometry;
using namespace pslam::geometry::test;

namespace {
struct PnpScene {
  Eigen::Matrix3d R_cam_world;
  Eigen::Vector3d t_cam_world;
  std::vector<Eigen::Vector3d> points_world;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<bool> isOutlier;
};

PnpScene makePnpScene(int n, double noisePx, double outlierFraction, unsigned seed) {
  const PinholeCamera cam = testCamera();
  PnpScene s;
  s.R_cam_world = rotationFromAxisAngle({0.3, 1.0, -0.2}, 25.0);
  s.t_cam_world = Eigen::Vector3d(0.4, -0.3, 1.2);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noisePx);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d px(u01(rng) * cam.width, u01(rng) * cam.height);
    const Eigen::Vector3d X_cam = cam.unprojectToPlane(px) * (2.0 + 6.0 * u01(rng));
    s.points_world.push_back(s.R_cam_world.transpose() * (X_cam - s.t_cam_world));
    const bool outlier = u01(rng) < outlierFraction;
    s.isOutlier.push_back(outlier);
    s.pixels.push_back(outlier ? Eigen::Vector2d(u01(rng) * cam.width, u01(rng) * cam.height)
                               : px + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  return s;
}
}  // namespace

TEST(Pnp, RecoversPoseWithOutliers) {
  const PnpScene s = makePnpScene(200, 1.0, 0.3, 1);
  const PnpResult r = solvePnpRansac(testCamera(), s.points_world, s.pixels);
  ASSERT_TRUE(r.success) << toString(r.failure) << ": " << r.message;
  const double rotErr = rotationErrorDeg(r.R_cam_world, s.R_cam_world);
  const double centerErr = (r.R_cam_world.transpose() * r.t_cam_world - s.R_cam_world.transpose() * s.t_cam_world).norm();
  std::cout << "rotation error " << rotErr << " deg, camera centre error " << centerErr << " m, " << r.message << "\n";
  EXPECT_LT(rotErr, 0.3);
  EXPECT_LT(centerErr, 0.03);  // points 2-8 m away
  int wrongInliers = 0, missedInliers = 0, trueInliers = 0;
  for (std::size_t i = 0; i < s.isOutlier.size(); ++i) {
    trueInliers += s.isOutlier[i] ? 0 : 1;
    if (s.isOutlier[i] && r.inliers[i]) ++wrongInliers;
    if (!s.isOutlier[i] && !r.inliers[i]) ++missedInliers;
  }
  // A random pixel lands within the 2.45 px inlier radius of the true projection with probability
  // ~6e-5; an inlier with 1 px noise fails the chi^2(2) 95 % test 5 % of the time.
  EXPECT_EQ(wrongInliers, 0);
  EXPECT_LT(missedInliers, 0.12 * trueInliers) << missedInliers << " of " << trueInliers << " inliers missed";
  EXPECT_LT(r.rmsReprojectionError, 1.6);
  // The MRPT pose is the same transform.
  const mrpt::poses::CPose3D T = r.poseCamWorld();
  const auto p = T.composePoint(mrpt::math::TPoint3D(1.0, 2.0, 3.0));
  const Eigen::Vector3d q = r.R_cam_world * Eigen::Vector3d(1.0, 2.0, 3.0) + r.t_cam_world;
  EXPECT_NEAR(p.x, q.x(), 1e-9);
  EXPECT_NEAR(p.z, q.z(), 1e-9);
}

TEST(Pnp, BothMinimalSolversRecoverThePoseOfASmallCandidateSet) {
  // A relocalization candidate: 40 matches, a third wrong. The iteration budget is small here (minInliers 15
  // of 40), and both samplers must still find the pose.
  const PnpScene s = makePnpScene(40, 1.0, 0.33, 7);
  for (const char* solver : {"epnp", "ap3p"}) {
    PnpParams p;
    p.minimalSolver = solver;
    const PnpResult r = solvePnpRansac(testCamera(), s.points_world, s.pixels, p);
    ASSERT_TRUE(r.success) << solver << ": " << toString(r.failure) << ": " << r.message;
    EXPECT_LT(rotationErrorDeg(r.R_cam_world, s.R_cam_world), 0.5) << solver;
  }
}

TEST(Pnp, IterationBudgetFollowsTheInlierShareAPassingPoseNeeds) {
  PnpParams p;  // minInliers 15, confidence 0.99, at most 300
  // (15/20)^5 = 0.237: ceil(log 0.01 / log 0.763) = 17 samples of 5; of 4: (0.75)^4 = 0.316 -> 13.
  EXPECT_EQ(ransacIterationBudget(p, 20, 5), 17);
  EXPECT_EQ(ransacIterationBudget(p, 20, 4), 13);
  EXPECT_EQ(ransacIterationBudget(p, 15, 5), 1);    // every correspondence must be an inlier
  EXPECT_EQ(ransacIterationBudget(p, 1000, 5), 300);  // capped by ransacIterations
  int last = 0;
  for (std::size_t n = 15; n <= 200; ++n) {
    const int budget = ransacIterationBudget(p, n, 5);
    EXPECT_GE(budget, last) << n;
    last = budget;
  }
}

TEST(Pnp, DeterministicAndClearFailures) {
  const PnpScene s = makePnpScene(120, 0.8, 0.2, 2);
  const PnpResult a = solvePnpRansac(testCamera(), s.points_world, s.pixels);
  const PnpResult b = solvePnpRansac(testCamera(), s.points_world, s.pixels);
  ASSERT_TRUE(a.success);
  EXPECT_EQ(a.R_cam_world, b.R_cam_world);
  EXPECT_EQ(a.t_cam_world, b.t_cam_world);
  EXPECT_EQ(a.inliers, b.inliers);

  const PnpScene few = makePnpScene(10, 0.5, 0.0, 3);
  const PnpResult f = solvePnpRansac(testCamera(), few.points_world, few.pixels);
  EXPECT_FALSE(f.success);
  EXPECT_EQ(f.failure, PnpFailure::TooFewCorrespondences) << f.message;

  // Only outliers: no pose explains 15 of them.
  const PnpScene junk = makePnpScene(100, 0.5, 1.0, 4);
  const PnpResult j = solvePnpRansac(testCamera(), junk.points_world, junk.pixels);
  EXPECT_FALSE(j.success);
  EXPECT_TRUE(j.failure == PnpFailure::TooFewInliers || j.failure == PnpFailure::RansacFailed) << toString(j.failure);

  auto pixels = s.pixels;
  pixels[3].y() = std::nan("");
  EXPECT_EQ(solvePnpRansac(testCamera(), s.points_world, pixels).failure, PnpFailure::InvalidInput);
  pixels.pop_back();
  EXPECT_EQ(solvePnpRansac(testCamera(), s.points_world, pixels).failure, PnpFailure::InvalidInput);
}

TEST(Pnp, ParamsCheckAndConfig) {
  PnpParams p;
  p.minInliers = 2;
  try {
    p.check();
    FAIL();
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("minInliers"), std::string::npos);
  }
  mrpt::config::CConfigFileMemory cfg;
  PnpParams saved;
  saved.ransacIterations = 77;
  saved.saveToConfigFile(cfg, "pnp");
  PnpParams loaded;
  loaded.loadFromConfigFile(cfg, "pnp");
  EXPECT_EQ(loaded.ransacIterations, 77);
}
