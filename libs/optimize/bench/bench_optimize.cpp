// Timings of the optimization back end on ORB-SLAM-sized synthetic problems (Google Benchmark).
//   bench_optimize --benchmark_min_time=1
// optimizePose: one frame with N map-point matches, 20 % outliers, pose 2 deg / 10 cm off.
// localBundleAdjustment: K keyframes (20 free local + K-20 fixed), P points each seen by W consecutive
// keyframes (W = 0: by every keyframe that sees it), ~5 % outliers, poses 0.3 deg / 2 cm off.
#include <benchmark/benchmark.h>

#include <random>

#include "SyntheticProblem.h"
#include "pslam/optimize/PoseOptimizer.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

static void BM_OptimizePose(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> ux(-3.0, 3.0), uy(-2.0, 2.0), uz(3.0, 10.0), u01(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  const auto cam = testCamera();
  const Eigen::Isometry3d T = arcPose(1, 3);
  std::vector<PoseObservation> obs;
  while (static_cast<int>(obs.size()) < n) {
    const Eigen::Vector3d pc(ux(rng), uy(rng), uz(rng));
    const Eigen::Vector2d px = cam.project(pc);
    if (!cam.inImage(px)) continue;
    PoseObservation o;
    o.p_world = T.inverse() * pc;
    o.pixel = u01(rng) < 0.2 ? px + Eigen::Vector2d(30.0, -25.0) : px + Eigen::Vector2d(g(rng), g(rng));
    obs.push_back(o);
  }
  const Eigen::Isometry3d start = perturb(T, 2.0 * M_PI / 180.0, 0.1, rng);
  int inliers = 0;
  for (auto _ : state) {
    const PoseOptimizationResult r = optimizePose(start, cam, obs);
    inliers = r.inliers;
    benchmark::DoNotOptimize(r.T_cam_world);
  }
  state.counters["observations"] = n;
  state.counters["inliers"] = inliers;
}
BENCHMARK(BM_OptimizePose)->Arg(300)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);

static void BM_LocalBundleAdjustment(benchmark::State& state) {
  SyntheticOptions opt;
  opt.keyframes = static_cast<int>(state.range(0));
  opt.fixedKeyFrames = opt.keyframes - 20;
  opt.points = static_cast<int>(state.range(1));
  opt.visibilityWindow = static_cast<int>(state.range(2));
  BundleAdjustmentParams params;
  params.linearSolver = state.range(3) ? "dense_schur" : "sparse_schur";
  opt.poseRotationNoise = 0.005;
  opt.poseTranslationNoise = 0.02;
  const SyntheticBA s = makeSyntheticBA(opt);
  BAResult r;
  for (auto _ : state) {
    r = localBundleAdjustment(s.problem, params);
    benchmark::DoNotOptimize(r.poses);
  }
  state.counters["keyframes"] = opt.keyframes;
  state.counters["points"] = static_cast<double>(s.problem.points.size());
  state.counters["observations"] = static_cast<double>(s.problem.observations.size());
  state.counters["iterations"] = r.iterations;
  state.counters["jacobian_ms"] = 1e3 * r.jacobianSeconds;
  state.counters["linsolve_ms"] = 1e3 * r.linearSolverSeconds;
  state.counters["rms_px_before"] = r.initialRmsPixels;
  state.counters["rms_px_after"] = r.finalRmsPixels;
}
// Args: keyframes, points, visibility window, dense Schur (0 = SPARSE_SCHUR / SuiteSparse, 1 = DENSE_SCHUR).
BENCHMARK(BM_LocalBundleAdjustment)
    ->Args({30, 3000, 6, 0})
    ->Args({30, 3000, 6, 1})
    ->Args({30, 6000, 6, 0})
    ->Args({30, 6000, 6, 1})
    ->Args({30, 2000, 0, 0})
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
