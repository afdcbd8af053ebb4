#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "TestUtil.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Metrics.h"

using namespace pslam;
using namespace pslam::eval;
using pslam::eval::test::makeSpiral;

namespace {
// The estimate as the GT seen through an unknown similarity: p_est = (R^T (p_gt - t)) / s, R_est = R^T R_gt,
// so that the true alignment est -> gt is (s, R, t).
Trajectory distort(const Trajectory& gt, double s, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Trajectory est = gt;
  for (auto& p : est) {
    p.position = R.transpose() * (p.position - t) / s;
    p.orientation = Eigen::Quaterniond(R.transpose()) * p.orientation;
  }
  return est;
}
const Eigen::Matrix3d kR =
    (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
const Eigen::Vector3d kT(0.3, -1.2, 2.5);
}  // namespace

TEST(Statistics, MatchNumpyDefinitions) {
  const ErrorStatistics s = computeStatistics({1.0, 2.0, 3.0, 10.0});
  EXPECT_DOUBLE_EQ(s.mean, 4.0);
  EXPECT_DOUBLE_EQ(s.median, 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.std, std::sqrt((9.0 + 4.0 + 1.0 + 36.0) / 4.0));  // ddof = 0
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt((1.0 + 4.0 + 9.0 + 100.0) / 4.0));
  EXPECT_DOUBLE_EQ(s.sse, 114.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 10.0);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(computeStatistics({3.0, 1.0, 2.0}).median, 2.0);
  EXPECT_THROW(computeStatistics({}), Error);
  EXPECT_THROW(computeStatistics({1.0, NAN}), Error);
}

TEST(Alignment, RecoversAKnownSim3AndGivesZeroAte) {
  const Trajectory gt = makeSpiral(60);
  const Trajectory est = distort(gt, 2.5, kR, kT);
  const Alignment a = alignTrajectories(gt, est, AlignmentMode::Sim3);
  EXPECT_NEAR(a.scale, 2.5, 1e-10);
  EXPECT_TRUE(a.rotation.isApprox(kR, 1e-10));
  EXPECT_TRUE(a.translation.isApprox(kT, 1e-10));
  const Trajectory aligned = applyAlignment(est, a);
  EXPECT_LT(computeAte(gt, aligned).stats.max, 1e-10);
  // Orientations are rotated too: RE and RPE rotation vanish, and RPE translation too (scale corrected).
  EXPECT_LT(computeRotationError(gt, aligned).stats.max, 1e-6);
  const RpeResult rpe = computeRpe(gt, aligned, RpeOptions{});
  EXPECT_LT(rpe.translation.max, 1e-10);
  EXPECT_LT(rpe.rotation.max, 1e-6);
  // SE(3) cannot absorb the scale: a positive ATE remains.
  const Alignment rigid = alignTrajectories(gt, est, AlignmentMode::SE3);
  EXPECT_DOUBLE_EQ(rigid.scale, 1.0);
  EXPECT_GT(computeAte(gt, applyAlignment(est, rigid)).stats.rmse, 0.1);
}

TEST(Alignment, SE3RecoversARigidMotionAndFirstNUsesOnlyThosePoses) {
  const Trajectory gt = makeSpiral(60);
  Trajectory est = distort(gt, 1.0, kR, kT);
  const Alignment a = alignTrajectories(gt, est, AlignmentMode::SE3);
  EXPECT_TRUE(a.rotation.isApprox(kR, 1e-10));
  // Corrupt the tail: aligning on the first 20 poses still recovers the exact motion.
  for (std::size_t k = 30; k < est.size(); ++k) est[k].position += Eigen::Vector3d(5, 0, 0);
  const Alignment first = alignTrajectories(gt, est, AlignmentMode::SE3, 20);
  EXPECT_TRUE(first.rotation.isApprox(kR, 1e-10));
  EXPECT_TRUE(first.translation.isApprox(kT, 1e-10));
  const AteResult ate = computeAte(gt, applyAlignment(est, first));
  EXPECT_LT(ate.errors[10], 1e-10);
  EXPECT_NEAR(ate.errors[40], 5.0, 1e-9);
}

