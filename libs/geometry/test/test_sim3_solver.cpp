// Sim(3) RANSAC between two keyframes (loop closing) on synthetic correspondences with known S12 and outliers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <mrpt/config/CConfigFileMemory.h>

#include "SyntheticScene.h"
#include "pslam/core/Error.h"
#include "pslam/geometry/Sim3Solver.h"

using namespace pslam::geometry;
using namespace pslam::geometry::test;

namespace {

const PinholeCamera kCam1 = testCamera();
const PinholeCamera kCam2(480.0, 482.0, 315.0, 245.0, 640, 480);

Eigen::Vector2d project(const PinholeCamera& cam, const Eigen::Vector3d& X) {
  const Eigen::Vector3d h = cam.K() * X;
  return h.head<2>() / h.z();
}

bool inImage(const PinholeCamera& cam, const Eigen::Vector2d& px) {
  return px.x() >= 0 && px.y() >= 0 && px.x() < cam.width && px.y() < cam.height;
}

struct Sim3Scene {
  Sim3 S12;  ///< ground truth
  std::vector<Sim3Correspondence> matches;
  std::vector<bool> isOutlier;
};

/// Camera 2 sits at a rigid pose from camera 1 (metres of map 1); keyframe 2's map has its own scale, so its
/// points are 1 / s12 times larger: p2 = (1 / s12) (R21 X1 + t21). Points 3-9 m in front of camera 1 and visible
/// in both images; map points carry 0.05 % of their depth as 3-D noise, keypoints 0.5 px times their level's
/// scale (levels 0-3, scale factor 1.2). Outliers: exactly round(outlierFraction * n) correspondences get the
/// point and keypoint of another random point seen by camera 2 (a wrong match), far from the true one.
Sim3Scene makeSim3Scene(int n, double s12, double outlierFraction, unsigned seed) {
  const Eigen::Matrix3d R21 = rotationFromAxisAngle({0.2, 1.0, 0.1}, 14.0);
  const Eigen::Vector3d t21(-0.7, 0.15, 0.25);
  const double sigma = 1.0 / s12;
  Sim3Scene s;
  s.S12 = Sim3(sigma, R21, sigma * t21).inverse();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 3);
  auto noise3 = [&](double stdDev) -> Eigen::Vector3d {
    return Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)) * stdDev;
  };
  auto noise2 = [&](double stdDev) -> Eigen::Vector2d { return Eigen::Vector2d(gauss(rng), gauss(rng)) * stdDev; };
  while (static_cast<int>(s.matches.size()) < n) {
    const Eigen::Vector2d px1(u01(rng) * kCam1.width, u01(rng) * kCam1.height);
    const double depth1 = 3.0 + 6.0 * u01(rng);
    const Eigen::Vector3d X1 = kCam1.unprojectToPlane(px1) * depth1;
    const Eigen::Vector3d X2 = R21 * X1 + t21;
    if (X2.z() < 1.0 || !inImage(kCam2, project(kCam2, X2))) continue;
    Sim3Correspondence m;
    const int l1 = level(rng), l2 = level(rng);
    m.sigma2_1 = std::pow(1.2, 2 * l1);
    m.sigma2_2 = std::pow(1.2, 2 * l2);
    m.p1 = X1 + noise3(5e-4 * X1.z());
    m.p2 = sigma * (X2 + noise3(5e-4 * X2.z()));
    m.px1 = px1 + noise2(0.5 * std::sqrt(m.sigma2_1));
    m.px2 = project(kCam2, X2) + noise2(0.5 * std::sqrt(m.sigma2_2));
    s.matches.push_back(m);
  }
  s.isOutlier.assign(n, false);
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  const int numOutliers = static_cast<int>(std::lround(outlierFraction * n));
  for (int k = 0; k < numOutliers; ++k) {
    Sim3Correspondence& m = s.matches[order[k]];
    const Eigen::Vector2d px1True = project(kCam1, s.S12.map(m.p2));
    for (;;) {
      const Eigen::Vector2d px2(u01(rng) * kCam2.width, u01(rng) * kCam2.height);
      const Eigen::Vector3d X2 = kCam2.unprojectToPlane(px2) * (3.0 + 6.0 * u01(rng));
      const Eigen::Vector3d X1 = s.S12.map(sigma * X2);
      // Far from the true match in both images, so the true inlier set is unambiguous.
      if ((px2 - m.px2).norm() < 20.0 || (X1.z() > 0 && (project(kCam1, X1) - px1True).norm() < 20.0)) continue;
      m.p2 = sigma * X2;
      m.px2 = px2;
      break;
    }
    s.isOutlier[order[k]] = true;
  }
  return s;
}

