#pragma once
// Per-stage wall-clock timings (extraction, matching, optimization, ...) for run reports and benchmarks.
#include <chrono>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pslam {

class StageTimings {
 public:
  void add(const std::string& stage, double milliseconds);
  /// Samples recorded per stage, in insertion order per stage.
  const std::map<std::string, std::vector<double>>& samples() const { return samples_; }
  /// {stage: {count, total_ms, mean_ms, median_ms, p90_ms, max_ms}}
  nlohmann::json summary() const;

 private:
  std::map<std::string, std::vector<double>> samples_;
};

/// Milliseconds of wall-clock time since `start`.
inline double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// CPU time of the whole process so far (all threads, OpenCV's workers included), in milliseconds: on a shared,
/// loaded machine a better estimate of the unloaded cost than wall-clock time, which includes waiting for a core.
double processCpuMs();

/// CPU time of the calling thread so far, in milliseconds (not counting other threads, OpenCV's workers
/// included): the cost of work that several threads share out.
double threadCpuMs();

/// Percentile (0..100) by linear interpolation between order statistics; NaN for an empty set.
double percentile(std::vector<double> values, double p);

/// Scoped timer: adds its lifetime to `timings` under `stage`.
class ScopedStage {
 public:
  ScopedStage(StageTimings& timings, std::string stage)
      : timings_(timings), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}
  ~ScopedStage() { timings_.add(stage_, msSince(start_) - excludedMs_); }
  /// Leaves `ms` of the scope out of its stage (a wait timed as a stage of its own inside it).
  void exclude(double ms) { excludedMs_ += ms; }

 private:
  StageTimings& timings_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
  double excludedMs_ = 0.0;
};

}  // namespace pslam
