// e2e: runs the slam-eval executable as a user would (exit codes, one-line errors, outputs).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <unistd.h>

#include <sys/wait.h>

#include "pslam/core/Trajectory.h"

namespace fs = std::filesystem;

namespace {
const fs::path kExe = fs::path(PRIORSLAM_BINARY_DIR) / "bin" / "slam-eval";

struct CliRun {
  int exitCode;
  std::string output;  // stdout + stderr
};

CliRun runCli(const std::string& args) {
  const std::string cmd = kExe.string() + " " + args + " 2>&1";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
  std::string out;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), pipe.get())) out += buf.data();
  const int status = pclose(pipe.release());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

pslam::Trajectory spiral(std::size_t n, double scale) {
  pslam::Trajectory t;
  for (std::size_t k = 0; k < n; ++k) {
    const double s = 0.1 * static_cast<double>(k);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = scale * Eigen::Vector3d(std::cos(s), std::sin(s), 0.1 * s);
    T.linear() = Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    t.emplace_back(10.0 + static_cast<double>(k) / 30.0, T);
  }
  return t;
}
}  // namespace

TEST(SlamEvalCli, EvaluatesAndWritesOutputs) {
  ASSERT_TRUE(fs::exists(kExe)) << kExe;
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pslam::writeTumTrajectory(d / "gt.txt", spiral(90, 1.0));
  pslam::writeTumTrajectory(d / "est.txt", spiral(90, 0.25));
  const CliRun r = runCli((d / "gt.txt").string() + " " + (d / "est.txt").string() + " --json " +
                       (d / "r.json").string() + " --plot-dir " + (d / "plots").string());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("scale 4.000000"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(d / "r.json"));
  EXPECT_TRUE(fs::exists(d / "plots" / "eval_top_view.png"));
  // SE(3) on the same files keeps the scale error.
  const CliRun se3 = runCli((d / "gt.txt").string() + " " + (d / "est.txt").string() + " --align se3");
  EXPECT_EQ(se3.exitCode, 0);
  EXPECT_NE(se3.output.find("scale 1.000000"), std::string::npos) << se3.output;
  fs::remove_all(d);
}

TEST(SlamEvalCli, SegmentsTableAndItsBadValues) {
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_seg_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pslam::writeTumTrajectory(d / "gt.txt", spiral(90, 1.0));
  pslam::writeTumTrajectory(d / "est.txt", spiral(90, 0.25));
  const std::string files = (d / "gt.txt").string() + " " + (d / "est.txt").string();
  const CliRun r = runCli(files + " --no-rpe --segments 3");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("segments, each aligned on its own (sim3)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("60-89"), std::string::npos) << r.output;  // the third segment's pairs
  EXPECT_NE(r.output.find("largest / smallest - 1 = 0.00 %"), std::string::npos) << r.output;
  // 90 pairs in 31 segments leave fewer than 3 per segment; a negative count is no count.
  const CliRun tooMany = runCli(files + " --segments 31");
  EXPECT_EQ(tooMany.exitCode, 1) << tooMany.output;
  EXPECT_NE(tooMany.output.find("fewer than 3 per segment"), std::string::npos) << tooMany.output;
  const CliRun negative = runCli(files + " --segments -2");
  EXPECT_NE(negative.exitCode, 0) << negative.output;
  fs::remove_all(d);
}

TEST(SlamEvalCli, AlignFromAnotherPair) {
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_af_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pslam::writeTumTrajectory(d / "gtA.txt", spiral(90, 1.0));
  pslam::writeTumTrajectory(d / "estA.txt", spiral(90, 0.25));
  pslam::writeTumTrajectory(d / "gtB.txt", spiral(60, 1.0));
  pslam::writeTumTrajectory(d / "estB.txt", spiral(60, 0.5));  // another scale than A's: not aligned away
  const CliRun r = runCli((d / "gtB.txt").string() + " " + (d / "estB.txt").string() + " --align-from " +
                       (d / "gtA.txt").string() + " " + (d / "estA.txt").string());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("(90 pairs; not fitted to this estimate), scale 4.000000"), std::string::npos) << r.output;
  const CliRun one = runCli((d / "gtB.txt").string() + " " + (d / "estB.txt").string() + " --align-from " +
                         (d / "gtA.txt").string());
  EXPECT_NE(one.exitCode, 0) << one.output;
  const CliRun missing = runCli((d / "gtB.txt").string() + " " + (d / "estB.txt").string() + " --align-from " +
                             (d / "gtA.txt").string() + " " + (d / "none.txt").string());
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.output.rfind("slam-eval: error: --align-from ", 0), 0u) << missing.output;
  EXPECT_EQ(std::count(missing.output.begin(), missing.output.end(), '\n'), 1) << missing.output;
  fs::remove_all(d);
}

