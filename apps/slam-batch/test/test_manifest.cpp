// Manifest parsing and validation (errors are one line naming the file, line and key), run expansion, the
// resume hash, the statistics of the summary, the CSV and the sbatch script.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "pslam/batch/BatchApp.h"
#include "pslam/batch/Collect.h"
#include "pslam/batch/Manifest.h"
#include "pslam/batch/Runs.h"
#include "pslam/batch/Slurm.h"
#include "pslam/core/Error.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::batch;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("pslam_manifest_" + std::to_string(::getpid()));
  TempDir() {
    fs::create_directories(path);
    std::ofstream(path / "a.rawlog") << "x";
    std::ofstream(path / "b.rawlog") << "y";
    std::ofstream(path / "gt.txt") << "0 0 0 0 0 0 0 1\n";
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
const fs::path& dir() {
  static const TempDir d;
  return d.path;
}

const std::string kConfig = std::string(PRIORSLAM_SOURCE_DIR) + "/config/slam/synthetic.ini";

/// A valid manifest with two datasets, two variants and two seeds; `extra` is appended verbatim.
std::string validText(const std::string& extra = "") {
  return "name: t\n"
         "output: out\n"
         "datasets:\n"
         "  - name: a\n"
         "    rawlog: a.rawlog\n"
         "    groundtruth: gt.txt\n"
         "    config: " + kConfig + "\n"
         "    last: 39\n"
         "  - {name: b, rawlog: b.rawlog, groundtruth: gt.txt, config: " + kConfig + "}\n"
         "variants:\n"
         "  - name: heuristic\n"
         "    set: [PointModel.model=heuristic]\n"
         "  - name: prob\n"
         "    set: PointModel.model=probabilistic\n"
         "seeds: [1, 2]\n" + extra;
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = dir() / name;
  std::ofstream(p) << text;
  return p;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string errorOf(const std::string& text) {
  const fs::path p = write("bad.yaml", text);
  try {
    loadManifest(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Manifest, ExpandsDatasetsTimesVariantsTimesSeedsInOrder) {
  const Manifest m = loadManifest(write("ok.yaml", validText()));
  EXPECT_EQ(m.name, "t");
  EXPECT_EQ(m.output, dir() / "out");
  ASSERT_EQ(m.runs.size(), 8u);
  EXPECT_EQ(m.runs[0].id, "a/heuristic/seed-1");
  EXPECT_EQ(m.runs[1].id, "a/heuristic/seed-2");
  EXPECT_EQ(m.runs[2].id, "a/prob/seed-1");
  EXPECT_EQ(m.runs[7].id, "b/prob/seed-2");
  EXPECT_EQ(m.runFolder(m.runs[7]), dir() / "out" / "b" / "prob" / "seed-2");
  EXPECT_EQ(m.datasets[0].last.value(), 39);
  EXPECT_FALSE(m.datasets[1].last.has_value());
  EXPECT_EQ(m.runs[2].overrides, std::vector<std::string>{"PointModel.model=probabilistic"});
  EXPECT_NE(m.runs[2].effectiveConfig.find("probabilistic"), std::string::npos);
  EXPECT_EQ(m.findRun("b/heuristic/seed-2"), &m.runs[5]);
  EXPECT_EQ(m.findRun("b/heuristic/seed-3"), nullptr);
  // --out wins over `output`
  EXPECT_EQ(loadManifest(dir() / "ok.yaml", dir() / "elsewhere").output, dir() / "elsewhere");
}

TEST(Manifest, HashChangesWithWhatARunComputesAndOnlyThen) {
  const Manifest m = loadManifest(write("ok.yaml", validText()));
  const Manifest same = loadManifest(write("ok2.yaml", validText("evaluation: {align: se3}\n")));
  for (std::size_t i = 0; i < m.runs.size(); ++i) EXPECT_EQ(m.runs[i].hash, same.runs[i].hash) << m.runs[i].id;
  // seeds, variants, datasets and the frame range all differ
  std::set<std::string> hashes;
  for (const RunSpec& r : m.runs) hashes.insert(r.hash);
  EXPECT_EQ(hashes.size(), m.runs.size());
  // An override that changes the effective configuration changes the hash of that variant only.
  std::string text = validText();
  text.replace(text.find("PointModel.model=probabilistic"), 30,
               "[PointModel.model=probabilistic, Tracking.minInliersAfterReloc=45]");
  const Manifest changed = loadManifest(write("changed.yaml", text));
  EXPECT_EQ(changed.runs[0].hash, m.runs[0].hash);
  EXPECT_NE(changed.runs[2].hash, m.runs[2].hash);
  // Touching the rawlog (size) changes the hash of its runs.
  {
    std::ofstream(dir() / "b.rawlog") << "yy";
  }
  const Manifest touched = loadManifest(dir() / "ok.yaml");
  EXPECT_EQ(touched.runs[0].hash, m.runs[0].hash);
  EXPECT_NE(touched.runs[4].hash, m.runs[4].hash);
}

TEST(Manifest, ErrorsAreOneLineNamingFileLineAndKey) {
  struct Case {
    std::string text, expected;
  };
  std::string dupDataset = validText();
  dupDataset.replace(dupDataset.find("name: b"), 7, "name: a");
  std::string dupVariant = validText();
  dupVariant.replace(dupVariant.find("name: prob"), 10, "name: heuristic");
  std::string missingRawlog = validText();
  missingRawlog.replace(missingRawlog.find("a.rawlog"), 8, "nope.rawlog");
  std::string noConfig = validText();
  noConfig.replace(noConfig.find("config: " + kConfig + "}"), 8 + kConfig.size(), "set: []");
  const std::vector<Case> cases = {
      {validText("colour: blue\n"), "line 16: unknown key 'colour' in the manifest (known: name, base"},
      {validText("evaluation: {align: sim3, dr: true}\n"), "unknown key 'dr' in evaluation"},
      {validText("evaluation: {align: sim4}\n"), "evaluation.align 'sim4': expected none | se3 | sim3"},
      {validText("evaluation: {depth_ratio: maybe}\n"), "evaluation.depth_ratio = 'maybe': not true or false"},
      {dupDataset, "line 9: duplicate dataset name 'a'"},
      {dupVariant, "duplicate variant name 'heuristic'"},
      {missingRawlog, "line 5: datasets[0].rawlog " + (dir() / "nope.rawlog").string() + ": file not found"},
      {noConfig, "variant 'heuristic' has no config and dataset 'b' gives none"},
      {validText().replace(validText().find("seeds: [1, 2]"), 13, "seeds: [1, 1]"), "duplicate seed 1"},
      {validText().replace(validText().find("seeds: [1, 2]"), 13, "seeds: [1, -2]"), "seed -2 is out of range"},
      {validText().replace(validText().find("seeds: [1, 2]"), 13, "seeds: [1, x]"), "seed = 'x': not an integer"},
      {validText().replace(validText().find("last: 39"), 8, "last: 3.5"), "datasets[0].last = '3.5': not a frame"},
      {validText().replace(validText().find("name: a"), 7, "name: a/b"), "datasets[0].name 'a/b': use letters"},
      {validText().replace(validText().find("PointModel.model=heuristic"), 26, "PointModel.modl=heuristic"),
       "dataset 'a' x variant 'heuristic': override 'PointModel.modl=heuristic': [PointModel] modl: unknown key"},
      {"datasets: [\n", "not valid YAML"},
      {"", "empty manifest"},
      {"- a\n- b\n", "the manifest must be a mapping"},
      {"output: o\ndatasets: []\nvariants: [{name: x}]\n", "'datasets' must be a non-empty list"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_NE(e.find(c.expected), std::string::npos) << "got: " << e << "\nexpected: " << c.expected;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
    EXPECT_EQ(e.rfind((dir() / "bad.yaml").string(), 0), 0u) << e;
  }
  EXPECT_NE(errorOf("output: o\n").find("'datasets' must be a non-empty list"), std::string::npos);
  try {
    loadManifest(dir() / "missing.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir() / "missing.yaml").string() + ": manifest not found");
  }
}

TEST(Manifest, RelativePathsResolveAgainstBase) {
  fs::create_directories(dir() / "sub");
  const Manifest m = loadManifest(write("sub/based.yaml", "base: ..\n" + validText()));
  EXPECT_EQ(m.datasets[0].rawlog, dir() / "a.rawlog");
  EXPECT_EQ(m.output, dir() / "out");
  EXPECT_EQ(m.file, dir() / "sub" / "based.yaml");
}

TEST(Collect, SpreadUsesLinearInterpolationQuartiles) {
  // numpy.percentile([4, 1, 3, 2], [0, 25, 50, 75, 100]) = 1, 1.75, 2.5, 3.25, 4
  const Spread s = spreadOf({4, 1, 3, 2});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.q1, 1.75);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.q3, 3.25);
  EXPECT_DOUBLE_EQ(s.max, 4);
  const Spread one = spreadOf({0.7});
  EXPECT_DOUBLE_EQ(one.q1, 0.7);
  EXPECT_DOUBLE_EQ(one.q3, 0.7);
  EXPECT_EQ(spreadOf({}).count, 0u);
}

TEST(Collect, CsvAndSummaryShowEveryRunWithItsStatus) {
  const Manifest m = loadManifest(write("ok.yaml", validText()));
  std::vector<RunResult> rows;
  for (const RunSpec& r : m.runs) {
    RunResult row;
    row.run = &r;
    row.status = "pending";
    rows.push_back(row);
  }
  rows[0].status = "ok";
  rows[0].frames = 40;
  rows[0].tracked = 30;
  rows[0].ateRmse = 0.0123456789;
  rows[0].cpuSeconds = 2.0;
  rows[1].status = "ok";
  rows[1].frames = 40;
  rows[1].tracked = 40;
  rows[1].ateRmse = 0.02;
  rows[2].status = "failed";
  rows[2].error = "slam-run: error: x, \"y\"";
  const std::string csv = resultsCsv(m, rows);
  EXPECT_NE(csv.find("\na/heuristic/seed-1,a,heuristic,1,ok,40,30,75,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",0.0123457,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("a/prob/seed-1,a,prob,1,failed,"), std::string::npos);
  EXPECT_NE(csv.find(",\"slam-run: error: x, \"\"y\"\"\"\n"), std::string::npos) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 9);
  const std::string md = summaryMarkdown(m, rows);
  // a x heuristic: median of 0.0123 and 0.02 over the two seeds, both evaluated
  EXPECT_NE(md.find("| a | 0.016 [0.012, 0.020] (2/2) | - (0/2) |"), std::string::npos) << md;
  EXPECT_NE(md.find("- `a/prob/seed-1`: failed: slam-run: error: x"), std::string::npos) << md;
  EXPECT_NE(md.find(": failed 1, ok 2, pending 5."), std::string::npos) << md;
  const nlohmann::json j = resultsJson(m, rows);
  EXPECT_EQ(j["runs"].size(), 8u);
  EXPECT_DOUBLE_EQ(j["runs"][0]["cpu_ms_per_frame"].get<double>(), 50.0);
  EXPECT_TRUE(j["runs"][2]["ate_rmse_m"].is_null());
}

TEST(Runs, FolderWithoutARunRecordIsNeverReplaced) {
  const Manifest m = loadManifest(write("ok.yaml", validText()), dir() / "out_foreign");
  const RunSpec& r = m.runs[0];
  EXPECT_EQ(runState(m, r), RunState::Pending);
  fs::create_directories(m.runFolder(r));
  std::ofstream(m.runFolder(r) / "notes.txt") << "mine";
  try {
    runState(m, r);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is not a slam-batch run folder"), std::string::npos) << e.what();
  }
  std::ofstream(m.runFolder(r) / "run.json") << "{\"status\": \"ok\"}";
  EXPECT_THROW(runState(m, r), Error);  // no hash: not a valid record
  // A record of success without the outputs it vouches for is no result (Runs.DoneOnlyWhenTheOutputsMatchTheRecord).
  std::ofstream(m.runFolder(r) / "run.json") << nlohmann::json{{"status", "ok"}, {"hash", r.hash}}.dump();
  EXPECT_EQ(runState(m, r), RunState::Stale);
  std::ofstream(m.runFolder(r) / "run.json") << nlohmann::json{{"status", "failed"}, {"hash", r.hash}}.dump();
  EXPECT_EQ(runState(m, r), RunState::Failed);
  std::ofstream(m.runFolder(r) / "run.json") << nlohmann::json{{"status", "ok"}, {"hash", "0"}}.dump();
  EXPECT_EQ(runState(m, r), RunState::Stale);
  EXPECT_EQ(runsToDo(m).size(), m.runs.size());
}

TEST(Slurm, ScriptIsOneArrayTaskPerRunCallingRunOne) {
  const Manifest m = loadManifest(write("ok.yaml", validText()));
  SlurmOptions o;
  o.partition = "debug";
  o.time = "00:10:00";
  o.mem = "2G";
  o.maxParallel = 3;
  const std::string s = slurmScript(m, "/x/tasks", 8, o, "1", "/x/logs");
  EXPECT_EQ(s.rfind("#!/bin/bash\n", 0), 0u);
  for (const std::string& line : std::vector<std::string>{"#SBATCH --array=0-7%3\n", "#SBATCH --cpus-per-task=1\n", "#SBATCH --partition=debug\n",
        "#SBATCH --time=00:10:00\n", "#SBATCH --mem=2G\n", "#SBATCH --output=/x/logs/%A_%a.out\n",
        " run-one '" + m.file.string() + "' --out '" + m.output.string() +
            "' --tasks '/x/tasks' --index \"$SLURM_ARRAY_TASK_ID\"\n"})
    EXPECT_NE(s.find(line), std::string::npos) << line << "\n" << s;
  const std::string plain = slurmScript(m, "/x/tasks", 1, SlurmOptions{}, "2", "/x/logs");
  EXPECT_NE(plain.find("#SBATCH --array=0-0\n"), std::string::npos);
  EXPECT_EQ(plain.find("--partition"), std::string::npos);
  EXPECT_NE(plain.find("--cpus-per-task=2"), std::string::npos);

  write("tasks.txt", "a/heuristic/seed-1\nb/prob/seed-2\n");
  EXPECT_EQ(taskRunId(dir() / "tasks.txt", 1), "b/prob/seed-2");
  EXPECT_THROW(taskRunId(dir() / "tasks.txt", 2), Error);
}

TEST(Slurm, RunCommandCapturesOutputAndExitCode) {
  const CommandOutput ok = runCommand({"sh", "-c", "echo out; echo err >&2; exit 3"});
  EXPECT_EQ(ok.exitCode, 3);
  EXPECT_EQ(ok.output, "out\nerr\n");
  EXPECT_EQ(runCommand({"/nonexistent/tool"}).exitCode, 127);
}

// Reliability (doc/reliability.md): a second `datasets:` or `seeds:` key was silently ignored by the YAML reader.
TEST(Manifest, DuplicateKeysAreErrors) {
  const std::string seedsTwice = errorOf(validText("seeds: [3]\n"));
  EXPECT_NE(seedsTwice.find("line 16: key 'seeds' given twice in the manifest (first on line 15)"), std::string::npos)
      << seedsTwice;
  const std::string datasetsTwice = errorOf(validText("datasets: []\n"));
  EXPECT_NE(datasetsTwice.find("key 'datasets' given twice in the manifest (first on line 3)"), std::string::npos)
      << datasetsTwice;
  const std::string inADataset =
      errorOf(validText().replace(validText().find("    last: 39\n"), 13, "    last: 39\n    last: 20\n"));
  EXPECT_NE(inADataset.find("key 'last' given twice in datasets[0]"), std::string::npos) << inADataset;
}

// Reliability: collect's outputs (results.csv, results.json, summary.md, ate_<dataset>.png) may never be an input
// of the manifest: a ground truth stored as <output>/results.csv was overwritten by `run`'s collect.
TEST(Manifest, CollectOutputsThatAreInputsAreRefusedAtLoad) {
  fs::create_directories(dir() / "out_gt");
  std::ofstream(dir() / "out_gt" / "results.csv") << "0 0 0 0 0 0 0 1\n";
  std::string text = validText();
  text.replace(text.find("output: out"), 11, "output: out_gt");
  for (std::size_t at = text.find("groundtruth: gt.txt"); at != std::string::npos; at = text.find("groundtruth: gt.txt"))
    text.replace(at, 19, "groundtruth: out_gt/results.csv");
  const std::string e = errorOf(text);
  EXPECT_NE(e.find((dir() / "out_gt" / "results.csv").string() + ": is the input"), std::string::npos) << e;
  EXPECT_EQ(readFile(dir() / "out_gt" / "results.csv"), "0 0 0 0 0 0 0 1\n");
  // The same through collect() on a manifest loaded before the file was named (collect checks again).
  const Manifest m = loadManifest(write("ok_gt.yaml", validText()), dir() / "out_gt2");
  Manifest tampered = m;
  tampered.datasets[0].groundTruth = m.output / "summary.md";
  fs::create_directories(m.output);
  std::ofstream(m.output / "summary.md") << "truth";
  EXPECT_THROW(collect(tampered, {}), Error);
  EXPECT_EQ(readFile(m.output / "summary.md"), "truth");
}

namespace {
/// A pid that no process has now: a child that has exited and been reaped.
pid_t deadPid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int st = 0;
  ::waitpid(pid, &st, 0);
  return pid;
}
void writeOutputsAndRecord(const fs::path& folder, const RunSpec& r) {
  fs::create_directories(folder);
  std::ofstream(folder / "trajectory.txt") << "1 0 0 0 0 0 0 1\n";
  std::ofstream(folder / "report.json") << "{}\n";
  RunRecord rec;
  rec.status = "ok";
  rec.hash = r.hash;
  rec.outputs = {{"trajectory.txt", 16}, {"report.json", 3}};
  std::ofstream(folder / "run.json") << rec.toJson().dump();
}
}  // namespace

// Reliability: a run is done only when the outputs its record vouches for exist with the recorded sizes (a
// deleted trajectory.txt stayed `done`, and collect then said "never initialized").
TEST(Runs, DoneOnlyWhenTheOutputsMatchTheRecord) {
  const Manifest m = loadManifest(write("ok.yaml", validText()), dir() / "out_outputs");
  const RunSpec& r = m.runs[0];
  writeOutputsAndRecord(m.runFolder(r), r);
  EXPECT_EQ(runState(m, r), RunState::Done);
  fs::remove(m.runFolder(r) / "trajectory.txt");
  RunRecord rec;
  EXPECT_EQ(runState(m, r, &rec), RunState::Stale);
  EXPECT_NE(rec.error.find("trajectory.txt: missing"), std::string::npos) << rec.error;
  std::ofstream(m.runFolder(r) / "trajectory.txt") << "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n";
  EXPECT_EQ(runState(m, r, &rec), RunState::Stale);
  EXPECT_NE(rec.error.find("trajectory.txt: 32 bytes, the record says 16"), std::string::npos) << rec.error;
  EXPECT_EQ(runsToDo(m).size(), m.runs.size());
}

// Reliability: the temporaries of runs whose slam-batch died (kill -9) are listed and removed by the next run;
// those of a live process are kept.
TEST(Runs, StaleTemporariesOfDeadProcessesAreFoundAndRemoved) {
  const Manifest m = loadManifest(write("ok.yaml", validText()), dir() / "out_stale");
  const fs::path parent = m.runFolder(m.runs[0]).parent_path();
  fs::create_directories(parent);
  const fs::path dead = parent / (".seed-1.tmp-" + std::to_string(deadPid()));
  const fs::path live = parent / (".seed-2.tmp-" + std::to_string(::getpid()));
  fs::create_directories(dead);
  std::ofstream(dead / "config.ini") << "x";
  fs::create_directories(live);
  const std::vector<fs::path> found = staleTemporaries(m);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0], dead);
  EXPECT_EQ(removeStaleTemporaries(m), found);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  fs::remove_all(live);
}

// Reliability: a run that cannot start (slam-run missing; a full disk while config.ini is written) leaves no
// temporary folder behind.
TEST(Runs, ARunThatCannotStartLeavesNoTemporary) {
  std::string text = validText();
  text.insert(text.find("datasets:"), "slam_run: gt.txt\n");  // a file, not an executable
  const Manifest m = loadManifest(write("noexe.yaml", text), dir() / "out_noexe");
  const RunSpec& r = m.runs[0];
  EXPECT_THROW(RunExecution(m, r), Error);
  const fs::path parent = m.runFolder(r).parent_path();
  ASSERT_TRUE(fs::exists(parent));
  EXPECT_TRUE(fs::is_empty(parent)) << fs::directory_iterator(parent)->path();
  // A full disk, as a file-size limit: writing config.ini fails (EFBIG instead of ENOSPC).
  struct rlimit old {};
  ::getrlimit(RLIMIT_FSIZE, &old);
  const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit tiny = old;
  tiny.rlim_cur = 16;
  ::setrlimit(RLIMIT_FSIZE, &tiny);
  std::string message;
  try {
    RunExecution e(m, r);
  } catch (const Error& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, oldHandler);
  EXPECT_NE(message.find("config.ini: cannot write"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(parent));
}

// Reliability: an output folder that cannot be made was reported as the lock file's "No such file or directory"
// (on a read-only file system); the message names the folder and the real reason.
TEST(Runs, AnOutputFolderThatCannotBeMadeIsNamedWithItsReason) {
  std::ofstream(dir() / "plain_file") << "x";
  CommonOptions c;
  c.manifest = write("ok.yaml", validText());
  c.out = dir() / "plain_file" / "out";
  c.quiet = true;
  try {
    commandRun(c, 1, true);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), c.out.string() + ": cannot create the output folder (Not a directory)");
  }
}

