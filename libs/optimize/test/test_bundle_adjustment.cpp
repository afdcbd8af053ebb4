// Local and global bundle adjustment on synthetic scenes with ground truth: the error decreases, free
// poses and inverse depths are recovered in the gauge of the fixed keyframes, gross outliers are reported,
// runs are repeatable; and the round trip through pslam::map::Map.
#include <gtest/gtest.h>

#include <atomic>
#include <limits>

#include <mrpt/config/CConfigFileMemory.h>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/MapAdapter.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

TEST(LocalBA, NoiseFreeRecoversTruthDespiteOutliers) {
  // Exact observations plus 5 % gross outliers: after the two passes the free poses and inverse depths
  // must be the ground truth (the fixed keyframes fix the gauge, including the scale).
  SyntheticOptions opt;
  opt.noisePixels = 0.0;
  const SyntheticBA s = makeSyntheticBA(opt);
  ASSERT_GT(s.problem.points.size(), 300u);
  const BAResult r = localBundleAdjustment(s.problem);
  EXPECT_EQ(r.poses.size(), std::size_t(opt.keyframes - opt.fixedKeyFrames));
  for (int i = 0; i < opt.fixedKeyFrames; ++i) EXPECT_EQ(r.poses.count(i), 0u);
  for (const auto& [id, T] : r.poses) {
    const auto& truth = s.truth.keyframes.at(id).T_cam_world;
    EXPECT_GT(centreError(s.problem.keyframes.at(id).T_cam_world, truth), 0.04);  // really perturbed
    EXPECT_LT(rotationErrorRad(T, truth), 1e-7) << "keyframe " << id;
    EXPECT_LT(centreError(T, truth), 1e-6) << "keyframe " << id;
  }
  for (const auto& [id, rho] : r.inverseDepths)
    EXPECT_NEAR(rho / s.truth.points.at(id).inverseDepth, 1.0, 1e-6) << "point " << id;
  EXPECT_LT(r.finalRmsPixels, 1e-5);
  EXPECT_LT(r.finalCost, r.initialCost);
  // Exactly the gross outliers are reported.
  std::vector<std::size_t> gross;
  for (std::size_t i = 0; i < s.isOutlier.size(); ++i)
    if (s.isOutlier[i]) gross.push_back(i);
  EXPECT_GT(gross.size(), 20u);
  EXPECT_EQ(r.outliers, gross);
}

TEST(LocalBA, DenseSchurReachesTheSameMinimum) {
  SyntheticOptions opt;
  opt.points = 200;
  const SyntheticBA s = makeSyntheticBA(opt);
  BundleAdjustmentParams dense;
  dense.linearSolver = "dense_schur";
  const BAResult a = localBundleAdjustment(s.problem);
  const BAResult b = localBundleAdjustment(s.problem, dense);
  for (const auto& [id, T] : a.poses) {
    EXPECT_LT(rotationErrorRad(T, b.poses.at(id)), 1e-8);
    EXPECT_LT(centreError(T, b.poses.at(id)), 1e-7);
  }
  EXPECT_EQ(a.outliers, b.outliers);
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("ba", "linearSolver", "cholesky");
  BundleAdjustmentParams p;
  try {
    p.loadFromConfigFile(cfg, "ba");
    FAIL() << "unknown linearSolver accepted";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("linearSolver"), std::string::npos) << e.what();
  }
}

