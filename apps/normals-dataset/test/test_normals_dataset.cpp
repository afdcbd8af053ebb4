// The normals-dataset app class: reproducible views, consistent triples, the split by seed, option errors.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Params.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/synth/NormalsDataset.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam::synth;

namespace {
NormalsDatasetOptions small() {
  NormalsDatasetOptions o;
  o.scenarios = "room,lowtexture";
  o.trainSeeds = 2;
  o.testSeeds = 1;
  o.views = 2;
  o.width = 48;
  o.height = 36;
  o.supersampling = 1;
  return o;
}
}  // namespace

TEST(NormalsDataset, ViewsAreReproducibleAndIndependentOfTheRange) {
  const NormalsDataset ds(small());
  const auto a = ds.renderSequence("room", 3, 0, 3);
  const auto b = ds.renderSequence("room", 3, 2, 1);
  ASSERT_EQ(a.size(), 3u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(cv::norm(a[2].image, b[0].image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a[2].normals, b[0].normals, cv::NORM_INF), 0.0);
  EXPECT_NE(cv::norm(a[0].image, a[1].image, cv::NORM_L1), 0.0);  // views differ
}

TEST(NormalsDataset, NormalsAreUnitFacingTheCameraInsideTheMask) {
  const NormalsDataset ds(small());
  for (const auto& s : ds.renderSequence("corridor", 5, 0, 2)) {
    ASSERT_EQ(s.image.type(), CV_8UC1);
    ASSERT_EQ(s.image.size(), cv::Size(48, 36));
    EXPECT_GT(cv::countNonZero(s.mask), 0.9 * 48 * 36);  // indoor: surfaces everywhere
    for (int v = 0; v < s.normals.rows; ++v)
      for (int u = 0; u < s.normals.cols; ++u) {
        const cv::Vec3f n = s.normals.at<cv::Vec3f>(v, u);
        if (!s.mask.at<uchar>(v, u)) continue;
        EXPECT_NEAR(cv::norm(n), 1.0, 1e-4);
        const cv::Vec3f ray(float((u - s.camera.cx) / s.camera.fx), float((v - s.camera.cy) / s.camera.fy), 1.f);
        EXPECT_LE(n.dot(ray), 1e-6);
      }
  }
}

TEST(NormalsDataset, WritesTriplesSplitBySeed) {
  pslam::test_support::TempDir dir("normals_dataset");
  NormalsDatasetOptions o = small();
  o.outDir = dir.path / "out";
  o.progress = false;
  const auto sum = NormalsDataset(o).run();
  EXPECT_EQ(sum.trainViews, 2u * 2u * 2u);
  EXPECT_EQ(sum.testViews, 2u * 1u * 2u);
  const fs::path train = o.outDir / "train", test = o.outDir / "test";
  ASSERT_TRUE(fs::is_regular_file(train / "manifest.csv"));
  ASSERT_TRUE(fs::is_regular_file(o.outDir / "dataset.json"));
  EXPECT_TRUE(fs::is_regular_file(train / "room_s1_0000_image.png"));
  EXPECT_TRUE(fs::is_regular_file(train / "lowtexture_s2_0001_mask.png"));
  EXPECT_TRUE(fs::is_regular_file(test / "room_s1001_0001_normal.png"));
  EXPECT_FALSE(fs::exists(train / "room_s1001_0000_image.png"));
  // The normal PNG decodes to the rendered normals (8-bit quantization: < 0.5 degrees).
  const auto s = NormalsDataset(o).renderSequence("room", 1001, 1, 1).front();
  const cv::Mat decoded = pslam::priors::decodeNormalMap(cv::imread((test / "room_s1001_0001_normal.png").string(),
                                                                    cv::IMREAD_UNCHANGED));
  pslam::priors::NormalErrorAccumulator acc;
  acc.addMaps(decoded, s.normals);
  EXPECT_EQ(acc.summary().count, static_cast<std::size_t>(cv::countNonZero(s.mask)));
  EXPECT_LT(acc.summary().meanDeg, 0.5);
  std::ifstream manifest(test / "manifest.csv");
  std::string header, line;
  std::getline(manifest, header);
  std::size_t lines = 0;
  while (std::getline(manifest, line)) ++lines;
  EXPECT_EQ(lines, sum.testViews);
}

TEST(NormalsDataset, BadOptionsNameTheKey) {
  NormalsDatasetOptions o = small();
  o.scenarios = "room,attic";
  EXPECT_THROW(
      {
        try {
          NormalsDataset{o};
        } catch (const pslam::params::ParamError& e) {
          EXPECT_NE(std::string(e.what()).find("scenarios"), std::string::npos) << e.what();
          EXPECT_NE(std::string(e.what()).find("attic"), std::string::npos) << e.what();
          throw;
        }
      },
      pslam::params::ParamError);
  o = small();
  o.focalMin = 1.5;
  o.focalMax = 1.0;
  EXPECT_THROW(NormalsDataset{o}, pslam::params::ParamError);
  o = small();
  EXPECT_THROW(NormalsDataset(o).run(), pslam::params::ParamError);  // no out_dir
}

TEST(NormalsDataset, LookingDownShowsMoreFloor) {
  // The same views with and without the downward look: the draws are otherwise identical, and the share of
  // pixels whose normal points up (camera -y after the turn, i.e. the floor) grows.
  NormalsDatasetOptions o = small();
  o.lookDownShare = 1.0;
  o.lookDownMinDeg = o.lookDownMaxDeg = 40.0;
  NormalsDatasetOptions flat = o;
  flat.lookDownShare = 0.0;
  const auto down = NormalsDataset(o).renderSequence("room", 4, 0, 4);
  const auto level = NormalsDataset(flat).renderSequence("room", 4, 0, 4);
  auto floorShare = [](const NormalsSample& s) {
    // Floor normal in the camera frame: the world up vector; with a level camera it is about -y.
    int n = 0;
    for (auto it = s.normals.begin<cv::Vec3f>(); it != s.normals.end<cv::Vec3f>(); ++it) n += (*it)[1] < -0.5f;
    return double(n) / double(s.normals.total());
  };
  double sumDown = 0, sumLevel = 0;
  for (std::size_t i = 0; i < down.size(); ++i) {
    EXPECT_NEAR(down[i].draws.pitchDeg, level[i].draws.pitchDeg - 40.0, 1e-9);
    EXPECT_EQ(down[i].draws.time, level[i].draws.time);
    sumDown += floorShare(down[i]);
    sumLevel += floorShare(level[i]);
  }
  EXPECT_GT(sumDown, sumLevel + 0.5);  // over 4 views
}
