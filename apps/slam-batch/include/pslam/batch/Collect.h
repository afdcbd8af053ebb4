#pragma once
// `slam-batch collect` (doc/batch.md): evaluates every finished run with the slam-eval library and writes,
// into the manifest's output folder, as one all-or-nothing set of outputs:
//   results.csv   one row per run: ids, status, tracking counts and the metrics. Only values that a run in
//                 sequential mode reproduces bit for bit, so two back ends give byte-identical files.
//   results.json  the same rows plus each run's wall and CPU time, host and error line, and the evaluation
//   summary.md    per dataset x variant: median over seeds [min, max] (the layout of thesis Tables 3.3/3.4)
//   ate_<dataset>.png  box plot of ATE RMSE per variant (box: quartiles, whiskers: min and max, dots: runs)
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pslam/batch/Manifest.h"

namespace pslam::batch {

struct RunResult {
  const RunSpec* run = nullptr;
  /// ok (evaluated) | failed (slam-run failed) | pending | stale (its record is of another configuration) |
  /// no-trajectory (ran, never initialized) | eval-failed (the evaluation raised an error)
  std::string status;
  std::string error;
  long long frames = -1, tracked = -1, initFrame = -1, keyFrames = -1, mapPoints = -1, resets = -1,
            relocalizations = -1;
  std::size_t posesEvaluated = 0;
  std::optional<double> ateRmse, ateMedian, rpeTranslationRmse, rotationErrorMean, depthRatio;
  double wallSeconds = 0, cpuSeconds = 0;
  std::string host;

  std::optional<double> trackedPercent() const;
  std::optional<double> cpuMsPerFrame() const;
};

/// Evaluates every run of the manifest (those not finished get their status and no metrics).
std::vector<RunResult> evaluateRuns(const Manifest& m, bool progress);

std::string resultsCsv(const Manifest& m, const std::vector<RunResult>& rows);
nlohmann::json resultsJson(const Manifest& m, const std::vector<RunResult>& rows);
std::string summaryMarkdown(const Manifest& m, const std::vector<RunResult>& rows);

/// Median and spread of a set of values (linear-interpolation quartiles, as numpy's default).
struct Spread {
  std::size_t count = 0;
  double min = 0, q1 = 0, median = 0, q3 = 0, max = 0;
};
Spread spreadOf(std::vector<double> values);

/// Writes results.csv, results.json, summary.md and the box plots (all or none); returns the written paths.
std::vector<std::filesystem::path> collect(const Manifest& m, const std::vector<RunResult>& rows);

}  // namespace pslam::batch