TEST(Alignment, RejectsTooFewAndDegeneratePoses) {
  const Trajectory gt = makeSpiral(10);
  EXPECT_THROW(alignTrajectories(gt, gt, AlignmentMode::Sim3, 2), Error);
  Trajectory line = gt;
  for (std::size_t k = 0; k < line.size(); ++k) line[k].position = Eigen::Vector3d(double(k), 0, 0);
  EXPECT_THROW(alignTrajectories(gt, line, AlignmentMode::SE3), Error);
  EXPECT_THROW(alignTrajectories(gt, Trajectory(gt.begin(), gt.begin() + 5), AlignmentMode::SE3), Error);
  const Alignment none = alignTrajectories(gt, line, AlignmentMode::None);
  EXPECT_DOUBLE_EQ(none.scale, 1.0);
}

TEST(Segments, EachSegmentRecoversItsOwnScaleWhereOneAlignmentCannot) {
  // An estimate whose scale jumps between three stretches of the path (a monocular map's scale drift, made
  // piecewise): 1.5 on pairs 0-33, 2.0 on 34-66, 2.5 on 67-99 (100 = 34 + 33 + 33: the first segment is the longer).
  const Trajectory gt = makeSpiral(100);
  Trajectory est;
  const double scales[] = {1.5, 2.0, 2.5};
  const Eigen::Vector3d shifts[] = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.4, 0, 0), Eigen::Vector3d(0, 0.7, 0)};
  for (std::size_t k = 0; k < gt.size(); ++k) {
    const int part = k < 34 ? 0 : (k < 67 ? 1 : 2);
    est.push_back(distort(Trajectory{gt[k]}, scales[part], kR, kT + shifts[part]).front());
  }
  const double whole = computeAte(gt, applyAlignment(est, alignTrajectories(gt, est, AlignmentMode::Sim3))).stats.rmse;
  EXPECT_GT(whole, 0.05);  // one Sim(3) cannot fit three scales

  const std::vector<SegmentAlignment> seg = alignSegments(gt, est, AlignmentMode::Sim3, 3);
  ASSERT_EQ(seg.size(), 3u);
  const std::size_t firsts[] = {0, 34, 67}, lasts[] = {33, 66, 99};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(seg[k].first, firsts[k]);
    EXPECT_EQ(seg[k].last, lasts[k]);
    EXPECT_NEAR(seg[k].alignment.scale, scales[k], 1e-9);
    EXPECT_LT(seg[k].ate.rmse, 1e-9);
    EXPECT_EQ(seg[k].ate.count, lasts[k] - firsts[k] + 1);
    EXPECT_DOUBLE_EQ(seg[k].startTime, gt[firsts[k]].timestamp);
    EXPECT_DOUBLE_EQ(seg[k].endTime, gt[lasts[k]].timestamp);
    double length = 0;
    for (std::size_t i = firsts[k] + 1; i <= lasts[k]; ++i) length += (gt[i].position - gt[i - 1].position).norm();
    EXPECT_NEAR(seg[k].pathLength, length, 1e-12);
  }
  const SegmentScaleRange range = segmentScaleRange(seg);
  EXPECT_NEAR(range.smallest, 1.5, 1e-9);
  EXPECT_NEAR(range.largest, 2.5, 1e-9);
  EXPECT_NEAR(range.spread(), 2.5 / 1.5 - 1.0, 1e-9);
  EXPECT_THROW(segmentScaleRange({}), Error);
  // Segments that straddle the jumps do not fit: 4 segments of 25 pairs, the second and third hold a jump.
  const std::vector<SegmentAlignment> four = alignSegments(gt, est, AlignmentMode::Sim3, 4);
  EXPECT_LT(four[0].ate.rmse, 1e-9);
  EXPECT_GT(four[1].ate.rmse, 1e-3);
  EXPECT_GT(four[2].ate.rmse, 1e-3);
  EXPECT_LT(four[3].ate.rmse, 1e-9);
  // One segment is the whole run.
  EXPECT_NEAR(alignSegments(gt, est, AlignmentMode::Sim3, 1).front().ate.rmse, whole, 1e-12);
}