// Reliability: a static ground truth was status `ok` with ATE 2e-16 through collect; slam-eval refuses it, and the
// run is recorded as failed to evaluate, with slam-eval's line naming the file.
TEST(Collect, ADegenerateGroundTruthIsAFailedEvaluation) {
  std::ofstream gt(dir() / "static_gt.txt");
  std::ofstream est(dir() / "moving.txt");
  for (int i = 0; i < 40; ++i) {
    gt << 10.0 + 0.1 * i << " 1 2 3 0 0 0 1\n";
    est << 10.0 + 0.1 * i << " " << std::cos(0.1 * i) << " " << std::sin(0.1 * i) << " " << 0.01 * i << " 0 0 0 1\n";
  }
  gt.close();
  est.close();
  std::string text = validText();
  for (std::size_t at = text.find("groundtruth: gt.txt"); at != std::string::npos; at = text.find("groundtruth: gt.txt"))
    text.replace(at, 19, "groundtruth: static_gt.txt");
  const Manifest m = loadManifest(write("static.yaml", text), dir() / "out_static");
  const RunSpec& r = m.runs[0];
  fs::create_directories(m.runFolder(r));
  fs::copy_file(dir() / "moving.txt", m.runFolder(r) / "trajectory.txt");
  std::ofstream(m.runFolder(r) / "report.json")
      << R"({"summary": {"frames_processed": 40, "frames_tracked": 40, "initialized_at_frame": 0, "keyframes": 5,
          "map_points": 100, "resets": 0, "relocalizations": 0}})";
  RunRecord rec;
  rec.status = "ok";
  rec.hash = r.hash;
  rec.outputs = {{"trajectory.txt", fs::file_size(m.runFolder(r) / "trajectory.txt")},
                 {"report.json", fs::file_size(m.runFolder(r) / "report.json")}};
  std::ofstream(m.runFolder(r) / "run.json") << rec.toJson().dump();
  ASSERT_EQ(runState(m, r), RunState::Done);
  const std::vector<RunResult> rows = evaluateRuns(m, false);
  EXPECT_EQ(rows[0].status, "eval-failed");
  EXPECT_NE(rows[0].error.find((dir() / "static_gt.txt").string() + ": all 40 poses are at one position"),
            std::string::npos)
      << rows[0].error;
  EXPECT_FALSE(rows[0].ateRmse.has_value());
}
