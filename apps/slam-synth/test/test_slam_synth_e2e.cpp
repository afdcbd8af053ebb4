// End to end: the slam-synth binary and the stock MRPT tool read what we write.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

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

fs::path tempDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("pslam_test_synth_e2e_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
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
}