Sim3RansacResult run(const Sim3Scene& s, const Sim3RansacParams& params, unsigned seed) {
  std::mt19937 rng(seed);
  return estimateSim3Ransac(s.matches, kCam1.K(), kCam2.K(), params, rng);
}

bool finite(const Sim3& S) { return std::isfinite(S.s) && S.R.allFinite() && S.t.allFinite(); }

struct Case {
  double s12;
  double outlierFraction;
  int n;
  unsigned seed;
};
void PrintTo(const Case& c, std::ostream* os) {
  *os << "s12 " << c.s12 << ", " << c.outlierFraction * 100 << " % outliers of " << c.n << ", seed " << c.seed;
}

class Sim3RecoveryTest : public ::testing::TestWithParam<Case> {};

}  // namespace

TEST_P(Sim3RecoveryTest, RecoversScaleRotationTranslationAndInliers) {
  const Case c = GetParam();
  const Sim3Scene s = makeSim3Scene(c.n, c.s12, c.outlierFraction, c.seed);
  const Sim3RansacParams params;
  const Sim3RansacResult r = run(s, params, 7);
  ASSERT_TRUE(r.success) << toString(r.failure) << ": " << r.message;
  ASSERT_TRUE(finite(r.S12));
  const double scaleErr = std::abs(r.S12.s - s.S12.s) / s.S12.s;
  const double rotErr = rotationErrorDeg(r.S12.R, s.S12.R);
  const double transErr = (r.S12.t - s.S12.t).norm();  // metres of map 1 (points 3-9 m away)
  std::cout << "s12 " << c.s12 << ": scale error " << scaleErr << ", rotation error " << rotErr
            << " deg, translation error " << transErr << " m; " << r.message << "\n";
  EXPECT_LT(scaleErr, 1e-2);
  EXPECT_LT(rotErr, 0.5);
  EXPECT_LT(transErr, 0.05);
  // The adaptive stop ends long before the cap at this inlier ratio (about 15 iterations after a good sample).
  EXPECT_LT(r.iterations, params.maxIterations);

  ASSERT_EQ(r.inliers.size(), s.matches.size());
  int disagree = 0, count = 0;
  for (std::size_t i = 0; i < s.matches.size(); ++i) {
    disagree += (r.inliers[i] == s.isOutlier[i]) ? 1 : 0;
    count += r.inliers[i] ? 1 : 0;
  }
  EXPECT_EQ(count, r.numInliers);
  // 0.5 px noise at a 3 px (x level scale) threshold: a true inlier fails with probability ~1e-5; outliers are
  // 20 px or more from their true match.
  EXPECT_LE(disagree, static_cast<int>(0.02 * c.n)) << disagree << " inlier flags differ from the truth";

  // Scale-free: the inverse maps each inlier's camera-1 point back onto its camera-2 point, relative to its size.
  const Sim3 S21 = r.S12.inverse();
  double worst = 0.0;
  for (std::size_t i = 0; i < s.matches.size(); ++i) {
    if (!r.inliers[i]) continue;
    const auto& m = s.matches[i];
    worst = std::max(worst, (S21.map(m.p1) - m.p2).norm() / m.p2.norm());
  }
  EXPECT_LT(worst, 0.01);
  EXPECT_NEAR((r.S12 * S21).s, 1.0, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Sim3Solver, Sim3RecoveryTest,
                         ::testing::Values(Case{0.37, 0.35, 150, 11}, Case{2.5, 0.30, 120, 12},
                                           Case{1.0, 0.40, 100, 13}));

TEST(Sim3Solver, PointsBehindACameraAreOutliers) {
  Sim3Scene s = makeSim3Scene(80, 0.6, 0.2, 21);
  const Sim3 S21 = s.S12.inverse();
  // A point behind camera 1 and its images: both reprojections are exact (a point and its mirror through the
  // camera centre share their pixel), only the depth test rejects it.
  const std::size_t first = s.matches.size();
  for (int k = 0; k < 5; ++k) {
    const Eigen::Vector3d X1(0.4 * k - 0.8, 0.3 - 0.1 * k, -(2.0 + k));
    Sim3Correspondence m;
    m.p1 = X1;
    m.p2 = S21.map(X1);
    m.px1 = project(kCam1, X1);
    m.px2 = project(kCam2, m.p2);
    EXPECT_FALSE(isSim3Inlier(m, s.S12, S21, kCam1.K(), kCam2.K(), 9.21)) << "point " << k;
    s.matches.push_back(m);
    s.isOutlier.push_back(true);
  }
  // The same test in front of the cameras passes.
  Sim3Correspondence front;
  front.p1 = Eigen::Vector3d(0.3, -0.2, 5.0);
  front.p2 = S21.map(front.p1);
  front.px1 = project(kCam1, front.p1);
  front.px2 = project(kCam2, front.p2);
  EXPECT_TRUE(isSim3Inlier(front, s.S12, S21, kCam1.K(), kCam2.K(), 9.21));

  const Sim3RansacResult r = run(s, {}, 3);
  ASSERT_TRUE(r.success) << r.message;
  for (std::size_t i = first; i < s.matches.size(); ++i) EXPECT_FALSE(r.inliers[i]) << "behind-camera match " << i;
}

TEST(Sim3Solver, InlierTestUsesBothImagesAndTheirVariances) {
  const Sim3 S12(0.5, rotationFromAxisAngle({0, 1, 0}, 10.0), Eigen::Vector3d(0.2, 0.0, 0.1));
  const Sim3 S21 = S12.inverse();
  Sim3Correspondence m;
  m.p1 = Eigen::Vector3d(0.5, 0.4, 6.0);
  m.p2 = S21.map(m.p1);
  m.px1 = project(kCam1, m.p1);
  m.px2 = project(kCam2, m.p2);
  const Eigen::Matrix3d K1 = kCam1.K(), K2 = kCam2.K();
  ASSERT_TRUE(isSim3Inlier(m, S12, S21, K1, K2, 9.21));
  const double level4 = std::pow(1.2, 8);  // sigma^2 of pyramid level 4: threshold sqrt(9.21 * 4.3) = 6.3 px

  Sim3Correspondence off1 = m;
  off1.px1.x() += 5.0;  // 25 px^2: fails 9.21 at level 0, passes 39.6 at level 4
  EXPECT_FALSE(isSim3Inlier(off1, S12, S21, K1, K2, 9.21));
  off1.sigma2_2 = level4;  // the other image's variance does not help
  EXPECT_FALSE(isSim3Inlier(off1, S12, S21, K1, K2, 9.21));
  off1.sigma2_1 = level4;
  EXPECT_TRUE(isSim3Inlier(off1, S12, S21, K1, K2, 9.21));

  Sim3Correspondence off2 = m;
  off2.px2.y() -= 5.0;
  EXPECT_FALSE(isSim3Inlier(off2, S12, S21, K1, K2, 9.21));
  off2.sigma2_1 = level4;
  EXPECT_FALSE(isSim3Inlier(off2, S12, S21, K1, K2, 9.21));
  off2.sigma2_2 = level4;
  EXPECT_TRUE(isSim3Inlier(off2, S12, S21, K1, K2, 9.21));
}

TEST(Sim3Solver, TooFewInliersFails) {
  // 40 correspondences, 16 of them right: no similarity explains the 20 that are required.
  const Sim3Scene s = makeSim3Scene(40, 0.8, 0.6, 31);
  const Sim3RansacResult r = run(s, {}, 5);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.failure, Sim3Failure::TooFewInliers) << r.message;
  EXPECT_NE(r.message.find("need 20"), std::string::npos) << r.message;
  EXPECT_LE(r.numInliers, 16 + 1);
  EXPECT_TRUE(finite(r.S12));
  // All outliers: same failure.
  const Sim3Scene junk = makeSim3Scene(60, 0.8, 1.0, 32);
  const Sim3RansacResult j = run(junk, {}, 5);
  EXPECT_FALSE(j.success);
  EXPECT_EQ(j.failure, Sim3Failure::TooFewInliers) << j.message;
  EXPECT_EQ(j.iterations, Sim3RansacParams{}.maxIterations);  // no early stop without a good hypothesis
}

