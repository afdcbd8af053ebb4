// Mean-shift Manhattan-frame tracker on synthetic normal sets with known ground-truth rotation.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include <Eigen/Geometry>
#include <mrpt/config/CConfigFile.h>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/manhattan/ManhattanTracker.h"

using namespace pslam::manhattan;

namespace {

Eigen::Matrix3d randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

Eigen::Matrix3d rotationAbout(const Eigen::Vector3d& axis, double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

/// Normals around the chosen MF axes (columns of R_cam_mf), both signs, Gaussian angular noise, plus
/// uniformly distributed outliers.
std::vector<Eigen::Vector3d> makeNormals(const Eigen::Matrix3d& R_cam_mf, std::vector<int> axes, int perAxis,
                                         double noiseDeg, int outliers, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Vector3d> out;
  for (int a : axes) {
    for (int i = 0; i < perAxis; ++i) {
      Eigen::Vector3d n = R_cam_mf.col(a) * (i % 2 ? -1.0 : 1.0);
      Eigen::Vector3d perturb(g(rng), g(rng), g(rng));
      perturb -= perturb.dot(n) * n;  // tangent direction, so the angular error is ~noiseDeg per component
      n = (n + perturb * noiseDeg * M_PI / 180.0).normalized();
      out.push_back(n);
    }
  }
  for (int i = 0; i < outliers; ++i) out.push_back(Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
  std::shuffle(out.begin(), out.end(), rng);
  return out;
}

double errorModuloCube(const Eigen::Matrix3d& est, const Eigen::Matrix3d& truth) {
  double angle = 0;
  alignToReference(est, truth, &angle);
  return angle;
}

}  // namespace

TEST(S2Maps, LogExpRoundTripAndAntipodalSymmetry) {
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0, 1);
  for (int i = 0; i < 200; ++i) {
    Eigen::Vector3d v(g(rng), g(rng), std::abs(g(rng)) + 0.2);
    v.normalize();
    const Eigen::Vector2d p = logMapS2(v);
    // |p| is the geodesic distance to the tangent point +z
    EXPECT_NEAR(p.norm(), std::acos(v.z()), 1e-9);
    EXPECT_LT((expMapS2(p) - v).norm(), 1e-9);
    EXPECT_LT((logMapS2(-v) - p).norm(), 1e-12);  // sign-less directions
  }
  EXPECT_LT((expMapS2(Eigen::Vector2d::Zero()) - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
}

TEST(CubeSymmetries, TwentyFourDistinctProperRotations) {
  const auto& S = cubeSymmetries();
  ASSERT_EQ(S.size(), 24u);
  for (std::size_t i = 0; i < S.size(); ++i) {
    EXPECT_NEAR(S[i].determinant(), 1.0, 1e-12);
    for (std::size_t j = 0; j < i; ++j) EXPECT_GT((S[i] - S[j]).norm(), 0.5);
  }
}

TEST(MeanShift, NoiseFreeTruthIsAFixedPoint) {
  std::mt19937 rng(2);
  const Eigen::Matrix3d R = randomRotation(rng);
  const auto normals = makeNormals(R, {0, 1, 2}, 300, 0.0, 0, rng);
  std::array<std::size_t, 3> support{};
  const Eigen::Matrix3d Rn = meanShiftIteration(normals, R, 10.0, 2.0, 1, &support);
  EXPECT_LT(rotationAngleDeg(R, Rn), 1e-6);
  for (auto s : support) EXPECT_EQ(s, 300u);
}

TEST(ManhattanTracker, InitializationRecoversRotationWithNoiseAndOutliers) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Matrix3d R = randomRotation(rng);
    const auto normals = makeNormals(R, {0, 1, 2}, 2000, 3.0, 2000, rng);  // 25 % outliers
    ManhattanTracker tracker;
    const ManhattanEstimate e = tracker.initialize(normals);
    ASSERT_TRUE(e.valid) << e.reason;
    EXPECT_EQ(e.observedAxes, 3);
    EXPECT_LT(errorModuloCube(e.R_cam_mf, R), 0.5) << "trial " << trial;
    // First-frame labelling: the cube symmetry closest to the camera axes.
    double toIdentity = 0;
    alignToReference(e.R_cam_mf, Eigen::Matrix3d::Identity(), &toIdentity);
    EXPECT_NEAR(rotationAngleDeg(Eigen::Matrix3d::Identity(), e.R_cam_mf), toIdentity, 1e-9);
  }
}

TEST(ManhattanTracker, TracksStepsSmallerAndLargerThanTheCone) {
  std::mt19937 rng(4);
  const Eigen::Matrix3d R0 = randomRotation(rng);
  ManhattanTracker tracker;
  ASSERT_TRUE(tracker.initialize(makeNormals(R0, {0, 1, 2}, 1500, 2.0, 500, rng)).valid);
  const Eigen::Matrix3d labelled0 = tracker.R_cam_mf();
  Eigen::Matrix3d R_true = R0;
  // Steps of 5 and 18 degrees (the latter beyond rho = 10 deg): the axis labels must follow the motion.
  for (double step : {5.0, 18.0, 5.0, 18.0}) {
    const Eigen::Matrix3d delta = rotationAbout(Eigen::Vector3d(1, 2, 3), step);
    R_true = delta * R_true;
    const ManhattanEstimate e = tracker.track(makeNormals(R_true, {0, 1, 2}, 1500, 2.0, 500, rng));
    ASSERT_TRUE(e.valid) << e.reason;
    // The tracked frame is the first frame's labelled MF carried along by the true camera motion.
    const Eigen::Matrix3d expected = R_true * R0.transpose() * labelled0;
    EXPECT_LT(rotationAngleDeg(e.R_cam_mf, expected), 0.5) << "step " << step;
  }
}

TEST(ManhattanTracker, MissingThirdAxisCompletedByCrossProduct) {
  std::mt19937 rng(5);
  const Eigen::Matrix3d R = randomRotation(rng);
  const auto normals = makeNormals(R, {0, 2}, 3000, 2.0, 600, rng);
  ManhattanTracker tracker;
  const ManhattanEstimate e = tracker.initialize(normals);
  ASSERT_TRUE(e.valid) << e.reason;
  EXPECT_EQ(e.observedAxes, 2);
  EXPECT_GE(e.completedAxis, 0);
  EXPECT_LT(errorModuloCube(e.R_cam_mf, R), 0.5);

  ManhattanParams needAll;
  needAll.minObservedAxes = 3;
  EXPECT_FALSE(ManhattanTracker(needAll).initialize(normals).valid);
}

TEST(ManhattanTracker, RejectsSceneWithoutManhattanStructure) {
  std::mt19937 rng(6);
  const Eigen::Matrix3d R = randomRotation(rng);
  ManhattanTracker tracker;
  // One plane only: a single axis cannot fix the rotation.
  ManhattanEstimate e = tracker.initialize(makeNormals(R, {1}, 4000, 2.0, 500, rng));
  EXPECT_FALSE(e.valid);
  EXPECT_FALSE(e.reason.empty());
  EXPECT_FALSE(tracker.initialized());
  // Uniform directions only.
  e = tracker.initialize(makeNormals(R, {}, 0, 0.0, 6000, rng));
  EXPECT_FALSE(e.valid);
}

TEST(ManhattanTracker, DeterministicForAFixedSeed) {
  std::mt19937 rng(7);
  const Eigen::Matrix3d R = randomRotation(rng);
  const auto normals = makeNormals(R, {0, 1, 2}, 10000, 3.0, 5000, rng);  // > maxNormals: subsampled
  ManhattanTracker a, b;
  const auto ea = a.initialize(normals), eb = b.initialize(normals);
  ASSERT_TRUE(ea.valid && eb.valid);
  EXPECT_EQ((ea.R_cam_mf - eb.R_cam_mf).norm(), 0.0);
}

TEST(ManhattanParams, LoadsFromIniAndRejectsBadValuesNamingTheKey) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("ManhattanTracker", "coneAngleDeg", 12.0);
  cfg.write("ManhattanTracker", "kernelWidth", 3.0);
  ManhattanParams p;
  p.loadFromConfigFile(cfg, "ManhattanTracker");
  EXPECT_DOUBLE_EQ(p.coneAngleDeg, 12.0);
  EXPECT_DOUBLE_EQ(p.kernelWidth, 3.0);
  EXPECT_DOUBLE_EQ(ManhattanParams{}.coneAngleDeg, 10.0);  // Table 4.1 defaults
  EXPECT_DOUBLE_EQ(ManhattanParams{}.kernelWidth, 2.0);
  cfg.write("ManhattanTracker", "coneAngleDeg", "-1");
  try {
    p.loadFromConfigFile(cfg, "ManhattanTracker");
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "[ManhattanTracker] coneAngleDeg = -1: must be in (0, 45)");
  }
  mrpt::config::CConfigFileMemory typo("[ManhattanTracker]\nconeAngle = 10\n");
  try {
    p.loadFromConfigFile(typo, "ManhattanTracker");
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "[ManhattanTracker] coneAngle: unknown key (did you mean coneAngleDeg?)");
  }
  // Round trip, including the unsigned and size_t keys.
  ManhattanParams q;
  q.seed = 4000000000u;
  q.maxNormals = 12345;
  mrpt::config::CConfigFileMemory saved(pslam::params::toIniText(q, "ManhattanTracker"));
  ManhattanParams r;
  r.loadFromConfigFile(saved, "ManhattanTracker");
  EXPECT_EQ(r.seed, 4000000000u);
  EXPECT_EQ(r.maxNormals, 12345u);
}
