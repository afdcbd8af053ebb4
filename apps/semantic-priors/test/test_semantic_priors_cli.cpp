// e2e: the semantic-priors executable on a small rawlog with a label folder, and its one-line errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const std::string kTool = std::string(PRIORSLAM_BINARY_DIR) + "/bin/semantic-priors";

int run(const std::string& args, const fs::path& log) {
  const int status = std::system((kTool + " " + args + " > " + log.string() + " 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(SemanticPriorsCli, LabelsToSemanticChannelAndCleanErrors) {
  const fs::path dir = fs::temp_directory_path() / "pslam_e2e_semantic_priors";
  fs::remove_all(dir);
  fs::create_directories(dir / "seq_Labels");
  {
    datasets::RawlogWriter w(dir / "seq.rawlog");
    for (int i = 0; i < 2; ++i) {
      datasets::Frame f;
      f.timestamp = i;
      f.image = cv::Mat(16, 20, CV_8UC3, cv::Scalar(10, 20, 30));
      f.camera.ncols = 20;
      f.camera.nrows = 16;
      f.camera.fx(20);
      f.camera.fy(20);
      f.camera.cx(10);
      f.camera.cy(8);
      w.write(f);
      cv::Mat lab(16, 20, CV_8UC1, cv::Scalar(11));  // person everywhere
      char name[32];
      std::snprintf(name, sizeof(name), "LABEL_%06d.png", i);
      cv::imwrite((dir / "seq_Labels" / name).string(), lab);
    }
    w.commit();
  }
  const fs::path log = dir / "log.txt";
  ASSERT_EQ(run((dir / "seq.rawlog").string() + " " + (dir / "out.rawlog").string() + " --labels " +
                    (dir / "seq_Labels").string() + " --overlay-dir " + (dir / "ov").string() + " --quiet",
                log),
            0)
      << readText(log);
  EXPECT_NE(readText(log).find("frames: 2"), std::string::npos) << readText(log);
  EXPECT_TRUE(fs::exists(dir / "ov" / "overlay_000001.png"));
  datasets::RawlogReader r(dir / "out.rawlog");
  datasets::Frame f;
  ASSERT_TRUE(r.next(f));
  ASSERT_TRUE(f.hasSemantic());
  EXPECT_EQ(f.semantic.at<cv::Vec3b>(5, 5), cv::Vec3b(0, 255, 0));

  // Missing input: exit code 1 and one line "semantic-priors: error: ...".
  EXPECT_EQ(run((dir / "none.rawlog").string() + " " + (dir / "x.rawlog").string() + " --labels " +
                    (dir / "seq_Labels").string(),
                log),
            1);
  const std::string err = readText(log);
  EXPECT_EQ(err.rfind("semantic-priors: error: ", 0), 0u) << err;
  EXPECT_NE(err.find("none.rawlog"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_FALSE(fs::exists(dir / "x.rawlog"));
  fs::remove_all(dir);
}
