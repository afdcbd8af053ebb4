// Translation with known rotation (eqs. 2.34 / 4.1) against synthetic ground truth, with noise and outliers.
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Geometry>

#include "pslam/core/Error.h"
#include "pslam/manhattan/TranslationSolver.h"

using namespace pslam::manhattan;

namespace {

struct Scene {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  std::vector<Eigen::Vector3d> Xprev, fPrev, fCur;
  std::vector<Eigen::Vector2d> xCur;
  std::vector<bool> isOutlier;
};

/// Points in front of both cameras; image noise in normalized coordinates (1 px at f = 500 is 0.002).
Scene makeScene(std::mt19937& rng, int n, double noise, double outlierShare) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> g(0, 1);
  Scene s;
  s.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  s.t = Eigen::Vector3d(0.4, -0.1, 0.2);
  std::bernoulli_distribution outlier(outlierShare);
  while (static_cast<int>(s.Xprev.size()) < n) {
    const Eigen::Vector3d X(2 * u(rng), 1.5 * u(rng), 4 + 2 * u(rng));
    const Eigen::Vector3d Xc = s.R * X + s.t;
    if (Xc.z() < 0.5) continue;
    Eigen::Vector2d xp = X.head<2>() / X.z() + noise * Eigen::Vector2d(g(rng), g(rng));
    Eigen::Vector2d xc = Xc.head<2>() / Xc.z() + noise * Eigen::Vector2d(g(rng), g(rng));
    const bool out = outlier(rng);
    if (out) xc = Eigen::Vector2d(0.6 * u(rng), 0.5 * u(rng));
    s.Xprev.push_back(X);
    s.fPrev.push_back(Eigen::Vector3d(xp.x(), xp.y(), 1.0));
    s.fCur.push_back(Eigen::Vector3d(xc.x(), xc.y(), 1.0));
    s.xCur.push_back(xc);
    s.isOutlier.push_back(out);
  }
  return s;
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace

TEST(TranslationSolver, ExactDirectionAndSignWithoutNoise) {
  std::mt19937 rng(1);
  const Scene s = makeScene(rng, 10, 0.0, 0.0);
  const Eigen::Vector3d t = solveTranslationDirection(s.fPrev, s.fCur, s.R);
  EXPECT_NEAR(t.norm(), 1.0, 1e-12);
  EXPECT_LT((t - s.t.normalized()).norm(), 1e-9);  // including the sign (cheirality)
  const Eigen::Vector3d tm = solveTranslationMetric(s.Xprev, s.xCur, s.R);
  EXPECT_LT((tm - s.t).norm(), 1e-9);
  // Minimal case: two points.
  EXPECT_LT((solveTranslationMetric({s.Xprev[0], s.Xprev[1]}, {s.xCur[0], s.xCur[1]}, s.R) - s.t).norm(), 1e-9);
}

TEST(TranslationSolver, RansacRecoversTranslationWithNoiseAndOutliers) {
  std::mt19937 rng(2);
  const Scene s = makeScene(rng, 200, 0.001, 0.3);
  TranslationRansacParams p;
  p.inlierThreshold = 0.004;
  const TranslationEstimate dir = ransacTranslationDirection(s.fPrev, s.fCur, s.R, p);
  ASSERT_TRUE(dir.valid);
  EXPECT_LT(angleDeg(dir.t_cur_prev, s.t), 1.5);
  EXPECT_GT(dir.t_cur_prev.dot(s.t), 0);
  const TranslationEstimate met = ransacTranslationMetric(s.Xprev, s.xCur, s.R, p);
  ASSERT_TRUE(met.valid);
  EXPECT_LT((met.t_cur_prev - s.t).norm(), 0.02);  // 2 cm at 4 m depth, 0.5 px noise
  std::size_t outliersAccepted = 0, outliers = 0;
  for (std::size_t i = 0; i < s.isOutlier.size(); ++i) {
    outliers += s.isOutlier[i];
    outliersAccepted += s.isOutlier[i] && met.inliers[i];
  }
  EXPECT_LT(outliersAccepted, outliers / 10 + 1);
  // Least squares on all points (no RANSAC) is visibly worse: the outliers matter.
  EXPECT_GT((solveTranslationMetric(s.Xprev, s.xCur, s.R) - s.t).norm(), (met.t_cur_prev - s.t).norm());
}

TEST(TranslationSolver, SeededAndDeterministic) {
  std::mt19937 rng(3);
  const Scene s = makeScene(rng, 100, 0.001, 0.4);
  const TranslationRansacParams p;
  const auto a = ransacTranslationMetric(s.Xprev, s.xCur, s.R, p);
  const auto b = ransacTranslationMetric(s.Xprev, s.xCur, s.R, p);
  EXPECT_EQ(a.t_cur_prev, b.t_cur_prev);
  EXPECT_EQ(a.inliers, b.inliers);
}

TEST(TranslationSolver, RejectsBadInput) {
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  EXPECT_THROW(solveTranslationDirection({Eigen::Vector3d(0, 0, 1)}, {Eigen::Vector3d(0, 0, 1)}, R), pslam::Error);
  EXPECT_THROW(solveTranslationMetric({Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1)},
                                      {Eigen::Vector2d(0, 0)}, R),
               pslam::Error);
  EXPECT_THROW(solveTranslationDirection({Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(NAN, 0, 1)},
                                         {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 0, 1)}, R),
               pslam::Error);
  EXPECT_THROW(solveTranslationMetric({Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1)},
                                      {Eigen::Vector2d(0, 0), Eigen::Vector2d(0, 0)}, 2.0 * R),
               pslam::Error);
  TranslationRansacParams p;
  p.confidence = 1.5;
  EXPECT_THROW(p.check(), pslam::Error);
}
