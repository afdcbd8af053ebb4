// e2e: the dataset2rawlog binary converts a small TUM dataset and fails with one line + exit code 1.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "SyntheticDatasets.h"
#include "pslam/datasets/Rawlog.h"

using namespace pslam::datasets::testing;

namespace {

struct Result {
  int code = -1;
  std::string err;
};

Result run(const std::string& args, const fs::path& dir) {
  const fs::path errFile = dir / "stderr.txt";
  const std::string cmd = std::string(DATASET2RAWLOG_EXE) + " " + args + " > " + (dir / "stdout.txt").string() +
                          " 2> " + errFile.string();
  const int status = std::system(cmd.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(errFile);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

}  // namespace

TEST(Dataset2RawlogCli, ConvertsAndReportsErrorsOnOneLine) {
  const fs::path base = freshDir("cli");
  const fs::path root = base / "rgbd_dataset_freiburg3_cli";
  TumSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.frames = 3;
  writeTumDataset(root, spec);
  fs::create_directories(base / "logs");

  EXPECT_EQ(run("--help", base / "logs").code, 0);

  const Result ok = run(root.string() + " -o " + (base / "out").string() + " -q", base / "logs");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(pslam::datasets::RawlogReader::countFrames(base / "out" / "rgbd_dataset_freiburg3_cli.rawlog"), 3u);
  EXPECT_TRUE(fs::is_regular_file(base / "out" / "rgbd_dataset_freiburg3_cli_groundtruth.txt"));

  const Result missing = run((base / "absent").string() + " -o " + (base / "out2").string(), base / "logs");
  EXPECT_EQ(missing.code, 1);
  EXPECT_EQ(missing.err.rfind("dataset2rawlog: error: ", 0), 0u) << missing.err;
  EXPECT_NE(missing.err.find("absent"), std::string::npos) << missing.err;
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1) << missing.err;
  EXPECT_FALSE(fs::exists(base / "out2" / "absent.rawlog"));

  const Result badFormat = run(root.string() + " -o " + (base / "out3").string() + " --format rosbag", base / "logs");
  EXPECT_NE(badFormat.code, 0);  // a command-line check: CLI11's exit code and its --help hint
  EXPECT_EQ(badFormat.err.rfind("--format: rosbag: must be one of auto, tum, icl, kitti, euroc, folder\n", 0), 0u)
      << badFormat.err;

  const Result lossy = run(root.string() + " -o " + (base / "out4").string() + " --image-format jpg", base / "logs");
  EXPECT_NE(lossy.code, 0);
  EXPECT_EQ(lossy.err.rfind("--image-format: jpg: must be one of png, bmp, tiff, ppm, pgm\n", 0), 0u) << lossy.err;

  const Result nanRate = run(root.string() + " -o " + (base / "out5").string() + " --rate nan", base / "logs");
  EXPECT_NE(nanRate.code, 0);
  EXPECT_EQ(nanRate.err.rfind("--rate: nan: not a number\n", 0), 0u) << nanRate.err;
  EXPECT_FALSE(fs::exists(base / "out5"));
}

namespace {
std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

// Reliability (doc/reliability.md): --help says what --count 0 means; an images folder that holds files this
// tool did not write is never replaced; a re-run replaces the tool's own earlier output.
TEST(Dataset2RawlogCli, CountZeroIsDocumentedAndForeignImagesFoldersAreKept) {
  const fs::path base = freshDir("cli_reliability");
  const fs::path root = base / "rgbd_dataset_freiburg3_rel";
  TumSpec spec;
  spec.width = 640;  // the fr3 calibration's image size
  spec.height = 480;
  spec.frames = 3;
  writeTumDataset(root, spec);
  fs::create_directories(base / "logs");
  ASSERT_EQ(run("--help", base / "logs").code, 0);
  EXPECT_NE(readAll(base / "logs" / "stdout.txt").find("0 = all"), std::string::npos);
  const Result all = run(root.string() + " -o " + (base / "out").string() + " --count 0 -q", base / "logs");
  ASSERT_EQ(all.code, 0) << all.err;
  EXPECT_EQ(pslam::datasets::RawlogReader::countFrames(base / "out" / "rgbd_dataset_freiburg3_rel.rawlog"), 3u);

  const Result again = run(root.string() + " -o " + (base / "out").string() + " --count 2 -q", base / "logs");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(pslam::datasets::RawlogReader::countFrames(base / "out" / "rgbd_dataset_freiburg3_rel.rawlog"), 2u);

  std::ofstream(base / "out" / "rgbd_dataset_freiburg3_rel_Images" / "notes.txt") << "mine";
  const Result foreign = run(root.string() + " -o " + (base / "out").string() + " -q", base / "logs");
  EXPECT_EQ(foreign.code, 1) << foreign.err;
  EXPECT_NE(foreign.err.find("holds 'notes.txt'"), std::string::npos) << foreign.err;
  EXPECT_EQ(std::count(foreign.err.begin(), foreign.err.end(), '\n'), 1) << foreign.err;
  EXPECT_EQ(readAll(base / "out" / "rgbd_dataset_freiburg3_rel_Images" / "notes.txt"), "mine");
  EXPECT_EQ(pslam::datasets::RawlogReader::countFrames(base / "out" / "rgbd_dataset_freiburg3_rel.rawlog"), 2u);
}