TEST(LocalBA, NoisyConvergesToTheOptimum) {
  SyntheticOptions opt;
  const SyntheticBA s = makeSyntheticBA(opt);
  const BAResult r = localBundleAdjustment(s.problem);
  // Reference minimum: the same cost solved to tight tolerance from the ground truth.
  BundleAdjustmentParams longRun;
  longRun.secondPassIterations = 200;
  longRun.functionTolerance = 1e-14;
  const BAResult ref = localBundleAdjustment(s.truth, longRun);
  EXPECT_LT(r.finalRmsPixels, 0.25 * r.initialRmsPixels);
  EXPECT_LT(r.finalRmsPixels, 2.0);  // noise: 1 px at level 0 .. 1.7 px at level 3
  for (const auto& [id, T] : r.poses) {
    const auto& truth = s.truth.keyframes.at(id).T_cam_world;
    const auto& start = s.problem.keyframes.at(id).T_cam_world;
    EXPECT_LT(rotationErrorRad(T, ref.poses.at(id)), 0.01 * M_PI / 180.0) << "keyframe " << id;
    EXPECT_LT(centreError(T, ref.poses.at(id)), 1e-3) << "keyframe " << id;
    // Estimation error at the optimum, far below the perturbation (0.57 deg, 5 cm).
    EXPECT_LT(rotationErrorRad(T, truth), 0.25 * M_PI / 180.0) << "keyframe " << id;
    EXPECT_LT(centreError(T, truth), 0.5 * centreError(start, truth)) << "keyframe " << id;
  }
  // Every gross outlier is reported; few true inliers are (chi2 at 95 %).
  std::set<std::size_t> reported(r.outliers.begin(), r.outliers.end());
  int gross = 0, caught = 0, falseAlarms = 0;
  for (std::size_t i = 0; i < s.isOutlier.size(); ++i) {
    gross += s.isOutlier[i];
    caught += s.isOutlier[i] && reported.count(i);
    falseAlarms += !s.isOutlier[i] && reported.count(i);
  }
  EXPECT_EQ(caught, gross);
  EXPECT_LT(falseAlarms, 0.1 * (s.isOutlier.size() - gross));
}

/// 200 points, 10 % of the observations gross outliers.
static SyntheticBA problemWithOutliers() {
  SyntheticOptions opt;
  opt.points = 200;
  opt.outlierFraction = 0.1;
  return makeSyntheticBA(opt);
}

TEST(LocalBA, DeterministicAndSecondPassMatters) {
  const SyntheticBA s = problemWithOutliers();
  const BAResult a = localBundleAdjustment(s.problem);
  const BAResult b = localBundleAdjustment(s.problem);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (const auto& [id, T] : a.poses) EXPECT_EQ(T.matrix(), b.poses.at(id).matrix());
  EXPECT_EQ(a.inverseDepths, b.inverseDepths);
  EXPECT_EQ(a.outliers, b.outliers);

  // With the Huber pass only, 10 % gross outliers bias the estimate more than after the clean second pass.
  BundleAdjustmentParams onePass;
  onePass.secondPassIterations = 0;
  const BAResult c = localBundleAdjustment(s.problem, onePass);
  double errTwo = 0.0, errOne = 0.0;
  for (const auto& [id, T] : a.poses) {
    errTwo += centreError(T, s.truth.keyframes.at(id).T_cam_world);
    errOne += centreError(c.poses.at(id), s.truth.keyframes.at(id).T_cam_world);
  }
  EXPECT_LT(errTwo, errOne);
}

// ORB-SLAM's abort flag: set before the solve, the first pass ends after Ceres' first iteration and the second
// pass is skipped; the result is still complete (poses, depths, outliers) and says it was stopped. Unset, the
// flag changes nothing.
TEST(LocalBA, StopFlagEndsTheSolveEarlyAndSkipsTheSecondPass) {
  const SyntheticBA s = problemWithOutliers();
  const BAResult full = localBundleAdjustment(s.problem);
  std::atomic<bool> stop{false};
  const BAResult unset = localBundleAdjustment(s.problem, {}, &stop);
  EXPECT_FALSE(unset.stopped);
  EXPECT_EQ(unset.iterations, full.iterations);
  EXPECT_EQ(unset.inverseDepths, full.inverseDepths);
  stop = true;
  const BAResult stopped = localBundleAdjustment(s.problem, {}, &stop);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_FALSE(full.stopped);
  EXPECT_LE(stopped.iterations, 2) << "the first pass went on after the stop request";
  EXPECT_GT(full.iterations, stopped.iterations);
  EXPECT_EQ(stopped.poses.size(), full.poses.size());
  EXPECT_EQ(stopped.inverseDepths.size(), full.inverseDepths.size());
  EXPECT_FALSE(stopped.outliers.empty());
  EXPECT_GE(stopped.finalCost, full.finalCost);
}

