#include "pslam/batch/BatchApp.h"

#include <fcntl.h>
#include <sys/file.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <map>

#include "pslam/batch/Collect.h"
#include "pslam/core/Error.h"

namespace pslam::batch {
namespace fs = std::filesystem;

namespace {
Manifest load(const CommonOptions& c) { return loadManifest(c.manifest, c.out); }
}  // namespace

int commandCollect(const CommonOptions& c) {
  const Manifest m = load(c);
  const std::vector<RunResult> rows = evaluateRuns(m, false);
  const std::vector<fs::path> written = collect(m, rows);
  std::size_t ok = 0;
  for (const RunResult& r : rows) ok += r.status == "ok";
  if (!c.quiet) {
    std::cerr << "slam-batch: collected " << ok << " evaluated run(s) of " << rows.size() << " into "
              << m.output.string() << ":";
    for (const fs::path& p : written) std::cerr << " " << p.filename().string();
    std::cerr << "\n";
  }
  return 0;
}

namespace {
/// One `run` per output folder at a time: an exclusive flock on <output>/.slam-batch.lock, released when the
/// process ends (however it ends).
void lockOutput(const Manifest& m) {
  std::error_code ec;
  fs::create_directories(m.output, ec);
  // The reason is the folder's (a read-only file system), not the lock file's "No such file or directory".
  if (ec) throw Error(m.output.string() + ": cannot create the output folder (" + ec.message() + ")");
  const fs::path lock = m.output / ".slam-batch.lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(lock.string() + ": cannot open (" + std::strerror(errno) + ")");
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0)
    throw Error(m.output.string() + ": another slam-batch run is working in this output folder");
  // fd stays open (and locked) until the process ends.
}
}  // namespace

int commandRun(const CommonOptions& c, std::size_t jobs, bool noCollect) {
  const Manifest m = load(c);
  lockOutput(m);
  // Under the lock no other `run` works here: temporaries of ended processes are leftovers (kill -9, a crash).
  const std::vector<fs::path> removed = removeStaleTemporaries(m);
  if (!c.quiet)
    for (const fs::path& p : removed) std::cerr << "slam-batch: removed the stale temporary " << p.string() << "\n";
  const std::vector<const RunSpec*> todo = runsToDo(m);
  LocalRunOptions o;
  o.jobs = jobs;
  o.progress = !c.quiet;
  const LocalRunSummary s = runLocally(m, todo, o, m.runs.size() - todo.size());
  if (!c.quiet)
    std::cerr << "slam-batch: " << s.ok << " ok, " << s.failed << " failed, " << s.skipped
              << " skipped (already done)\n";
  if (!noCollect) commandCollect(c);
  return s.failed == 0 ? 0 : 1;
}

int commandRunOne(const CommonOptions& c, const std::string& runIdIn, const fs::path& tasks, long long index) {
  const Manifest m = load(c);
  std::string runId = runIdIn;
  if (runId.empty()) {
    require(!tasks.empty() && index >= 0, "slam-batch run-one", "give --run ID, or --tasks FILE and --index I");
    runId = taskRunId(tasks, static_cast<std::size_t>(index));
  }
  const RunSpec* run = m.findRun(runId);
  require(run != nullptr, m.file.string(), "no run '" + runId + "' in this manifest");
  if (runState(m, *run) == RunState::Done) {
    if (!c.quiet) std::cerr << "slam-batch: " << runId << " is already done\n";
    return 0;
  }
  // The same execution as `run` (temporary folder, run.json, rename, stop signals), for this one run.
  LocalRunOptions o;
  o.progress = !c.quiet;
  return runLocally(m, {run}, o, 0).failed == 0 ? 0 : 1;
}

int commandSubmit(const CommonOptions& c, const SlurmOptions& o) {
  const Manifest m = load(c);
  const std::vector<const RunSpec*> todo = runsToDo(m);
  if (todo.empty()) {
    if (!c.quiet) std::cerr << "slam-batch: every run of " << m.name << " is done; nothing to submit\n";
    return 0;
  }
  const SlurmSubmission sub = submitToSlurm(m, todo, o);
  if (o.dryRun) {
    std::cerr << "slam-batch: dry run: " << sub.script.string() << " (" << sub.taskCount << " tasks) not submitted\n";
    return 0;
  }
  std::cout << sub.jobId << "\n";
  if (!c.quiet)
    std::cerr << "slam-batch: submitted job array " << sub.jobId << " (" << sub.taskCount << " tasks): "
              << sub.script.string() << "\n";
  return 0;
}

int commandStatus(const CommonOptions& c, bool verbose) {
  const Manifest m = load(c);
  std::string slurmError;
  const std::map<std::string, std::string> slurm = slurmStates(m, slurmError);
  std::map<std::string, std::size_t> counts;
  std::vector<std::string> lines;
  for (const RunSpec& r : m.runs) {
    RunRecord rec;
    const RunState s = runState(m, r, &rec);
    std::string state = toString(s);
    std::string note;
    if (s != RunState::Done) {
      if (auto it = slurm.find(r.id); it != slurm.end()) {
        if (it->second != "ENDED") {
          state = "slurm:" + it->second;  // queued or running (again, for a failed or stale run)
        } else if (s == RunState::Pending) {
          // Left the queue without a run folder (time limit with SIGKILL, node failure): its log says why.
          state = "slurm:ENDED";
          note = "  left the queue without a result; see " + (m.output / "slurm" / "logs").string();
        }
      }
    }
    counts[state]++;
    if (verbose || s == RunState::Failed || state.rfind("slurm:", 0) == 0 || s == RunState::Stale) {
      std::string line = "  " + r.id + "  " + state;
      if (s == RunState::Failed || (s == RunState::Stale && !rec.error.empty())) line += "  " + rec.error;
      line += note;
      lines.push_back(line);
    }
  }
  std::cout << m.name << ": " << m.runs.size() << " runs in " << m.output.string() << "\n ";
  for (const auto& [state, n] : counts) std::cout << " " << state << " " << n;
  std::cout << "\n";
  for (const std::string& l : lines) std::cout << l << "\n";
  for (const fs::path& p : staleTemporaries(m))
    std::cout << "  stale temporary " << p.string() << " (its process has ended; the next `run` removes it)\n";
  if (!slurmError.empty()) std::cout << "  (Slurm not asked: " << slurmError << ")\n";
  return counts["done"] == m.runs.size() ? 0 : 3;
}

}  // namespace pslam::batch
