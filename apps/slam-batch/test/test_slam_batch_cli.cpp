// End-to-end tests of the slam-batch tool (bin/slam-batch driving bin/slam-run) on two short synthetic
// sequences: run + collect, resume (finished runs skipped, changed ones redone), a failing run recorded while
// the others finish, an interrupt that leaves no half-written run folder, and manifest errors on the CLI.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <regex>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "BatchTestData.h"

extern char** environ;

using namespace batchtest;

namespace {

const fs::path& root() {
  static const TempRoot r("pslam_batch_e2e_");
  return r.path;
}

const std::vector<Dataset>& datasets() {
  static const std::vector<Dataset> d = {{"room", render(root(), "room", 40, 3)},
                                         {"street", render(root(), "street", 30, 1)}};
  return d;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// Every entry under `dir` whose name marks a temporary (".<name>.tmp-<pid>" / ".old-<pid>").
std::vector<fs::path> temporaries(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.find(".tmp-") != std::string::npos || n.find(".old-") != std::string::npos) out.push_back(e.path());
  }
  return out;
}

}  // namespace

TEST(SlamBatchCli, RunsCollectsAndResumesOnlyWhatChanged) {
  const fs::path manifest = writeManifest(root(), "resume.yaml", datasets());
  const ToolResult first = run(batch("run " + manifest.string() + " -j 2"));
  ASSERT_EQ(first.exitCode, 0) << first.output;
  const fs::path out = root() / "out";
  const std::vector<std::string> csv = lines(readText(out / "results.csv"));
  ASSERT_EQ(csv.size(), 5u) << readText(out / "results.csv");
  EXPECT_EQ(csv[0].rfind("run,dataset,variant,seed,status,", 0), 0u);
  for (std::size_t i = 1; i < csv.size(); ++i) EXPECT_NE(csv[i].find(",ok,"), std::string::npos) << csv[i];
  EXPECT_EQ(csv[1].rfind("room/heuristic/seed-1,room,heuristic,1,ok,40,", 0), 0u) << csv[1];
  for (const char* f : {"summary.md", "results.json", "ate_room.png", "ate_street.png"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;
  for (const char* f : {"trajectory.txt", "report.json", "map.slammap", "config.ini", "log.txt", "run.json"})
    EXPECT_TRUE(fs::is_regular_file(out / "street/probabilistic/seed-1" / f)) << f;
  EXPECT_NE(readText(out / "summary.md").find("| room | "), std::string::npos);
  EXPECT_TRUE(temporaries(out).empty());

  // Again: nothing to do, no run record touched.
  const auto recordTime = [&](const std::string& id) { return fs::last_write_time(out / id / "run.json"); };
  const auto heuristicTime = recordTime("room/heuristic/seed-1");
  const auto probabilisticTime = recordTime("room/probabilistic/seed-1");
  const ToolResult again = run(batch("run " + manifest.string() + " -j 2"));
  ASSERT_EQ(again.exitCode, 0) << again.output;
  EXPECT_NE(again.output.find("0 run(s) to do, 4 already done"), std::string::npos) << again.output;
  EXPECT_EQ(recordTime("room/heuristic/seed-1"), heuristicTime);
  const std::string csvBefore = readText(out / "results.csv");
  EXPECT_EQ(run(batch("status " + manifest.string())).exitCode, 0);

  // Change the probabilistic variant: its two runs are stale and redone, the heuristic ones are kept.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  writeManifest(root(), "resume.yaml", datasets(), ", Tracking.minInliersAfterReloc=45");
  const ToolResult status = run(batch("status " + manifest.string()));
  EXPECT_EQ(status.exitCode, 3) << status.output;
  EXPECT_NE(status.output.find("done 2 stale 2"), std::string::npos) << status.output;
  const ToolResult redo = run(batch("run " + manifest.string() + " -j 2"));
  ASSERT_EQ(redo.exitCode, 0) << redo.output;
  EXPECT_NE(redo.output.find("2 run(s) to do, 2 already done"), std::string::npos) << redo.output;
  EXPECT_EQ(recordTime("room/heuristic/seed-1"), heuristicTime);
  EXPECT_NE(recordTime("room/probabilistic/seed-1"), probabilisticTime);
  // That key does not change these runs (no relocalization here), and sequential mode is deterministic:
  // the results are the same bytes.
  EXPECT_EQ(readText(out / "results.csv"), csvBefore);
  const nlohmann::json j = nlohmann::json::parse(readText(out / "room/probabilistic/seed-1/run.json"));
  EXPECT_EQ(j["status"], "ok");
  EXPECT_NE(readText(out / "room/probabilistic/seed-1/config.ini").find("minInliersAfterReloc = 45"),
            std::string::npos);
}

TEST(SlamBatchCli, FailingRunIsRecordedAndTheOthersFinish) {
  const fs::path bad = root() / "broken.rawlog";
  std::ofstream(bad) << "this is not a rawlog";
  std::ofstream(root() / "broken_groundtruth.txt") << "0 0 0 0 0 0 0 1\n";
  const fs::path manifest = writeManifest(root(), "failing.yaml", {{"broken", bad}, datasets()[1]});
  const fs::path out = root() / "out_failing";
  const ToolResult r = run(batch("run " + manifest.string() + " --out " + out.string() + " -j 2"));
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("2 ok, 2 failed"), std::string::npos) << r.output;
  const nlohmann::json rec = nlohmann::json::parse(readText(out / "broken/heuristic/seed-1/run.json"));
  EXPECT_EQ(rec["status"], "failed");
  EXPECT_EQ(rec["exit_code"], 1);
  EXPECT_NE(rec["error"].get<std::string>().find(bad.string()), std::string::npos) << rec.dump();
  const std::string csv = readText(out / "results.csv");
  EXPECT_NE(csv.find("broken/heuristic/seed-1,broken,heuristic,1,failed,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("street/probabilistic/seed-1,street,probabilistic,1,ok,"), std::string::npos) << csv;
  const ToolResult status = run(batch("status " + manifest.string() + " --out " + out.string()));
  EXPECT_EQ(status.exitCode, 3);
  EXPECT_NE(status.output.find("broken/heuristic/seed-1  failed  slam-run: error: " + bad.string()),
            std::string::npos)
      << status.output;
  EXPECT_NE(readText(out / "summary.md").find("- `broken/heuristic/seed-1`: failed: "), std::string::npos);
}

TEST(SlamBatchCli, InterruptLeavesNoHalfWrittenRunFolder) {
  const fs::path manifest = writeManifest(root(), "interrupt.yaml", datasets());
  const fs::path out = root() / "out_interrupt";
  std::vector<std::string> args = {(kBin / "slam-batch").string(), "run", manifest.string(), "--out", out.string(),
                                   "-j", "2", "-q"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);  // its own group, as a shell job: Ctrl-C hits all
  posix_spawnattr_setpgroup(&attr, 0);
  pid_t pid = -1;
  ASSERT_EQ(::posix_spawn(&pid, argv[0], nullptr, &attr, argv.data(), environ), 0);
  posix_spawnattr_destroy(&attr);
  // Wait until both runs are in flight (their temporaries exist), then Ctrl-C the job.
  const auto t0 = std::chrono::steady_clock::now();
  while (temporaries(out).size() < 2 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(temporaries(out).size(), 2u);
  // A second `run` on the same output folder meanwhile is refused.
  const ToolResult second = run(batch("run " + manifest.string() + " --out " + out.string()));
  EXPECT_EQ(second.exitCode, 1);
  EXPECT_EQ(second.output, "slam-batch: " + out.string() + ": another slam-batch run is working in this output folder\n");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(-pid, SIGINT);
  int st = 0;
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGINT) << st;
  EXPECT_TRUE(temporaries(out).empty());
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.path().filename().string().rfind("seed-", 0) == 0)
      ADD_FAILURE() << "a run folder after an interrupt within the first runs: " << e.path();
  // SIGTERM to slam-batch alone (as a scheduler sends it): it stops its children and cleans up too.
  pid = -1;
  ASSERT_EQ(::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ), 0);
  while (temporaries(out).size() < 2 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ::kill(pid, SIGTERM);
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGTERM) << st;
  EXPECT_TRUE(temporaries(out).empty());
  // ("[.]" so that the pattern does not match pgrep's own command line)
  EXPECT_EQ(run("pgrep -f -- '--out " + out.string() + "/.*[.]seed-'").exitCode, 1)
      << "a slam-run child is still running";
}

// Reliability (doc/reliability.md): kill -9 of slam-batch takes its slam-run children with it (they were left
// running to completion, orphaned); `status` lists the temporaries the killed process left, and the next `run`
// removes them and does the runs.
TEST(SlamBatchCli, KilledBatchTakesItsRunsAlongAndItsTemporariesAreCleanedUpLater) {
  const fs::path manifest = writeManifest(root(), "kill9.yaml", datasets());
  const fs::path out = root() / "out_kill9";
  std::vector<std::string> args = {(kBin / "slam-batch").string(), "run", manifest.string(), "--out", out.string(),
                                   "-j", "2", "-q"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  ASSERT_EQ(::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ), 0);
  const auto t0 = std::chrono::steady_clock::now();
  while (temporaries(out).size() < 2 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(temporaries(out).size(), 2u);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(pid, SIGKILL);
  int st = 0;
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  // The children get SIGTERM from the kernel when their parent dies; give them a moment to end.
  const std::string pattern = "pgrep -f -- '--out " + out.string() + "/.*[.]seed-'";
  const auto t1 = std::chrono::steady_clock::now();
  while (run(pattern).exitCode == 0 && std::chrono::steady_clock::now() - t1 < std::chrono::seconds(10))
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(run(pattern).exitCode, 1) << "a slam-run child outlived its killed slam-batch";
  const std::vector<fs::path> left = temporaries(out);
  ASSERT_FALSE(left.empty());  // a SIGKILL leaves slam-batch no chance to clean up
  const ToolResult status = run(batch("status " + manifest.string() + " --out " + out.string()));
  for (const fs::path& p : left)
    if (p.filename().string().rfind(".seed-", 0) == 0)
      EXPECT_NE(status.output.find("stale temporary " + p.string()), std::string::npos) << status.output;
  const ToolResult again = run(batch("run " + manifest.string() + " --out " + out.string() + " -j 2"));
  EXPECT_EQ(again.exitCode, 0) << again.output;
  EXPECT_NE(again.output.find("slam-batch: removed the stale temporary "), std::string::npos) << again.output;
  EXPECT_TRUE(temporaries(out).empty());
}

TEST(SlamBatchCli, ManifestErrorsAreOneLine) {
  const fs::path manifest = root() / "unknown_key.yaml";
  std::ofstream(manifest) << "output: o\nworkers: 3\n";
  const ToolResult r = run(batch("run " + manifest.string()));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.output, "slam-batch: " + manifest.string() +
                          ": line 2: unknown key 'workers' in the manifest (known: name, base, output, slam_run, "
                          "datasets, variants, seeds, evaluation)\n");
  const ToolResult missing = run(batch("collect " + (root() / "none.yaml").string()));
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.output, "slam-batch: " + (root() / "none.yaml").string() + ": manifest not found\n");
  EXPECT_NE(run(batch("run")).exitCode, 0);
}