TEST(Sim3Solver, FewerThanThreeCorrespondencesFails) {
  const Sim3Scene s = makeSim3Scene(3, 1.3, 0.0, 41);
  Sim3RansacParams params;
  params.minInliers = 3;
  for (int n = 0; n < 3; ++n) {
    Sim3Scene few = s;
    few.matches.resize(n);
    const Sim3RansacResult r = run(few, params, 1);
    EXPECT_FALSE(r.success) << n;
    EXPECT_EQ(r.failure, Sim3Failure::TooFewCorrespondences) << n;
    EXPECT_FALSE(r.message.empty());
    EXPECT_EQ(r.iterations, 0);
  }
  // Three exact correspondences are enough for minInliers = 3; with the default 20 they are too few.
  const Sim3RansacResult three = run(s, params, 1);
  EXPECT_TRUE(three.success) << three.message;
  const Sim3RansacResult defaults = run(s, {}, 1);
  EXPECT_EQ(defaults.failure, Sim3Failure::TooFewCorrespondences);
}

TEST(Sim3Solver, DegenerateSetsFailWithoutNaN) {
  const Sim3 S12(1.7, rotationFromAxisAngle({1, 1, 0}, 8.0), Eigen::Vector3d(0.1, 0.2, -0.1));
  const Sim3 S21 = S12.inverse();
  auto correspondence = [&](const Eigen::Vector3d& X1) {
    Sim3Correspondence m;
    m.p1 = X1;
    m.p2 = S21.map(X1);
    m.px1 = project(kCam1, m.p1);
    m.px2 = project(kCam2, m.p2);
    return m;
  };
  const std::vector<Sim3Correspondence> identical(30, correspondence({0.2, -0.1, 4.0}));
  std::vector<Sim3Correspondence> collinear;
  for (int i = 0; i < 30; ++i)
    collinear.push_back(correspondence(Eigen::Vector3d(-1.0, 0.5, 3.0) + 0.1 * i * Eigen::Vector3d(1.0, -0.2, 0.5)));
  const std::vector<Sim3Correspondence>* sets[] = {&identical, &collinear};
  for (const auto* set : sets) {
    std::mt19937 rng(9);
    const Sim3RansacResult r = estimateSim3Ransac(*set, kCam1.K(), kCam2.K(), {}, rng);
    EXPECT_FALSE(r.success);
    EXPECT_EQ(r.failure, Sim3Failure::AllSamplesDegenerate) << r.message;
    EXPECT_FALSE(r.message.empty());
    EXPECT_TRUE(finite(r.S12));
    EXPECT_EQ(r.numInliers, 0);
    EXPECT_EQ(r.iterations, Sim3RansacParams{}.maxIterations);
  }
}