// The global BA honours the same flag (a loop closed while the previous loop's global BA runs stops it).
TEST(GlobalBA, StopFlagEndsTheSolveEarly) {
  const SyntheticBA s = problemWithOutliers();
  BundleAdjustmentParams params;
  params.globalIterations = 20;
  const BAResult full = globalBundleAdjustment(s.problem, params);
  std::atomic<bool> stop{false};
  const BAResult unset = globalBundleAdjustment(s.problem, params, &stop);
  EXPECT_FALSE(unset.stopped);
  EXPECT_EQ(unset.iterations, full.iterations);
  EXPECT_EQ(unset.inverseDepths, full.inverseDepths);
  stop = true;
  const BAResult stopped = globalBundleAdjustment(s.problem, params, &stop);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_LE(stopped.iterations, 1) << "the solve went on after the stop request";
  EXPECT_GT(full.iterations, 2);
  EXPECT_EQ(stopped.poses.size(), full.poses.size());
}

TEST(LocalBA, RejectsInconsistentInput) {
  SyntheticOptions opt;
  opt.points = 50;
  SyntheticBA s = makeSyntheticBA(opt);
  BAProblem noGauge = s.problem;
  for (auto& [id, kf] : noGauge.keyframes) kf.fixed = false;
  EXPECT_THROW(localBundleAdjustment(noGauge), pslam::Error);
  BAProblem unknown = s.problem;
  unknown.observations[0].keyframe = 999;
  EXPECT_THROW(localBundleAdjustment(unknown), pslam::Error);
  BAProblem nan = s.problem;
  nan.observations[1].pixel.y() = std::nan("");
  EXPECT_THROW(localBundleAdjustment(nan), pslam::Error);
  BundleAdjustmentParams p;
  p.maxLocalKeyFrames = 0;
  EXPECT_THROW(p.check(), pslam::Error);
}

TEST(GlobalBA, TwoViewInitialMap) {
  for (double noise : {0.0, 1.0}) {
    SyntheticOptions opt;
    opt.keyframes = 2;
    opt.fixedKeyFrames = 0;  // globalBundleAdjustment fixes the first itself
    opt.points = 300;
    opt.noisePixels = noise;
    opt.outlierFraction = 0.0;
    opt.poseRotationNoise = 0.005;
    opt.poseTranslationNoise = 0.03;
    const SyntheticBA s = makeSyntheticBA(opt);
    const BAResult r = globalBundleAdjustment(s.problem);
    EXPECT_EQ(r.poses.count(0), 0u);  // first keyframe fixed
    ASSERT_EQ(r.poses.count(1), 1u);
    EXPECT_LT(r.finalRmsPixels, r.initialRmsPixels);
    // Two views fix the relative pose T_1_0 up to scale: rotation and translation direction. (Keyframe 0 was
    // perturbed too and is held where it is, so only relative poses are comparable.)
    const Eigen::Isometry3d truth =
        s.truth.keyframes.at(1).T_cam_world * s.truth.keyframes.at(0).T_cam_world.inverse();
    const Eigen::Isometry3d estimate = r.poses.at(1) * s.problem.keyframes.at(0).T_cam_world.inverse();
    const Eigen::Vector3d c = estimate.inverse().translation(), ct = truth.inverse().translation();
    const double directionError = std::acos(std::min(1.0, c.normalized().dot(ct.normalized())));
    if (noise == 0.0) {
      EXPECT_LT(r.finalRmsPixels, 1e-5);
      EXPECT_LT(rotationErrorRad(estimate, truth), 1e-7);
      EXPECT_LT(directionError, 1e-6);
    } else {
      // Same minimum as a long solve from the ground truth (relative pose is gauge-free but for scale);
      // two narrow-angle views leave the rotation noticeably uncertain, hence the loose bound on the truth.
      BundleAdjustmentParams longRun;
      longRun.globalIterations = 200;
      longRun.functionTolerance = 1e-14;
      const BAResult ref = globalBundleAdjustment(s.truth, longRun);
      const Eigen::Isometry3d refRel = ref.poses.at(1) * s.truth.keyframes.at(0).T_cam_world.inverse();
      const Eigen::Vector3d cr = refRel.inverse().translation();
      EXPECT_LT(rotationErrorRad(estimate, refRel), 0.01 * M_PI / 180.0);
      EXPECT_LT(std::acos(std::min(1.0, c.normalized().dot(cr.normalized()))), 0.05 * M_PI / 180.0);
      EXPECT_LT(r.finalRmsPixels, 2.0);
      EXPECT_LT(rotationErrorRad(estimate, truth), 1.0 * M_PI / 180.0);
      EXPECT_LT(directionError, 3.0 * M_PI / 180.0);
    }
  }
}

