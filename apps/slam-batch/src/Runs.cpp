#include "pslam/batch/Runs.h"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"

extern char** environ;

namespace pslam::batch {
namespace fs = std::filesystem;

// ---------------------------------------------------------------- records

nlohmann::json RunRecord::toJson() const {
  nlohmann::json j = {{"status", status},           {"hash", hash},       {"exit_code", exitCode},
                      {"error", error},             {"wall_s", wallSeconds}, {"cpu_s", cpuSeconds},
                      {"host", host},               {"command", command}};
  if (!outputs.empty()) j["outputs"] = outputs;
  return j;
}

RunRecord RunRecord::fromJson(const nlohmann::json& j) {
  RunRecord r;
  r.status = j.at("status").get<std::string>();
  r.hash = j.at("hash").get<std::string>();
  r.exitCode = j.value("exit_code", 0);
  r.error = j.value("error", std::string());
  r.wallSeconds = j.value("wall_s", 0.0);
  r.cpuSeconds = j.value("cpu_s", 0.0);
  r.host = j.value("host", std::string());
  r.command = j.value("command", std::vector<std::string>());
  r.outputs = j.value("outputs", std::map<std::string, std::uintmax_t>());
  if (r.status != "ok" && r.status != "failed") throw Error("status '" + r.status + "' is neither ok nor failed");
  return r;
}

const char* toString(RunState s) {
  switch (s) {
    case RunState::Pending: return "pending";
    case RunState::Done: return "done";
    case RunState::Failed: return "failed";
    case RunState::Stale: return "stale";
  }
  return "?";
}

RunState runState(const Manifest& m, const RunSpec& run, RunRecord* record) {
  const fs::path folder = m.runFolder(run);
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(folder, ec))) return RunState::Pending;
  const fs::path json = folder / "run.json";
  if (!fs::is_directory(fs::symlink_status(folder, ec)) || !fs::is_regular_file(json, ec))
    throw Error(folder.string() + ": exists but is not a slam-batch run folder (no run.json); move it away");
  RunRecord r;
  try {
    std::ifstream in(json);
    r = RunRecord::fromJson(nlohmann::json::parse(in));
  } catch (const std::exception& e) {
    throw Error(json.string() + ": not a valid run record (" + oneLineMessage(e) + "); remove the run folder");
  }
  if (record) *record = r;
  if (r.hash != run.hash) return RunState::Stale;
  if (r.status != "ok") return RunState::Failed;
  // Done only with what the record vouches for: a deleted or changed output makes the run stale (run again).
  std::string mismatch;
  if (r.outputs.empty()) mismatch = "run.json lists no outputs";
  for (const char* required : {"trajectory.txt", "report.json"})
    if (mismatch.empty() && !r.outputs.count(required)) mismatch = std::string(required) + ": not in run.json";
  for (const auto& [name, bytes] : r.outputs) {
    if (!mismatch.empty()) break;
    const fs::path f = folder / name;
    if (!fs::is_regular_file(f, ec)) mismatch = name + ": missing";
    else if (const auto now = fs::file_size(f, ec); now != bytes)
      mismatch = name + ": " + std::to_string(now) + " bytes, the record says " + std::to_string(bytes);
  }
  if (mismatch.empty()) return RunState::Done;
  if (record) record->error = folder.string() + ": outputs do not match run.json (" + mismatch + ")";
  return RunState::Stale;
}

namespace {
/// "<host> <pid>" of the process that made a temporary run folder (its `.owner` file).
const char* const kOwnerFile = ".owner";

std::string thisHost() {
  char buf[256] = {0};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "";
  return buf;
}

/// The pid in a temporary's name (".seed-1.tmp-123", ".seed-1.old-123"), or -1.
long long temporaryPid(const std::string& name) {
  static const std::regex re(R"(^\.seed-[0-9]+\.(tmp|old)-([0-9]{1,9})$)");
  std::smatch mm;
  return std::regex_match(name, mm, re) ? std::stoll(mm[2].str()) : -1;
}

bool processExists(long long pid) { return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM; }
}  // namespace

