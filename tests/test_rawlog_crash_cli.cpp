// e2e (doc/reliability.md): a rawlog whose first DEPTH observation declares a corrupt range-image size inside a
// valid gzip stream made every tool that reads rawlogs die with SIGSEGV inside MRPT (repro
// rawlog_depth_size_segfault). Each tool must now refuse it with one error line naming the file and exit 1, with
// no temporary left behind. The rawlog is built here (so the test never depends on ../shared); the repro file
// itself is run too when ../shared is present (copied first: it is read only).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>

#include "pslam/datasets/Rawlog.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;

namespace {

const fs::path kBin = fs::path(PRIORSLAM_BINARY_DIR) / "bin";
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";

const fs::path& root() {
  static const pslam::test_support::TempDir r("pslam_rawlog_crash_cli");
  return r.path;
}

void putU32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s[at + k] = static_cast<char>((v >> (8 * k)) & 0xff);
}

/// dir/bad.rawlog (+ bad_Images, bad_groundtruth.txt): 4 frames of 160x120 with depth, the first DEPTH observation's
/// range-image rows and cols set to 0xFEFEFEFE as in the repro, inside a valid gzip stream.
fs::path syntheticCrashRawlog(const fs::path& dir) {
  fs::create_directories(dir);
  {
    pslam::datasets::RawlogWriter w(dir / "good.rawlog");
    for (int i = 0; i < 4; ++i) {
      pslam::datasets::Frame f;
      f.timestamp = 100.0 + 0.05 * i;
      f.camera.ncols = 160;
      f.camera.nrows = 120;
      f.camera.fx(120.0);
      f.camera.fy(120.0);
      f.camera.cx(79.5);
      f.camera.cy(59.5);
      f.image = cv::Mat(120, 160, CV_8UC1);
      cv::randu(f.image, 0, 256);
      f.depth = cv::Mat(120, 160, CV_16UC1, cv::Scalar(10000));
      f.depthUnits = 1.0 / 5000.0;
      w.write(f);
    }
    w.commit();
  }
  std::string raw;
  {
    mrpt::io::CFileGZInputStream in((dir / "good.rawlog").string());
    char buf[4096];
    std::size_t n = 0;
    while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  }
  std::string size(8, '\0');
  putU32(size, 0, 120);
  putU32(size, 4, 160);
  const std::size_t at = raw.find(size, raw.find("CObservation3DRangeScan"));
  EXPECT_NE(at, std::string::npos);
  putU32(raw, at, 0xFEFEFEFEu);
  putU32(raw, at + 4, 0xFEFEFEFEu);
  {
    mrpt::io::CFileGZOutputStream out((dir / "bad.rawlog").string());
    out.Write(raw.data(), raw.size());
  }
  fs::copy(dir / "good_Images", dir / "bad_Images", fs::copy_options::recursive);
  std::ofstream gt(dir / "bad_groundtruth.txt");
  for (int i = 0; i < 4; ++i) gt << 100.0 + 0.05 * i << " 0 0 " << 0.1 * i << " 0 0 0 1\n";
  return dir / "bad.rawlog";
}

struct Run {
  int exitCode = -1;
  std::string err;
};

Run runTool(const std::string& command, const fs::path& errFile) {
  const int st = std::system((command + " > /dev/null 2> " + errFile.string()).c_str());
  Run r;
  r.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  std::ifstream in(errFile);
  std::stringstream s;
  s << in.rdbuf();
  r.err = s.str();
  return r;
}

std::vector<fs::path> temporariesUnder(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) out.push_back(e.path());
  return out;
}

/// Every tool that reads rawlogs, on `rawlog`: exit code 1, one line `<tool>: error: <rawlog>: ...<expected>`.
void expectEveryToolRefuses(const fs::path& rawlog, const std::string& expected, const std::string& tag) {
  struct Tool {
    std::string name, args;
  };
  const fs::path out = root() / ("out_" + tag);
  const std::string r = rawlog.string();
  const std::vector<Tool> tools = {
      {"slam-run", "--config " + kConfig.string() + " --rawlog " + r + " --out " + (out / "slam").string() + " -q"},
      {"normal-priors", r + " " + (out / "normals" / "n.rawlog").string() + " -q"},
      {"vocab-train", "--rawlog " + r + " --out " + (out / "vocab" / "v.pvoc").string() + " -q"},
      {"bench-slam", "--config " + kConfig.string() + " --rawlog " + r},
      {"manhattan-eval", r + " --json " + (out / "manhattan" / "m.json").string()},
      {"match-oracle", r + " --config " + kConfig.string()},
  };
  for (const Tool& t : tools) {
    SCOPED_TRACE(t.name);
    const fs::path exe = kBin / t.name;
    if (!fs::exists(exe)) {
      ADD_FAILURE() << exe << " is not built";
      continue;
    }
    const Run run = runTool(exe.string() + " " + t.args, root() / ("err_" + tag + "_" + t.name + ".txt"));
    EXPECT_EQ(run.exitCode, 1) << run.err;
    EXPECT_EQ(run.err.rfind(t.name + ": error: " + r + ": ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(expected), std::string::npos) << run.err;
    EXPECT_EQ(run.err.find('\n'), run.err.size() - 1) << "not one line: " << run.err;
  }
  EXPECT_TRUE(temporariesUnder(out).empty()) << temporariesUnder(out).front();
}

}  // namespace

TEST(RawlogCrashCli, CorruptDepthSizeIsOneErrorLineInEveryTool) {
  const fs::path rawlog = syntheticCrashRawlog(root() / "synthetic");
  expectEveryToolRefuses(rawlog, "corrupt rawlog at object 1 (after 1 frames): a DEPTH observation declares a "
                                 "4278124286x4278124286 range image",
                         "synthetic");
}

TEST(RawlogCrashCli, ReproFileIsOneErrorLineInEveryTool) {
  const fs::path repro = fs::path(PRIORSLAM_SHARED_DATA_DIR).parent_path() / "repro" / "rawlog_depth_size_segfault";
  if (!fs::exists(repro / "min.rawlog")) GTEST_SKIP() << repro << " is absent (the shared folder is not here)";
  const fs::path dir = root() / "repro";
  fs::create_directories(dir);
  for (const char* name : {"min.rawlog", "min_groundtruth.txt"})
    fs::copy(repro / name, dir / name);
  fs::copy(repro / "min_Images", dir / "min_Images", fs::copy_options::recursive);
  // The copies are writable (the shared folder is read only; a tool must not need to write there anyway).
  for (const auto& e : fs::recursive_directory_iterator(dir))
    fs::permissions(e.path(), fs::perms::owner_write, fs::perm_options::add);
  expectEveryToolRefuses(dir / "min.rawlog", "a DEPTH observation declares a ", "repro");
}