namespace {

// A pslam::map::Map built from the synthetic problem: one keypoint per observation.
pslam::map::Map mapFromSynthetic(const SyntheticBA& s) {
  pslam::map::Map map;
  std::map<pslam::map::KeyFrameId, std::vector<const BAObservation*>> obsByKf;
  for (const BAObservation& o : s.problem.observations) obsByKf[o.keyframe].push_back(&o);
  std::map<std::pair<pslam::map::KeyFrameId, pslam::map::MapPointId>, std::size_t> keypointOf;
  for (const auto& [id, kf] : s.problem.keyframes) {
    pslam::map::KeyFrame k;
    k.T_cam_world = kf.T_cam_world;
    k.camera = kf.camera;
    k.setPyramid(8, 1.2);
    for (const BAObservation* o : obsByKf[id]) {
      const int level = static_cast<int>(std::lround(std::log(1.0 / o->invSigma2) / (2.0 * std::log(1.2))));
      keypointOf[{id, o->point}] = k.keypoints.size();
      k.keypoints.emplace_back(cv::Point2f(float(o->pixel.x()), float(o->pixel.y())), 31.f, 0.f, 1.f, level);
    }
    k.descriptors = cv::Mat(int(k.keypoints.size()), 32, CV_8UC1, cv::Scalar(0));
    const auto newId = map.addKeyFrame(std::move(k));
    EXPECT_EQ(newId, id);
  }
  std::map<pslam::map::MapPointId, pslam::map::MapPointId> newIds;
  for (const auto& [pid, p] : s.problem.points)
    newIds[pid] = map.addMapPointInverseDepth(p.anchor, keypointOf.at({p.anchor, pid}), p.bearing, p.inverseDepth);
  for (const BAObservation& o : s.problem.observations)
    map.addObservation(newIds.at(o.point), o.keyframe, keypointOf.at({o.keyframe, o.point}));
  return map;
}

}  // namespace

TEST(LocalBA, ThroughTheMap) {
  SyntheticOptions opt;
  opt.keyframes = 8;
  opt.fixedKeyFrames = 1;
  opt.points = 400;
  const SyntheticBA s = makeSyntheticBA(opt);
  pslam::map::Map map = mapFromSynthetic(s);
  ASSERT_NO_THROW(map.checkInvariants());
  const std::size_t observationsBefore = s.problem.observations.size();

  BundleAdjustmentParams params;
  params.maxLocalKeyFrames = 5;
  const pslam::map::KeyFrameId centre = 5;
  const BAProblem problem = makeLocalProblem(map, centre, params);
  const auto window = map.localWindow(centre, 5);
  int freeKfs = 0;
  for (const auto& [id, kf] : problem.keyframes) freeKfs += kf.fixed ? 0 : 1;
  const bool rootIsLocal = std::count(window.localKeyFrames.begin(), window.localKeyFrames.end(), 0u) > 0;
  EXPECT_EQ(freeKfs, rootIsLocal ? 4 : 5);  // local keyframes are free, except the root (gauge)
  EXPECT_EQ(problem.keyframes.size(), window.localKeyFrames.size() + window.fixedKeyFrames.size());

  const BAResult r = localBundleAdjustment(problem, params);
  EXPECT_LT(r.finalRmsPixels, 0.5 * r.initialRmsPixels);
  const MapUpdateSummary u = applyResult(map, problem, r);
  EXPECT_EQ(u.posesUpdated, freeKfs);
  EXPECT_GT(u.pointsUpdated, 100);
  EXPECT_EQ(u.observationsErased, static_cast<int>(r.outliers.size()));
  ASSERT_NO_THROW(map.checkInvariants());
  std::size_t observationsAfter = 0;
  for (const auto& [id, p] : map.mapPoints()) observationsAfter += p.numObservations();
  EXPECT_EQ(observationsAfter + u.observationsErased, observationsBefore);
  for (const auto& [id, T] : r.poses) EXPECT_EQ(map.keyFrame(id).T_cam_world.matrix(), T.matrix());

  // A point filter (the probabilistic model's activation) leaves the rejected points out entirely.
  const PointFilter evenOnly = [](const pslam::map::MapPoint& p) { return p.id % 2 == 0; };
  const BAProblem filtered = makeLocalProblem(map, centre, params, evenOnly);
  ASSERT_FALSE(filtered.points.empty());
  for (const auto& [id, p] : filtered.points) EXPECT_EQ(id % 2, 0u);
  for (const BAObservation& o : filtered.observations) EXPECT_EQ(o.point % 2, 0u);
  EXPECT_LT(filtered.points.size(), makeLocalProblem(map, centre, params).points.size());
}