TEST(Segments, RejectsNoSegmentTooShortSegmentsAndNamesTheDegenerateOne) {
  const Trajectory gt = makeSpiral(12);
  EXPECT_THROW(alignSegments(gt, gt, AlignmentMode::Sim3, 0), Error);
  EXPECT_NO_THROW(alignSegments(gt, gt, AlignmentMode::Sim3, 4));  // 3 pairs each
  EXPECT_THROW(alignSegments(gt, gt, AlignmentMode::Sim3, 5), Error);
  EXPECT_THROW(alignSegments(gt, Trajectory(gt.begin(), gt.begin() + 6), AlignmentMode::Sim3, 2), Error);
  Trajectory est = gt;
  for (std::size_t k = 6; k < 12; ++k) est[k].position = Eigen::Vector3d(double(k), 0, 0);  // collinear
  try {
    alignSegments(gt, est, AlignmentMode::Sim3, 2);
    FAIL() << "a collinear segment must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("segment 2 of 2 (pairs 6-11)"), std::string::npos) << e.what();
  }
}

TEST(Ate, NoiseOfKnownSizeGivesTheExpectedRmse) {
  // Isotropic Gaussian noise sigma per axis: E[|e|^2] = 3 sigma^2, so the RMSE is about sqrt(3) sigma. The
  // alignment absorbs ~6 of 3N degrees of freedom: expected RMSE sqrt(3 sigma^2 (N - 2) / N) ~ 0.99933 *
  // sqrt(3) sigma for N = 3000; the sampling error of the RMSE is ~ sqrt(3) sigma / sqrt(6N) ~ 1%.
  const double sigma = 0.01;
  const Trajectory gt = makeSpiral(3000);
  Trajectory est = distort(gt, 1.7, kR, kT);
  std::mt19937 rng(42);
  std::normal_distribution<double> n(0.0, sigma / 1.7);
  for (auto& p : est) p.position += Eigen::Vector3d(n(rng), n(rng), n(rng));
  const Alignment a = alignTrajectories(gt, est, AlignmentMode::Sim3);
  EXPECT_NEAR(a.scale, 1.7, 1.7 * 1e-3);
  const double rmse = computeAte(gt, applyAlignment(est, a)).stats.rmse;
  EXPECT_NEAR(rmse, std::sqrt(3.0) * sigma, 0.03 * std::sqrt(3.0) * sigma);
}