std::vector<fs::path> staleTemporaries(const Manifest& m) {
  std::set<fs::path> parents;
  for (const RunSpec& r : m.runs) parents.insert(m.runFolder(r).parent_path());
  const std::string host = thisHost();
  std::vector<fs::path> out;
  std::error_code ec;
  for (const fs::path& parent : parents) {
    if (!fs::is_directory(parent, ec)) continue;
    for (const auto& e : fs::directory_iterator(parent, ec)) {
      const long long pid = temporaryPid(e.path().filename().string());
      if (pid <= 0 || !e.is_directory(ec)) continue;
      std::ifstream owner(e.path() / kOwnerFile);
      std::string ownerHost;
      if (owner >> ownerHost && ownerHost != host) continue;  // another node's run (Slurm): not ours to judge
      if (!processExists(pid)) out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<fs::path> removeStaleTemporaries(const Manifest& m) {
  std::vector<fs::path> removed;
  for (const fs::path& p : staleTemporaries(m)) {
    std::error_code ec;
    fs::remove_all(p, ec);
    if (ec) throw Error(p.string() + ": cannot remove this stale temporary run folder (" + ec.message() + ")");
    removed.push_back(p);
  }
  return removed;
}

std::vector<const RunSpec*> runsToDo(const Manifest& m) {
  std::vector<const RunSpec*> out;
  for (const RunSpec& r : m.runs)
    if (runState(m, r) != RunState::Done) out.push_back(&r);
  return out;
}

fs::path selfExecutable() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("/proc/self/exe: cannot resolve this executable (" + ec.message() + ")");
  return p;
}

fs::path slamRunExecutable(const Manifest& m) {
  const fs::path p = m.slamRun.empty() ? selfExecutable().parent_path() / "slam-run" : m.slamRun;
  if (::access(p.c_str(), X_OK) != 0)
    throw Error(p.string() + ": slam-run executable not found (build it, or set slam_run in " + m.file.string() +
                ")");
  return p;
}

// ---------------------------------------------------------------- stop signals

namespace {
volatile std::sig_atomic_t g_stopSignal = 0;
extern "C" void onStopSignal(int sig) { g_stopSignal = sig; }

double nowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// The last non-empty line of a text file (slam-run's one-line error), at most 500 characters.
std::string lastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    // Progress lines end with carriage returns; keep their last segment.
    if (const auto cr = line.rfind('\r'); cr != std::string::npos) line = line.substr(cr + 1);
    if (!line.empty()) last = line;
  }
  if (last.size() > 500) last = last.substr(0, 500) + "...";
  return last;
}
}  // namespace

void installStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking call returns EINTR
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(sig, &sa, nullptr);
}

int stopSignal() { return static_cast<int>(g_stopSignal); }

void reraise(int sig) {
  std::cerr.flush();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
  std::_Exit(128 + sig);
}

// ---------------------------------------------------------------- one run

RunExecution::RunExecution(const Manifest& m, const RunSpec& run) : manifest_(&m), run_(&run) {
  final_ = m.runFolder(run);
  const fs::path parent = final_.parent_path();
  temp_ = parent / ("." + final_.filename().string() + ".tmp-" + std::to_string(::getpid()));
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(parent.string() + ": cannot create the run's folder (" + ec.message() + ")");
  fs::remove_all(temp_, ec);  // a leftover of an earlier process with our pid
  if (!fs::create_directory(temp_, ec) || ec)
    throw Error(temp_.string() + ": cannot create the run's temporary folder (" + ec.message() + ")");
  try {
    start();
  } catch (...) {
    // Nothing of a run that never started stays behind (a full disk left .seed-N.tmp-PID/config.ini).
    fs::remove_all(temp_, ec);
    throw;
  }
}

namespace {
/// Writes `text` to `file`; throws naming the file and the reason (ENOSPC, EFBIG, ...).
void writeRunFile(const fs::path& file, const std::string& text) {
  errno = 0;
  std::ofstream out(file);
  out << text;
  out.flush();
  if (!out) throw Error(file.string() + ": cannot write (" + std::strerror(errno ? errno : EIO) + ")");
  out.close();
  if (!out) throw Error(file.string() + ": cannot write (" + std::strerror(errno ? errno : EIO) + ")");
}
}  // namespace