TEST(GlobalBA, ThroughTheMapTwoView) {
  SyntheticOptions opt;
  opt.keyframes = 2;
  opt.fixedKeyFrames = 0;
  opt.points = 200;
  opt.noisePixels = 0.0;
  opt.outlierFraction = 0.0;
  SyntheticBA s = makeSyntheticBA(opt);
  s.problem.keyframes.at(0).T_cam_world = s.truth.keyframes.at(0).T_cam_world;  // the fixed first keyframe
  pslam::map::Map map = mapFromSynthetic(s);
  BAResult report;
  const MapUpdateSummary u = globalBundleAdjustment(map, {}, &report);
  EXPECT_EQ(u.posesUpdated, 1);
  EXPECT_EQ(u.observationsErased, 0);
  EXPECT_LT(report.finalRmsPixels, 1e-5);
  ASSERT_NO_THROW(map.checkInvariants());
  EXPECT_EQ(map.keyFrame(0).T_cam_world.matrix(), s.truth.keyframes.at(0).T_cam_world.matrix());
  // Noise-free: the relative rotation is exact, and every point reprojects exactly into both views.
  EXPECT_LT(rotationErrorRad(map.keyFrame(1).T_cam_world, s.truth.keyframes.at(1).T_cam_world), 1e-7);
  for (const auto& [id, p] : map.mapPoints())
    for (const auto& [kf, k] : p.observations) {
      const auto& keyframe = map.keyFrame(kf);
      const Eigen::Vector2d px = keyframe.camera.project(keyframe.T_cam_world * map.worldPosition(id));
      EXPECT_LT((px - keyframe.pixel(k)).norm(), 1e-3) << "point " << id << " keyframe " << kf;
    }
}

TEST(ApplyResult, APointTheBAPutAtOrBehindInfinityKeepsItsDepth) {
  // An inverse depth <= 0 has no finite position: written as 0 it made an infinitely far point that the next
  // frame's pose optimization refused (a threaded corridor-loop run stopped on it after a global BA).
  SyntheticOptions opt;
  opt.keyframes = 4;
  opt.fixedKeyFrames = 1;
  opt.points = 100;
  const SyntheticBA s = makeSyntheticBA(opt);
  pslam::map::Map map = mapFromSynthetic(s);
  const BAProblem problem = makeGlobalProblem(map);
  BAResult r = globalBundleAdjustment(problem, {});
  ASSERT_GE(r.inverseDepths.size(), 3u);
  auto it = r.inverseDepths.begin();
  const pslam::map::MapPointId atInfinity = (it++)->first, behind = (it++)->first, notFinite = (it++)->first;
  const double before[3] = {map.mapPoint(atInfinity).inverseDepth, map.mapPoint(behind).inverseDepth,
                            map.mapPoint(notFinite).inverseDepth};
  r.inverseDepths[atInfinity] = 0.0;
  r.inverseDepths[behind] = -0.2;
  r.inverseDepths[notFinite] = std::numeric_limits<double>::quiet_NaN();
  const MapUpdateSummary u = applyResult(map, problem, r, false);
  EXPECT_EQ(u.pointsNotMoved, 3);
  EXPECT_EQ(u.pointsUpdated, static_cast<int>(r.inverseDepths.size()) - 3);
  EXPECT_EQ(map.mapPoint(atInfinity).inverseDepth, before[0]);
  EXPECT_EQ(map.mapPoint(behind).inverseDepth, before[1]);
  EXPECT_EQ(map.mapPoint(notFinite).inverseDepth, before[2]);
  for (const auto& [id, p] : map.mapPoints()) EXPECT_TRUE(map.worldPosition(id).allFinite()) << id;
}
