// Timings of the geometry building blocks on the synthetic scenes of the tests (400 matches, 20 %
// outliers, 0.8 px noise). Run: bench_geometry [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include "SyntheticScene.h"
#include "pslam/geometry/Pnp.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/geometry/TwoViewInitializer.h"

using namespace pslam::geometry;
using namespace pslam::geometry::test;

namespace {
const Eigen::Matrix3d kR = rotationFromAxisAngle({0.2, 1.0, 0.1}, 4.0);

void runInitializer(benchmark::State& state, SceneShape shape, bool parallel, bool refine) {
  const Eigen::Vector3d t = shape == SceneShape::General ? Eigen::Vector3d(0.5, 0.08, 0.1) : Eigen::Vector3d(0.6, 0, 0.05);
  const TwoViewScene s = makeScene(shape, kR, t, 400, 0.8, 0.2, 1);
  TwoViewParams params;
  params.parallel = parallel;
  params.refinePose = refine;
  const TwoViewInitializer init(testCamera(), params);
  for (auto _ : state) {
    std::mt19937 rng(1);
    TwoViewResult r = init.initialize(s.pixels_ref, s.pixels_cur, rng);
    benchmark::DoNotOptimize(r);
  }
}
void BM_TwoViewGeneralParallel(benchmark::State& s) { runInitializer(s, SceneShape::General, true, true); }
void BM_TwoViewGeneralSequential(benchmark::State& s) { runInitializer(s, SceneShape::General, false, true); }
void BM_TwoViewGeneralNoRefinement(benchmark::State& s) { runInitializer(s, SceneShape::General, false, false); }
void BM_TwoViewPlanarParallel(benchmark::State& s) { runInitializer(s, SceneShape::Planar, true, true); }
void BM_TwoViewPlanarSequential(benchmark::State& s) { runInitializer(s, SceneShape::Planar, false, true); }

void BM_TriangulateDLT2(benchmark::State& state) {
  const PinholeCamera cam = testCamera();
  const Matrix34d P1 = projectionMatrix(cam.K(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const Matrix34d P2 = projectionMatrix(cam.K(), kR, Eigen::Vector3d(0.5, 0, 0));
  const Eigen::Vector3d X(0.3, -0.2, 5.0);
  const Eigen::Vector2d x1 = cam.project(X), x2 = cam.project(kR * X + Eigen::Vector3d(0.5, 0, 0));
  Eigen::Vector3d out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(triangulateDLT(P1, x1, P2, x2, out));
  }
}

void BM_PnpRansac(benchmark::State& state) {
  const TwoViewScene s = makeScene(SceneShape::General, kR, Eigen::Vector3d(0.5, 0.08, 0.1), 200, 1.0, 0.3, 2);
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& p : s.pixels_cur) pixels.emplace_back(p.x, p.y);
  for (auto _ : state) {
    PnpResult r = solvePnpRansac(testCamera(), s.points_ref, pixels);
    benchmark::DoNotOptimize(r);
  }
}
}  // namespace

BENCHMARK(BM_TwoViewGeneralParallel)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TwoViewGeneralSequential)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TwoViewGeneralNoRefinement)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TwoViewPlanarParallel)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TwoViewPlanarSequential)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TriangulateDLT2);
BENCHMARK(BM_PnpRansac)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
