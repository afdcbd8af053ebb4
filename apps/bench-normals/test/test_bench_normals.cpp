// bench-normals' app class on a tiny split written by normals-dataset's format: reading, per-group accuracy,
// the panel, and errors naming the file.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/priors/BenchNormals.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam::priors;

namespace {

/// Two views of a constant normal (0, 0, -1) (a wall facing the camera), one of group "a", one of "b".
void writeSplit(const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream m(dir / "manifest.csv");
  m << "stem,scenario,seed,view,width,height,fx,fy,cx,cy\n";
  for (const char* stem : {"a_s1_0000", "b_s1_0000"}) {
    m << stem << "," << std::string(stem).substr(0, 1) << ",1,0,32,32,30,30,15.5,15.5\n";
    cv::imwrite((dir / (std::string(stem) + "_image.png")).string(), cv::Mat(32, 32, CV_8UC1, cv::Scalar(100)));
    cv::imwrite((dir / (std::string(stem) + "_normal.png")).string(), cv::Mat(32, 32, CV_8UC3, cv::Scalar(128, 128, 0)));
    cv::Mat mask(32, 32, CV_8UC1, cv::Scalar(255));
    mask(cv::Rect(0, 0, 32, 8)).setTo(0);  // the top quarter is not evaluated
    cv::imwrite((dir / (std::string(stem) + "_mask.png")).string(), mask);
  }
}

}  // namespace

TEST(BenchNormals, ReadsASplitFolder) {
  pslam::test_support::TempDir dir("bench_normals_read");
  writeSplit(dir.path / "test");
  const auto views = readNormalViews(dir.path / "test");
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].group, "a");
  EXPECT_EQ(views[1].group, "b");
  EXPECT_DOUBLE_EQ(views[0].K.fx, 30.0);
  const cv::Vec3f n = views[0].normals.at<cv::Vec3f>(5, 5);
  EXPECT_NEAR(n[2], -1.0, 1e-2);
  EXPECT_EQ(cv::countNonZero(views[0].mask), 32 * 24);
  EXPECT_EQ(readNormalViews(dir.path / "test", 1).size(), 1u);
}

TEST(BenchNormals, ErrorsNameTheFile) {
  pslam::test_support::TempDir dir("bench_normals_errors");
  const std::string missing = pslam::test_support::errorOf([&] { readNormalViews(dir.path / "nothing"); });
  EXPECT_NE(missing.find((dir.path / "nothing" / "manifest.csv").string()), std::string::npos) << missing;
  writeSplit(dir.path / "test");
  fs::remove(dir.path / "test" / "b_s1_0000_mask.png");
  const std::string noMask = pslam::test_support::errorOf([&] { readNormalViews(dir.path / "test"); });
  EXPECT_NE(noMask.find("b_s1_0000_mask.png"), std::string::npos) << noMask;
  BenchNormalsOptions o;
  o.config = dir.path / "absent.ini";
  o.data = dir.path / "test";
  const std::string noIni = pslam::test_support::errorOf([&] { runBenchNormals(o); });
  EXPECT_NE(noIni.find("absent.ini"), std::string::npos) << noIni;
}

TEST(BenchNormals, PanelHasOneRowOfFourTilesPerView) {
  pslam::test_support::TempDir dir("bench_normals_panel");
  writeSplit(dir.path / "test");
  const auto views = readNormalViews(dir.path / "test");
  std::vector<cv::Mat> predictions = {views[0].normals, views[1].normals};
  const cv::Mat panel = normalViewsPanel(views, predictions, 2);
  EXPECT_EQ(panel.size(), cv::Size(4 * 64, 2 * 64));
  EXPECT_EQ(panel.type(), CV_8UC3);
}
