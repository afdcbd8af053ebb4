#include "pslam/batch/Slurm.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "pslam/batch/Runs.h"
#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"

extern char** environ;

namespace pslam::batch {
namespace fs = std::filesystem;

namespace {

/// Single-quoted for a POSIX shell.
std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string timestamp() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  char out[48];
  std::snprintf(out, sizeof out, "%s-%03lld", buf, static_cast<long long>(ms));
  return out;
}

std::string trim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  std::size_t i = 0;
  while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
  return s.substr(i);
}

}  // namespace

CommandOutput runCommand(const std::vector<std::string>& argvIn) {
  CommandOutput out;
  int fds[2];
  if (::pipe(fds) != 0) return out;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  std::vector<std::string> args = argvIn;
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    out.exitCode = 127;
    out.output = args[0] + ": " + std::strerror(rc);
    return out;
  }
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n > 0) out.output.append(buf, static_cast<std::size_t>(n));
    else if (n == 0 || errno != EINTR) break;
  }
  ::close(fds[0]);
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
  }
  out.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return out;
}

std::string slurmScript(const Manifest& m, const fs::path& tasksFile, std::size_t taskCount, const SlurmOptions& o,
                        const std::string& cpusPerTask, const fs::path& logDir) {
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# slam-batch: " << taskCount << " run(s) of " << m.file.string() << ", one per array task\n"
    << "#SBATCH --job-name=" << "slam-batch-" << m.name << "\n"
    << "#SBATCH --array=0-" << (taskCount - 1);
  if (o.maxParallel > 0) s << "%" << o.maxParallel;
  s << "\n#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=" << cpusPerTask << "\n"
    << "#SBATCH --output=" << (logDir / "%A_%a.out").string() << "\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.time.empty()) s << "#SBATCH --time=" << o.time << "\n";
  if (!o.mem.empty()) s << "#SBATCH --mem=" << o.mem << "\n";
  s << "# Slurm sends SIGTERM at the time limit: slam-batch then stops slam-run and removes the half-done run.\n"
    << "exec " << shellQuote(selfExecutable().string()) << " run-one " << shellQuote(m.file.string()) << " --out "
    << shellQuote(m.output.string()) << " --tasks " << shellQuote(tasksFile.string())
    << " --index \"$SLURM_ARRAY_TASK_ID\"\n";
  return s.str();
}

SlurmSubmission submitToSlurm(const Manifest& m, const std::vector<const RunSpec*>& runs, const SlurmOptions& o) {
  require(!runs.empty(), m.file.string(), "nothing to submit: every run is done");
  slamRunExecutable(m);  // fail now, not in every task
  // Sequential runs use one CPU; a threaded variant (local mapping in a second thread) two.
  std::string cpus = "1";
  for (const RunSpec* r : runs)
    if (r->threaded) cpus = "2";

  const fs::path dir = m.output / "slurm";
  const fs::path logDir = dir / "logs";
  std::error_code ec;
  fs::create_directories(logDir, ec);
  if (ec) throw Error(logDir.string() + ": cannot create (" + ec.message() + ")");
  const std::string stamp = timestamp();
  SlurmSubmission sub;
  sub.taskCount = runs.size();
  sub.tasks = dir / (stamp + ".tasks");
  sub.script = dir / (stamp + ".sbatch");
  writeFileAtomically(sub.tasks, [&](std::ostream& os) {
    for (const RunSpec* r : runs) os << r->id << "\n";
  });
  writeFileAtomically(sub.script, [&](std::ostream& os) { os << slurmScript(m, sub.tasks, runs.size(), o, cpus, logDir); });
  if (o.dryRun) return sub;

  const CommandOutput res = runCommand({"sbatch", "--parsable", sub.script.string()});
  if (res.exitCode != 0)
    throw Error("sbatch " + sub.script.string() + ": " +
                (res.exitCode == 127 ? std::string("sbatch not found (is Slurm installed and on PATH?)")
                                     : oneLineMessage(trim(res.output))));
  // --parsable prints "<job id>[;<cluster>]"
  std::string id = trim(res.output);
  if (const auto nl = id.rfind('\n'); nl != std::string::npos) id = id.substr(nl + 1);
  if (const auto semi = id.find(';'); semi != std::string::npos) id = id.substr(0, semi);
  require(!id.empty() && id.find_first_not_of("0123456789") == std::string::npos, "sbatch",
          "unexpected output '" + trim(res.output) + "' (expected a job id)");
  sub.jobId = id;
  std::ofstream jobs(dir / "jobs.txt", std::ios::app);
  jobs << id << " " << stamp << " " << runs.size() << "\n";
  if (!jobs) throw Error((dir / "jobs.txt").string() + ": cannot append the job id " + id);
  return sub;
}