TEST(Sim3Solver, SameSeedSameResult) {
  const Sim3Scene s = makeSim3Scene(100, 0.37, 0.35, 51);
  const Sim3RansacResult a = run(s, {}, 123);
  const Sim3RansacResult b = run(s, {}, 123);
  ASSERT_TRUE(a.success) << a.message;
  EXPECT_EQ(a.S12.s, b.S12.s);
  EXPECT_EQ(a.S12.R, b.S12.R);
  EXPECT_EQ(a.S12.t, b.S12.t);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.message, b.message);
  // The generator is the only source of randomness: it advances, and another state gives another sample path.
  std::mt19937 rng(123);
  estimateSim3Ransac(s.matches, kCam1.K(), kCam2.K(), {}, rng);
  EXPECT_NE(rng, std::mt19937(123));
}

TEST(Sim3Solver, InvalidInput) {
  Sim3Scene s = makeSim3Scene(30, 1.0, 0.0, 61);
  auto nan = s;
  nan.matches[4].p1.y() = std::nan("");
  EXPECT_EQ(run(nan, {}, 1).failure, Sim3Failure::InvalidInput);
  auto zeroVar = s;
  zeroVar.matches[7].sigma2_2 = 0.0;
  EXPECT_EQ(run(zeroVar, {}, 1).failure, Sim3Failure::InvalidInput);
  std::mt19937 rng(1);
  Eigen::Matrix3d badK = kCam1.K();
  badK(0, 0) = -1.0;
  EXPECT_THROW(estimateSim3Ransac(s.matches, badK, kCam2.K(), {}, rng), pslam::Error);
}

TEST(Sim3Solver, ParamsCheck) {
  EXPECT_NO_THROW(Sim3RansacParams{}.check());
  auto expectRejected = [](const Sim3RansacParams& p, const std::string& field) {
    try {
      p.check();
      ADD_FAILURE() << field << " accepted";
    } catch (const pslam::Error& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  Sim3RansacParams p;
  p.chi2 = 0.0;
  expectRejected(p, "chi2");
  p = {};
  p.chi2 = -1.0;
  expectRejected(p, "chi2");
  p = {};
  p.minInliers = 2;
  expectRejected(p, "minInliers");
  for (double prob : {0.0, 1.0, -0.5, 1.5}) {
    p = {};
    p.probability = prob;
    expectRejected(p, "probability");
  }
  p = {};
  p.maxIterations = 0;
  expectRejected(p, "maxIterations");
  // The estimator checks its params first.
  std::mt19937 rng(1);
  EXPECT_THROW(estimateSim3Ransac({}, kCam1.K(), kCam2.K(), p, rng), pslam::Error);

  mrpt::config::CConfigFileMemory cfg;
  Sim3RansacParams saved;
  saved.minInliers = 25;
  saved.chi2 = 7.5;
  saved.saveToConfigFile(cfg);
  Sim3RansacParams loaded;
  loaded.loadFromConfigFile(cfg);
  EXPECT_EQ(loaded.minInliers, 25);
  EXPECT_EQ(loaded.chi2, 7.5);
}
