// semantic-model-bench: time of the per-observation operations of the keypoint model (Google Benchmark).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MeasurementVariance.h"

using namespace pslam::landmarks;

namespace {
struct Measurements {
  std::vector<double> d, alpha;
  std::vector<ClassVector> cnn;
  explicit Measurements(std::size_t n) {
    std::mt19937 rng(1);
    std::normal_distribution<double> noise(0.5, 0.02);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
      d.push_back(u(rng) < 0.8 ? noise(rng) : 10 * u(rng));
      alpha.push_back(u(rng));
      const double s = u(rng), dy = (1 - s) * u(rng);
      cnn.push_back({s, dy, 1 - s - dy});
    }
  }
};
}  // namespace

static void BM_DepthUpdate(benchmark::State& state) {
  const KeypointModel model{KeypointModelParams{}};
  const Measurements m(4096);
  KeypointState s = model.initialize(0.5, 0.01);
  std::size_t i = 0;
  for (auto _ : state) {
    model.updateDepth(s, m.d[i & 4095], 4e-4, m.alpha[i & 4095]);
    benchmark::DoNotOptimize(s);
    ++i;
  }
}
BENCHMARK(BM_DepthUpdate);

static void BM_SemanticObservation(benchmark::State& state) {
  const KeypointModel model{KeypointModelParams{}};
  const Measurements m(4096);
  KeypointState s = model.initialize(0.5, 0.01);
  std::size_t i = 0;
  for (auto _ : state) {
    model.addSemanticObservation(s, m.cnn[i & 4095], m.alpha[i & 4095]);
    benchmark::DoNotOptimize(s);
    ++i;
  }
}
BENCHMARK(BM_SemanticObservation);

static void BM_InlierRatio(benchmark::State& state) {
  const KeypointModel model{KeypointModelParams{}};
  KeypointState s = model.initialize(0.5, 0.01);
  model.addSemanticObservation(s, {0.7, 0.2, 0.1}, 0.9);
  for (auto _ : state) benchmark::DoNotOptimize(model.inlierRatio(s));
}
BENCHMARK(BM_InlierRatio);

static void BM_MeasurementVariance(benchmark::State& state) {
  const Eigen::Vector3d f = Eigen::Vector3d(0.1, -0.05, 1.0).normalized();
  const Eigen::Vector3d t(0.3, 0.01, 0.05);
  for (auto _ : state) benchmark::DoNotOptimize(depthUncertainty(f, 8.0, t, 718.0, 1.0));
}
BENCHMARK(BM_MeasurementVariance);

BENCHMARK_MAIN();