void RunExecution::start() {
  const Manifest& m = *manifest_;
  const RunSpec& run = *run_;
  writeRunFile(temp_ / "config.ini", "; effective configuration of " + run.id + " (" + run.config.string() +
                                         " with its overrides)\n" + run.effectiveConfig);
  writeRunFile(temp_ / kOwnerFile, thisHost() + " " + std::to_string(::getpid()) + "\n");

  const DatasetSpec& d = m.dataset(run);
  command_ = {slamRunExecutable(m).string(), "--config", run.config.string(), "--rawlog", d.rawlog.string(),
              "--out", temp_.string(), "--seed", std::to_string(run.seed), "-q"};
  if (d.first) command_.insert(command_.end(), {"--first", std::to_string(*d.first)});
  if (d.last) command_.insert(command_.end(), {"--last", std::to_string(*d.last)});
  for (const std::string& o : run.overrides) command_.insert(command_.end(), {"--set", o});

  std::vector<char*> argv;
  for (std::string& a : command_) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string log = (temp_ / "log.txt").string();
  const pid_t parent = ::getpid();
  start_ = nowSeconds();
  // fork + exec rather than posix_spawn: the child must ask for PR_SET_PDEATHSIG before it runs slam-run, so
  // that a slam-batch ended by SIGKILL takes its runs with it. Only async-signal-safe calls after fork.
  const pid_t pid = ::fork();
  if (pid < 0) throw Error(command_[0] + ": cannot start (" + std::strerror(errno) + ")");
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(127);  // the parent died before the request took effect
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::signal(sig, SIG_DFL);
    const int in = ::open("/dev/null", O_RDONLY);
    const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || ::dup2(in, 0) < 0 || ::dup2(out, 1) < 0 || ::dup2(out, 2) < 0) ::_exit(127);
    ::execve(argv[0], argv.data(), environ);
    const char msg[] = "slam-batch: cannot execute slam-run\n";
    [[maybe_unused]] const auto n = ::write(2, msg, sizeof msg - 1);
    ::_exit(127);
  }
  pid_ = pid;
}

RunExecution::~RunExecution() {
  if (finished_) return;
  if (pid_ > 0) {  // still running (an exception on the way out): stop and reap it
    ::kill(pid_, SIGTERM);
    int st = 0;
    while (::waitpid(pid_, &st, 0) < 0 && errno == EINTR) {
    }
  }
  std::error_code ec;
  fs::remove_all(temp_, ec);
}

double RunExecution::elapsedSeconds() const { return nowSeconds() - start_; }

void RunExecution::signal(int sig) const {
  if (pid_ > 0) ::kill(pid_, sig);
}

RunRecord RunExecution::finish(int waitStatus, double cpuSeconds) {
  pid_ = -1;  // reaped by the caller
  RunRecord rec;
  rec.hash = run_->hash;
  rec.wallSeconds = elapsedSeconds();
  rec.cpuSeconds = cpuSeconds;
  rec.host = thisHost();
  rec.command = command_;
  if (WIFEXITED(waitStatus)) rec.exitCode = WEXITSTATUS(waitStatus);
  else if (WIFSIGNALED(waitStatus)) rec.exitCode = 128 + WTERMSIG(waitStatus);
  std::error_code ec;
  const bool outputs = fs::is_regular_file(temp_ / "trajectory.txt", ec) && fs::is_regular_file(temp_ / "report.json", ec);
  rec.status = rec.exitCode == 0 && outputs ? "ok" : "failed";
  if (rec.status == "failed") {
    rec.error = lastLine(temp_ / "log.txt");
    if (WIFSIGNALED(waitStatus))
      rec.error = "slam-run ended by signal " + std::to_string(WTERMSIG(waitStatus)) +
                  (rec.error.empty() ? "" : " (last output: " + rec.error + ")");
    else if (rec.exitCode == 0)
      rec.error = "slam-run exited 0 without writing its outputs";
    else if (rec.error.empty())
      rec.error = "slam-run exited with code " + std::to_string(rec.exitCode) + " and printed nothing";
  }
  if (rec.status == "ok")
    for (const auto& e : fs::directory_iterator(temp_, ec))
      if (e.is_regular_file(ec) && e.path().filename() != kOwnerFile)
        rec.outputs[e.path().filename().string()] = e.file_size(ec);
  fs::remove(temp_ / kOwnerFile, ec);
  {
    std::ostringstream text;
    text << std::setw(1) << rec.toJson() << "\n";
    writeRunFile(temp_ / "run.json", text.str());
  }
  // Replace an earlier record of this run (checked to be one) in two renames, so the folder is never absent
  // while holding something, and never half-written.
  const fs::path old = final_.parent_path() / ("." + final_.filename().string() + ".old-" + std::to_string(::getpid()));
  bool hadOld = false;
  if (fs::exists(fs::symlink_status(final_, ec))) {
    runState(*manifest_, *run_);  // throws if it is not a run folder
    fs::remove_all(old, ec);
    fs::rename(final_, old, ec);
    if (ec) throw Error(final_.string() + ": cannot move the earlier record aside (" + ec.message() + ")");
    hadOld = true;
  }
  fs::rename(temp_, final_, ec);
  if (ec) throw Error(final_.string() + ": cannot move the finished run into place (" + ec.message() + ")");
  finished_ = true;
  if (hadOld) fs::remove_all(old, ec);
  return rec;
}

