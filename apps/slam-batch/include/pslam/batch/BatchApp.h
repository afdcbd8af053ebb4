#pragma once
// The slam-batch commands (doc/batch.md); main() only parses the command line into these calls. Each returns
// the process exit code and throws pslam::Error (one line naming the file at fault) for bad input.
#include <filesystem>
#include <string>

#include "pslam/batch/Runs.h"
#include "pslam/batch/Slurm.h"

namespace pslam::batch {

struct CommonOptions {
  std::filesystem::path manifest;
  std::filesystem::path out;  ///< overrides the manifest's output folder
  bool quiet = false;
};

/// Runs what is not done yet, `jobs` at a time; then, unless noCollect, collects. 0 when every run is ok.
int commandRun(const CommonOptions& c, std::size_t jobs, bool noCollect);
/// One run (a Slurm array task, or by hand): by id, or line `index` of a task file. 0 when it is ok.
int commandRunOne(const CommonOptions& c, const std::string& runId, const std::filesystem::path& tasks, long long index);
/// Writes and submits a job array of the runs not done. Prints the job id.
int commandSubmit(const CommonOptions& c, const SlurmOptions& o);
/// Done / failed / stale / pending per run, with Slurm's view of submitted ones. 0 when all are done.
int commandStatus(const CommonOptions& c, bool verbose);
/// Evaluates finished runs and writes results.csv, results.json, summary.md and the plots.
int commandCollect(const CommonOptions& c);

}  // namespace pslam::batch