TEST(SlamEvalCli, BadInputIsOneErrorLineAndExitCodeOne) {
  const CliRun missing = runCli("/nonexistent/gt.txt /nonexistent/est.txt");
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.output.rfind("slam-eval: error: /nonexistent/gt.txt", 0), 0u) << missing.output;
  EXPECT_EQ(std::count(missing.output.begin(), missing.output.end(), '\n'), 1) << missing.output;
  const CliRun badAlign = runCli("a b --align affine");
  EXPECT_EQ(badAlign.exitCode, 1);
  EXPECT_NE(badAlign.output.find("alignment 'affine'"), std::string::npos) << badAlign.output;
}

namespace {
std::string readAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}
}  // namespace

// Reliability (doc/reliability.md): --json never deletes a folder and never overwrites an input; a run that
// cannot write one of its outputs writes none.
TEST(SlamEvalCli, OutputsNeverDestroyAFolderOrAnInput) {
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_out_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d / "X");
  std::ofstream(d / "X" / "keep.txt") << "keep";
  pslam::writeTumTrajectory(d / "gt.txt", spiral(60, 1.0));
  pslam::writeTumTrajectory(d / "est.txt", spiral(60, 0.5));
  const std::string files = (d / "gt.txt").string() + " " + (d / "est.txt").string();

  const CliRun folder = runCli(files + " --json " + (d / "X").string());
  EXPECT_EQ(folder.exitCode, 1) << folder.output;
  EXPECT_NE(folder.output.find("X: is a folder; refusing to replace it with a file"), std::string::npos)
      << folder.output;
  EXPECT_EQ(readAll(d / "X" / "keep.txt"), "keep");

  const std::string est = readAll(d / "est.txt"), gt = readAll(d / "gt.txt");
  for (const char* input : {"est.txt", "gt.txt"}) {
    const CliRun same = runCli(files + " --json " + (d / input).string());
    EXPECT_EQ(same.exitCode, 1) << same.output;
    EXPECT_NE(same.output.find("is the input"), std::string::npos) << same.output;
    EXPECT_EQ(std::count(same.output.begin(), same.output.end(), '\n'), 1) << same.output;
  }
  EXPECT_EQ(readAll(d / "est.txt"), est);
  EXPECT_EQ(readAll(d / "gt.txt"), gt);

  // A plot that cannot be written (its name is a folder): the JSON is not written either.
  fs::create_directories(d / "plots" / "eval_top_view.png");
  const CliRun plots = runCli(files + " --json " + (d / "r.json").string() + " --plot-dir " + (d / "plots").string());
  EXPECT_EQ(plots.exitCode, 1) << plots.output;
  EXPECT_NE(plots.output.find("eval_top_view.png: is a folder"), std::string::npos) << plots.output;
  EXPECT_FALSE(fs::exists(d / "r.json"));
  EXPECT_TRUE(fs::is_directory(d / "plots" / "eval_top_view.png"));
  fs::remove_all(d);
}