// ---------------------------------------------------------------- local back end

LocalRunSummary runLocally(const Manifest& m, const std::vector<const RunSpec*>& runs, const LocalRunOptions& o,
                           std::size_t skipped) {
  require(o.jobs >= 1, "slam-batch", "--jobs must be >= 1");
  installStopHandlers();
  LocalRunSummary sum;
  sum.skipped = skipped;
  std::vector<std::unique_ptr<RunExecution>> active;
  std::size_t next = 0, finished = 0;
  const std::size_t total = runs.size();
  const int width = static_cast<int>(std::to_string(total).size());
  if (o.progress)
    std::cerr << "slam-batch: " << m.name << ": " << total << " run(s) to do, " << skipped
              << " already done; " << o.jobs << " at a time; run folders in " << m.output.string() << "\n";

  while (next < runs.size() || !active.empty()) {
    if (const int sig = stopSignal()) {
      for (auto& a : active) a->signal(SIGTERM);
      for (auto& a : active) {
        int st = 0;
        while (::waitpid(a->pid(), &st, 0) < 0 && errno == EINTR) {
        }
        a->markReaped();
      }
      const std::size_t interrupted = active.size();
      active.clear();  // removes their temporaries
      std::cerr << "\nslam-batch: stopped by signal " << sig << ": " << interrupted
                << " run(s) interrupted and removed; " << finished << " finished run(s) kept\n";
      reraise(sig);
    }
    while (active.size() < o.jobs && next < runs.size()) active.push_back(std::make_unique<RunExecution>(m, *runs[next++]));

    int status = 0;
    struct rusage ru {};
    const pid_t pid = ::wait4(-1, &status, WNOHANG, &ru);
    if (pid == 0 || (pid < 0 && errno == EINTR)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    if (pid < 0) throw Error(std::string("slam-batch: waiting for slam-run failed (") + std::strerror(errno) + ")");
    auto it = std::find_if(active.begin(), active.end(), [&](const auto& a) { return a->pid() == pid; });
    if (it == active.end()) continue;  // not one of ours
    const double cpu = ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    const std::string id = (*it)->run().id;
    const RunRecord rec = (*it)->finish(status, cpu);
    active.erase(it);
    ++finished;
    (rec.status == "ok" ? sum.ok : sum.failed)++;
    if (o.progress) {
      std::ostringstream line;
      line << "slam-batch: [" << std::setw(width) << finished << "/" << total << "] " << std::left << std::setw(6)
           << rec.status << std::right << " " << id << "  " << std::fixed << std::setprecision(1) << rec.wallSeconds
           << " s";
      if (rec.status != "ok") line << "  " << rec.error;
      std::cerr << line.str() << "\n";
    }
  }
  return sum;
}

}  // namespace pslam::batch
