#pragma once
// The Slurm back end (doc/batch.md): one sbatch job array per `submit`, one task per run to do. Each task runs
// `slam-batch run-one MANIFEST --out OUTPUT --tasks TASKS --index $SLURM_ARRAY_TASK_ID`, which executes that run
// exactly as `slam-batch run` does (temporary folder, run.json, rename), so a run folder does not depend on the
// back end that produced it. Files under <output>/slurm/:
//   <stamp>.sbatch  the submitted script          <stamp>.tasks  one run id per line (task i = line i+1)
//   logs/<job>_<task>.out  a task's own output    jobs.txt       "<job id> <stamp> <tasks>" per submission
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "pslam/batch/Manifest.h"

namespace pslam::batch {

struct SlurmOptions {
  std::string partition;  ///< --partition (empty: the cluster's default)
  std::string time;       ///< --time per task, e.g. 01:00:00 (empty: the partition's default)
  std::string mem;        ///< --mem per task, e.g. 2G (empty: the default)
  std::size_t maxParallel = 0;  ///< array throttle "%N" (0 = no limit)
  bool dryRun = false;    ///< write the files, do not call sbatch
};

struct SlurmSubmission {
  std::string jobId;  ///< empty for a dry run
  std::filesystem::path script, tasks;
  std::size_t taskCount = 0;
};

/// Writes the array script and task list for `runs` and submits it with `sbatch --parsable`. Throws
/// pslam::Error with sbatch's message when it fails or is not installed.
SlurmSubmission submitToSlurm(const Manifest& m, const std::vector<const RunSpec*>& runs, const SlurmOptions& o);

/// The sbatch script text (exposed for tests).
std::string slurmScript(const Manifest& m, const std::filesystem::path& tasksFile, std::size_t taskCount,
                        const SlurmOptions& o, const std::string& cpusPerTask, const std::filesystem::path& logDir);

/// Run id -> Slurm state of every run this manifest's submissions listed: squeue's state (PENDING, RUNNING,
/// ...) while it lists the task, ENDED once the task has left the queue (done, or lost when its run folder is
/// missing: see slurm/logs/). `error` receives squeue's message when it cannot be asked (not installed, no
/// controller); the map is then empty.
std::map<std::string, std::string> slurmStates(const Manifest& m, std::string& error);

/// Line `index` (0-based) of a task file: the run id of that array task. Throws pslam::Error naming the file.
std::string taskRunId(const std::filesystem::path& tasksFile, std::size_t index);

struct CommandOutput {
  int exitCode = -1;
  std::string output;  ///< stdout and stderr together
};
/// Runs argv (no shell) and captures its output. exitCode 127 when it cannot be started.
CommandOutput runCommand(const std::vector<std::string>& argv);

}  // namespace pslam::batch