std::string taskRunId(const fs::path& tasksFile, std::size_t index) {
  std::ifstream in(tasksFile);
  if (!in) throw Error(tasksFile.string() + ": task list not found");
  std::string line;
  for (std::size_t i = 0; std::getline(in, line); ++i)
    if (i == index) return trim(line);
  throw Error(tasksFile.string() + ": no task " + std::to_string(index));
}

std::map<std::string, std::string> slurmStates(const Manifest& m, std::string& error) {
  std::map<std::string, std::string> states;
  const fs::path dir = m.output / "slurm";
  std::ifstream jobs(dir / "jobs.txt");
  if (!jobs) return states;  // never submitted
  std::map<std::string, fs::path> tasksOf;
  std::string jobId, stamp;
  std::size_t count = 0;
  std::string list;
  while (jobs >> jobId >> stamp >> count) {
    tasksOf[jobId] = dir / (stamp + ".tasks");
    list += (list.empty() ? "" : ",") + jobId;
  }
  if (list.empty()) return states;
  auto markAllEnded = [&] {
    for (const auto& entry : tasksOf) {
      std::ifstream in(entry.second);
      for (std::string id; std::getline(in, id);)
        if (!trim(id).empty()) states[trim(id)] = "ENDED";
    }
  };
  const CommandOutput res = runCommand({"squeue", "--noheader", "--array", "--jobs=" + list, "--format=%i %T"});
  if (res.exitCode != 0) {
    // squeue says "Invalid job id specified" once every listed job has left the queue.
    if (res.output.find("Invalid job id") != std::string::npos) {
      markAllEnded();
      return states;
    }
    error = res.exitCode == 127 ? "squeue not found" : oneLineMessage(trim(res.output));
    return states;
  }
  // Every run a submission listed starts as ENDED (left the queue); squeue's lines then say which are not.
  markAllEnded();
  std::istringstream lines(res.output);
  std::string task, state;
  while (lines >> task >> state) {
    const auto us = task.find('_');
    if (us == std::string::npos) continue;
    const std::string job = task.substr(0, us), idx = task.substr(us + 1);
    auto it = tasksOf.find(job);
    if (it == tasksOf.end()) continue;
    if (idx.find_first_not_of("0123456789") != std::string::npos) {
      // a pending range "[0-3]": every listed index of it is pending
      const auto dash = idx.find('-');
      if (idx.size() < 3 || idx.front() != '[' || dash == std::string::npos) continue;
      std::size_t lo = 0, hi = 0;
      try {
        lo = std::stoul(idx.substr(1, dash - 1));
        hi = std::stoul(idx.substr(dash + 1));
      } catch (const std::exception&) {
        continue;
      }
      for (std::size_t i = lo; i <= hi; ++i) {
        try {
          states[taskRunId(it->second, i)] = state;
        } catch (const Error&) {
        }
      }
      continue;
    }
    try {
      states[taskRunId(it->second, std::stoul(idx))] = state;
    } catch (const std::exception&) {
    }
  }
  return states;
}

}  // namespace pslam::batch
