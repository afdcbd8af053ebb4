#pragma once
// Run folders and their execution (doc/batch.md). A run is executed in a temporary sibling folder
// (<dataset>/<variant>/.seed-<s>.tmp-<pid>) by a slam-run child process; when the child ends, run.json
// (status, hash, exit code, error line, times) is written into it and the folder is renamed into place. So a
// run folder is either complete (status ok or failed) or absent: an interrupted run leaves nothing.
//
// A run folder holds slam-run's outputs (trajectory.txt, keyframes.txt, map.slammap, depths.txt,
// report.json), config.ini (the effective configuration), log.txt (slam-run's output) and run.json.
#include <csignal>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <sys/types.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "pslam/batch/Manifest.h"

namespace pslam::batch {

/// What run.json records.
struct RunRecord {
  std::string status;       ///< "ok" | "failed"
  std::string hash;         ///< RunSpec::hash of the configuration it ran
  int exitCode = 0;         ///< slam-run's exit code; 128 + n for signal n
  std::string error;        ///< failed: the last non-empty line slam-run printed
  double wallSeconds = 0, cpuSeconds = 0;  ///< of the slam-run process (wait4's rusage)
  std::string host;
  std::vector<std::string> command;
  /// ok: the files of the run folder and their sizes in bytes when it was recorded (run.json and the files the
  /// record vouches for); a run is done only while they are there with these sizes.
  std::map<std::string, std::uintmax_t> outputs;
  nlohmann::json toJson() const;
  static RunRecord fromJson(const nlohmann::json& j);
};

enum class RunState {
  Pending,  ///< no run folder
  Done,     ///< status ok with the current hash, and its outputs there as recorded
  Failed,   ///< status failed with the current hash (run again by `run` and `submit`)
  Stale,    ///< a record of another configuration or input, or outputs missing or changed (run again)
};
const char* toString(RunState s);

/// The state of a run from its folder; `record` receives run.json when there is one (for a stale run whose
/// outputs do not match it, its `error` says which). Throws pslam::Error
/// naming the folder when it exists but is not a run folder (no run.json, or an unreadable one): slam-batch
/// never replaces what it did not write.
RunState runState(const Manifest& m, const RunSpec& run, RunRecord* record = nullptr);

/// The runs `run` and `submit` have to execute: pending, failed and stale ones.
std::vector<const RunSpec*> runsToDo(const Manifest& m);

/// Temporary folders of runs (`.seed-<s>.tmp-<pid>`, `.seed-<s>.old-<pid>`) whose process has ended without
/// removing them (kill -9, a crash, a power cut): of this host (their `.owner` file), with no process of that pid.
std::vector<std::filesystem::path> staleTemporaries(const Manifest& m);
/// Removes staleTemporaries(m); returns what it removed. `run` calls it under its lock of the output folder.
std::vector<std::filesystem::path> removeStaleTemporaries(const Manifest& m);

/// The slam-run executable of a manifest: its `slam_run`, else the slam-run next to this executable.
std::filesystem::path slamRunExecutable(const Manifest& m);
/// This process's executable (/proc/self/exe).
std::filesystem::path selfExecutable();

/// One run in flight: its child process and temporary folder.
class RunExecution {
 public:
  /// Creates the temporary folder, writes config.ini and starts slam-run (output into log.txt). Throws
  /// pslam::Error when the folder cannot be created or the process not started, and then leaves no temporary.
  /// The child gets SIGTERM when this process dies, however it dies (PR_SET_PDEATHSIG): no orphaned slam-run
  /// goes on writing into a folder nobody will rename.
  RunExecution(const Manifest& m, const RunSpec& run);
  ~RunExecution();  ///< removes the temporary folder if not finished
  RunExecution(const RunExecution&) = delete;
  RunExecution& operator=(const RunExecution&) = delete;

  pid_t pid() const { return pid_; }
  const RunSpec& run() const { return *run_; }
  double elapsedSeconds() const;
  /// Records the child's end (status as from wait4, its CPU seconds), writes run.json and moves the folder into
  /// place (replacing an earlier record of this run). Returns the record.
  RunRecord finish(int waitStatus, double cpuSeconds);
  /// Sends `sig` to the child (no-op when it has ended).
  void signal(int sig) const;
  /// The caller has reaped the child without finish() (a stop): the destructor then only removes the temporary.
  void markReaped() { pid_ = -1; }

 private:
  void start();  ///< writes the run's files and starts the child
  const Manifest* manifest_;
  const RunSpec* run_;
  std::filesystem::path temp_, final_;
  std::vector<std::string> command_;
  pid_t pid_ = -1;
  double start_ = 0;
  bool finished_ = false;
};

/// Stop requests: SIGINT, SIGTERM and SIGHUP set a flag (no SA_RESTART) that the run loops poll; they then
/// stop their children, remove the temporary folders and end the process with that signal.
void installStopHandlers();
/// The signal that asked us to stop, or 0.
int stopSignal();
/// Restores the default action of `sig` and raises it (the process ends as if it had not been caught).
[[noreturn]] void reraise(int sig);

struct LocalRunOptions {
  std::size_t jobs = 1;       ///< processes at a time
  bool progress = true;       ///< one line per finished run on stderr
};

struct LocalRunSummary {
  std::size_t skipped = 0, ok = 0, failed = 0;
};

/// Runs `runs` (of `m`) locally, `jobs` at a time. A failed run is recorded and the others go on. On a stop
/// signal: the children are stopped, their temporaries removed, and the process ends with that signal.
LocalRunSummary runLocally(const Manifest& m, const std::vector<const RunSpec*>& runs, const LocalRunOptions& o,
                           std::size_t skipped);

}  // namespace pslam::batch
