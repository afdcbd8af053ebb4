// End to end: the slam-synth binary and the stock MRPT tool read what we write; an interrupted run leaves
// nothing behind.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;

namespace {

bool onPath(const std::string& tool) { return std::system(("command -v " + tool + " > /dev/null 2>&1").c_str()) == 0; }

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

fs::path tool() { return fs::path(PRIORSLAM_BINARY_DIR) / "bin" / "slam-synth"; }

/// A fresh folder for one test in this process's temporary folder (removed when the process ends).
fs::path tempDir(const std::string& name) {
  static const pslam::test_support::TempDir root("pslam_test_synth_e2e");
  return pslam::test_support::freshSubDir(root, name);
}

}  // namespace

TEST(SlamSynthE2E, GeneratesARawlogThatRawlogEditReads) {
  if (!fs::exists(tool())) GTEST_SKIP() << "slam-synth not built (configure with the slam-synth component)";
  const fs::path d = tempDir("info");
  const std::string cmd = tool().string() + " --scenario street --frames 3 --width 64 --height 48 --quiet --out " +
                          d.string() + " > " + (d / "stdout.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(d / "stdout.txt");
  EXPECT_NE(slurp(d / "stdout.txt").find("frames: 3"), std::string::npos);
  ASSERT_TRUE(fs::exists(d / "street.rawlog"));
  ASSERT_TRUE(fs::exists(d / "street_Labels" / "LABEL_000002.png"));
  if (!onPath("rawlog-edit")) GTEST_SKIP() << "rawlog-edit is not on PATH";
  const std::string info = "rawlog-edit --info -i " + (d / "street.rawlog").string() + " > " +
                           (d / "info.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(info.c_str()), 0) << slurp(d / "info.txt");
  const std::string out = slurp(d / "info.txt");
  for (const char* label : {"CAMERA", "DEPTH", "SEMANTIC", "NORMALS"})
    EXPECT_NE(out.find(label), std::string::npos) << label << " missing in:\n" << out;
}

TEST(SlamSynthE2E, BadInputGivesOneErrorLineAndExitCode1) {
  if (!fs::exists(tool())) GTEST_SKIP() << "slam-synth not built";
  const fs::path d = tempDir("bad");
  const std::string cmd = tool().string() + " --scenario moon --out " + d.string() + " 2> " + (d / "err.txt").string();
  const int rc = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 1);
  const std::string err = slurp(d / "err.txt");
  EXPECT_EQ(err.rfind("slam-synth: error: ", 0), 0u) << err;
  EXPECT_NE(err.find("moon"), std::string::npos);
  EXPECT_TRUE(fs::is_empty(d) || (fs::directory_iterator(d)->path().filename() == "err.txt"));
  // A path variant the scenario does not have.
  const std::string cmd2 = tool().string() + " --scenario jam --path-variant 1 --frames 1 --out " + (d / "v").string() +
                           " 2> " + (d / "err2.txt").string();
  const int rc2 = std::system(cmd2.c_str());
  EXPECT_TRUE(WIFEXITED(rc2) && WEXITSTATUS(rc2) == 1);
  const std::string err2 = slurp(d / "err2.txt");
  EXPECT_EQ(err2, "slam-synth: error: [synth] path_variant = 1: scenario 'jam' has no path variant 1 (it has only 0)\n");
  EXPECT_FALSE(fs::exists(d / "v"));
}

namespace {
/// Paths under `dir` (recursively) whose name holds ".tmp-": the temporaries of AtomicOutput.
std::vector<fs::path> temporariesUnder(const fs::path& dir) {
  std::vector<fs::path> found;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().find(".tmp-") != std::string::npos) found.push_back(it->path());
  return found;
}

/// True once the images temporary of slam-synth holds a file (the run is writing its outputs).
bool writingStarted(const fs::path& dir) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find("_Images.tmp-") != std::string::npos && it->is_directory() && !fs::is_empty(it->path(), ec))
      return true;
  }
  return false;
}
}  // namespace

// Reliability (doc/reliability.md): SIGINT / SIGTERM while the outputs are being written leave no temporary
// file behind, commit nothing, and end the process by the signal (non-zero exit).
TEST(SlamSynthE2E, InterruptLeavesNoTemporaryFiles) {
  if (!fs::exists(tool())) GTEST_SKIP() << "slam-synth not built";
  for (const int sig : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(sig == SIGINT ? "SIGINT" : "SIGTERM");
    const fs::path d = tempDir("signal_" + std::to_string(sig));
    const std::string exe = tool().string(), out = d.string();  // no allocation after fork
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      // As from an interactive shell, whatever the test runner ignores.
      ::signal(SIGINT, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      const int devNull = ::open("/dev/null", O_WRONLY);
      ::dup2(devNull, 1);
      ::dup2(devNull, 2);
      ::execl(exe.c_str(), exe.c_str(), "--scenario", "room", "--frames", "20000", "--width", "160", "--height",
              "120", "--threads", "2", "--quiet", "--out", out.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    bool started = false;
    while (!(started = writingStarted(d)) && std::chrono::steady_clock::now() < deadline) {
      if (::waitpid(pid, nullptr, WNOHANG) == pid) break;  // ended on its own: reported below
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(started) << "slam-synth did not start writing";
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // in the middle of writing frames
    ::kill(pid, sig);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
    for (const auto& p : temporariesUnder(d)) ADD_FAILURE() << "left behind: " << p;
    EXPECT_FALSE(fs::exists(d / "room.rawlog"));
    fs::remove_all(d);
  }
}
