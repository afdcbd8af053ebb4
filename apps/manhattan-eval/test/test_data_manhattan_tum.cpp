// TUM fr3_cabinet (every 20th frame): dataset2rawlog -> normal-priors (depth) -> manhattan-eval.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include "pslam/datasets/Dataset2RawlogApp.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/manhattan/ManhattanEvalApp.h"
#include "pslam/priors/NormalPriorsApp.h"

namespace fs = std::filesystem;
using namespace pslam;

TEST(DataManhattanTum, CabinetRotationAgainstGroundTruth) {
  const fs::path folder = fs::path(PRIORSLAM_SHARED_DATA_DIR) / "tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th";
  if (!fs::is_directory(folder)) GTEST_SKIP() << "shared data not found: " << folder;
  const fs::path tmp = fs::temp_directory_path() / ("pslam_manhattan_tum_" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  struct Cleanup {
    fs::path p;
    ~Cleanup() { fs::remove_all(p); }
  } cleanup{tmp};

  datasets::Dataset2RawlogOptions conv;
  conv.input = folder;
  conv.outDir = tmp;
  conv.name = "cabinet";
  conv.format = "tum";
  conv.tumCamera = "fr3";
  conv.progress = false;
  const auto converted = datasets::Dataset2RawlogApp(conv).run();
  ASSERT_EQ(converted.frames, 58u);
  ASSERT_TRUE(fs::exists(tmp / "cabinet_groundtruth.txt"));

  priors::NormalPriorsOptions np;
  np.input = tmp / "cabinet.rawlog";
  np.output = tmp / "cabinet_normals.rawlog";
  np.source = "depth";
  np.config = fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan/tum_fr3_depth.ini";
  np.progress = false;
  const auto npr = priors::runNormalPriors(np);
  EXPECT_EQ(npr.frames, 58u);
  EXPECT_GT(npr.meanPlanarShare, 0.2);  // the cabinet and the floor fill much of the view

  manhattan::ManhattanEvalOptions eo;
  eo.rawlog = np.output;
  eo.normals = "rawlog";
  eo.config = np.config;
  eo.outputJson = tmp / "eval.json";
  eo.progress = false;
  const auto r = manhattan::runManhattanEval(eo);
  std::cout << r.text;
  ASSERT_TRUE(fs::exists(eo.outputJson));
  const auto& s = r.report["summary"];
  EXPECT_EQ(s["frames"].get<std::size_t>(), 58u);
  // Acceptance bounds from the thesis' use of AHC normals as the accurate reference ("-w AHC", §4.5.5):
  // most frames tracked, rotation error of a few degrees at most.
  EXPECT_GT(s["success_share"].get<double>(), 0.8);
  EXPECT_LT(s["rotation_error_median_deg"].get<double>(), 3.0);
  EXPECT_LT(s["rotation_error_max_deg"].get<double>(), 10.0);
}