// Reliability: a stamp before the previous one is an error naming the file and line; a duplicate stamp is
// kept (as evo does: published ground truth has some) with a warning naming the file.
TEST(SlamEvalCli, StampOrderIsCheckedAndDuplicatesAreNamed) {
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_dup_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pslam::writeTumTrajectory(d / "gt.txt", spiral(30, 1.0));
  auto est = spiral(30, 0.5);
  std::swap(est[9].timestamp, est[10].timestamp);
  pslam::writeTumTrajectory(d / "est.txt", est);
  const CliRun back = runCli((d / "gt.txt").string() + " " + (d / "est.txt").string());
  EXPECT_EQ(back.exitCode, 1) << back.output;
  // One header comment line, then pose k on line k + 2.
  EXPECT_NE(back.output.find("est.txt:12: timestamp 10.300000 is before the previous one (line 11)"), std::string::npos)
      << back.output;

  est = spiral(30, 0.5);
  est[10].timestamp = est[9].timestamp;
  pslam::writeTumTrajectory(d / "est.txt", est);
  const CliRun dup = runCli((d / "gt.txt").string() + " " + (d / "est.txt").string());
  EXPECT_EQ(dup.exitCode, 0) << dup.output;
  EXPECT_NE(dup.output.find("slam-eval: warning: " + (d / "est.txt").string() + ": 1 pose has the timestamp of the previous one"),
            std::string::npos)
      << dup.output;
  fs::remove_all(d);
}

// Reliability (doc/reliability.md): degenerate data is refused, never scored as perfect. A ground truth whose poses
// all sit at one position gave scale 0 and ATE 0.000000 with exit code 0; an estimate whose stamps are all equal
// was scored too (with only a warning); a static estimate is refused as well. One line naming the file.
TEST(SlamEvalCli, DegenerateTrajectoriesAreRefused) {
  const fs::path d = fs::temp_directory_path() / ("pslam_slam_eval_cli_degenerate_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pslam::writeTumTrajectory(d / "gt.txt", spiral(30, 1.0));
  pslam::writeTumTrajectory(d / "est.txt", spiral(30, 0.5));
  auto stat = spiral(30, 1.0);
  for (auto& p : stat) p.position = Eigen::Vector3d(1.0, 2.0, 3.0);
  pslam::writeTumTrajectory(d / "static.txt", stat);
  auto equal = spiral(30, 0.5);
  for (auto& p : equal) p.timestamp = 10.5;
  pslam::writeTumTrajectory(d / "equal.txt", equal);
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {(d / "static.txt").string() + " " + (d / "est.txt").string(),
       (d / "static.txt").string() + ": all 30 poses are at one position (1 2 3): a static ground truth"},
      {(d / "static.txt").string() + " " + (d / "est.txt").string() + " --align se3",
       (d / "static.txt").string() + ": all 30 poses are at one position (1 2 3): a static ground truth"},
      {(d / "gt.txt").string() + " " + (d / "static.txt").string(),
       (d / "static.txt").string() + ": all 30 poses are at one position (1 2 3): a static estimate"},
      {(d / "gt.txt").string() + " " + (d / "equal.txt").string(),
       (d / "equal.txt").string() + ": all 30 poses have the timestamp 10.500000"},
      {(d / "equal.txt").string() + " " + (d / "est.txt").string(),
       (d / "equal.txt").string() + ": all 30 poses have the timestamp 10.500000"},
  };
  for (const Case& c : cases) {
    const CliRun r = runCli(c.args);
    EXPECT_EQ(r.exitCode, 1) << c.args << "\n" << r.output;
    EXPECT_EQ(r.output.rfind("slam-eval: error: " + c.expected, 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  // Without an alignment a static ground truth is a reference like any other (the estimate's own spread).
  EXPECT_EQ(runCli((d / "static.txt").string() + " " + (d / "est.txt").string() + " --align none").exitCode, 0);
  fs::remove_all(d);
}