TEST(Rpe, HandComputedTinyCase) {
  // GT moves 1 m along x per frame without rotating. The estimate moves 1.1 m along x, then 1 m along x
  // while rotating by 10 deg about z at the second step. No alignment.
  Trajectory gt, est;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(k, 0, 0);
    gt.emplace_back(k, T);
  }
  Eigen::Isometry3d E0 = Eigen::Isometry3d::Identity(), E1 = E0, E2 = E0;
  E1.translation() = Eigen::Vector3d(1.1, 0, 0);
  E2.translation() = Eigen::Vector3d(2.1, 0, 0);
  E2.linear() = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  est.emplace_back(0, E0);
  est.emplace_back(1, E1);
  est.emplace_back(2, E2);
  const RpeResult r = computeRpe(gt, est, RpeOptions{});
  ASSERT_EQ(r.pairs.size(), 2u);
  // Pair (0,1): E = (I + 1x)^-1 (I + 1.1x) -> translation 0.1, no rotation.
  EXPECT_NEAR(r.translationErrors[0], 0.1, 1e-12);
  EXPECT_NEAR(r.rotationErrorsDeg[0], 0.0, 1e-9);
  // Pair (1,2): relative GT = 1 m along x; relative estimate = 1 m along x with Rz(10): E = [Rz(10) | 0].
  EXPECT_NEAR(r.translationErrors[1], 0.0, 1e-12);
  EXPECT_NEAR(r.rotationErrorsDeg[1], 10.0, 1e-9);
  EXPECT_NEAR(r.translation.rmse, std::sqrt(0.01 / 2.0), 1e-12);
  // delta 2 frames: the single pair (0, 2): E = (I+2x)^-1 [Rz | 2.1x] -> translation 0.1, rotation 10 deg.
  RpeOptions o;
  o.delta = 2;
  const RpeResult r2 = computeRpe(gt, est, o);
  ASSERT_EQ(r2.pairs.size(), 1u);
  EXPECT_NEAR(r2.translationErrors[0], 0.1, 1e-12);
  EXPECT_NEAR(r2.rotationErrorsDeg[0], 10.0, 1e-9);
}

TEST(Rpe, PairSelectionFollowsEvo) {
  // Poses 0.4 m apart along x.
  Trajectory t;
  for (int k = 0; k < 10; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.4 * k, 0, 0);
    t.emplace_back(k, T);
  }
  RpeOptions o;
  o.delta = 3;
  auto p = selectRpePairs(t, o);  // ids 0,3,6,9
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[2], std::make_pair(std::size_t(6), std::size_t(9)));
  o.allPairs = true;
  EXPECT_EQ(selectRpePairs(t, o).size(), 7u);  // (0,3) ... (6,9)
  // Metres, consecutive: the accumulator reaches 1 m at poses 3 (1.2), 6, 9 -> pairs (3,6), (6,9); pose 0
  // is not an id in evo.
  o = RpeOptions{};
  o.delta = 1.0;
  o.unit = DeltaUnit::Meters;
  p = selectRpePairs(t, o);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], std::make_pair(std::size_t(3), std::size_t(6)));
  // Metres, all pairs, tolerance 10%: arc lengths within [1.08, 1.32] -> 1.2 m = 3 steps.
  o.delta = 1.2;
  o.allPairs = true;
  p = selectRpePairs(t, o);
  ASSERT_EQ(p.size(), 7u);
  for (const auto& [i, j] : p) EXPECT_EQ(j, i + 3);
  o.delta = 100.0;
  EXPECT_THROW(selectRpePairs(t, o), Error);
  o.unit = DeltaUnit::Frames;
  o.delta = 1.5;
  EXPECT_THROW(selectRpePairs(t, o), Error);
}

TEST(RotationError, IsTheAngleBetweenOpticalAxes) {
  Trajectory gt = makeSpiral(5), est = gt;
  // A rotation about the camera's own z axis leaves the optical axis unchanged (RE 0), one about x tilts it.
  est[0].orientation = est[0].orientation * Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  est[1].orientation = est[1].orientation * Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
  const RotationErrorResult r = computeRotationError(gt, est);
  EXPECT_NEAR(r.errorsDeg[0], 0.0, 1e-6);
  EXPECT_NEAR(r.errorsDeg[1], 0.2 * 180.0 / M_PI, 1e-9);
  EXPECT_NEAR(r.stats.mean, 0.2 * 180.0 / M_PI / 5.0, 1e-9);
}

TEST(RotationAngle, MatchesAngleAxisIncludingNearPi) {
  for (double angle : {0.0, 1e-7, 0.3, 2.0, M_PI - 1e-6, M_PI}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Eigen::Vector3d(0.2, -0.5, 0.8).normalized()).toRotationMatrix();
    EXPECT_NEAR(rotationAngle(R), angle, 1e-9) << angle;
  }
}
