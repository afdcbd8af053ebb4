// Dataset2RawlogApp end to end on small datasets written by the test: what is read back with RawlogReader
// and readTumTrajectory must equal what the dataset holds (intrinsics, stamps, u16 depth, poses).
#include <gtest/gtest.h>

#include <mrpt/config/CConfigFileMemory.h>

#include "SyntheticDatasets.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Camera.h"
#include "pslam/datasets/Dataset2RawlogApp.h"
#include "pslam/datasets/Rawlog.h"

using namespace pslam;
using namespace pslam::datasets;
using namespace pslam::datasets::testing;

namespace {

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a.reshape(1) != b.reshape(1)) == 0;
}

std::vector<std::string> listDir(const fs::path& d) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST(Dataset2Rawlog, TumRoundTripKeepsStampsDepthIntrinsicsAndPoses) {
  const fs::path base = freshDir("app_tum");
  const fs::path root = base / "rgbd_dataset_freiburg2_synthetic";
  TumSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.frames = 6;
  writeTumDataset(root, spec);

  Dataset2RawlogOptions opt;
  opt.input = root;
  opt.outDir = base / "out";
  opt.progress = false;
  Dataset2RawlogApp app(opt);
  const auto summary = app.run();
  EXPECT_EQ(summary.format, "tum");
  EXPECT_EQ(summary.frames, 6u);
  EXPECT_EQ(summary.depthFrames, 6u);
  EXPECT_EQ(summary.groundTruthPoses, 4u);  // frames 0 and 1 precede the ground truth
  EXPECT_EQ(summary.rawlogPath, base / "out" / "rgbd_dataset_freiburg2_synthetic.rawlog");
  EXPECT_EQ(summary.groundTruthPath, base / "out" / "rgbd_dataset_freiburg2_synthetic_groundtruth.txt");

  const auto ref = tumCamera("fr2");
  RawlogReader reader(summary.rawlogPath);
  Frame f;
  std::vector<double> stamps;
  std::size_t i = 0;
  while (reader.next(f)) {
    ASSERT_LT(i, 6u);
    stamps.push_back(f.timestamp);
    EXPECT_EQ(f.timestamp, quantizeStamp(tumStamp(spec.t0 + static_cast<double>(i) * spec.dt))) << i;
    EXPECT_NEAR(f.timestamp, spec.t0 + static_cast<double>(i) * spec.dt, 1e-6);
    EXPECT_EQ(f.camera.fx(), ref.fx());
    EXPECT_EQ(f.camera.fy(), ref.fy());
    EXPECT_EQ(f.camera.cx(), ref.cx());
    EXPECT_EQ(f.camera.cy(), ref.cy());
    for (int k = 0; k < 5; ++k) EXPECT_EQ(f.camera.dist[k], ref.dist[k]);
    EXPECT_TRUE(sameMat(f.image, patternImage(640, 480, static_cast<int>(i))));
    ASSERT_TRUE(f.hasDepth());
    EXPECT_TRUE(sameMat(f.depth, depthImage(640, 480, static_cast<int>(i))));  // raw u16, bit-exact
    EXPECT_FLOAT_EQ(static_cast<float>(f.depthUnits), 1.0f / 5000.0f);
    ++i;
  }
  EXPECT_EQ(i, 6u);

  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  ASSERT_EQ(gt.size(), 4u);
  for (std::size_t k = 0; k < gt.size(); ++k) {
    EXPECT_EQ(gt[k].timestamp, stamps[k + 2]) << "GT stamps must equal the CAMERA stamps";
    const Eigen::Isometry3d expected = motion(stamps[k + 2] - spec.t0);
    EXPECT_LT((gt[k].position - expected.translation()).norm(), 1e-4);
    EXPECT_LT(Eigen::AngleAxisd(gt[k].orientation.toRotationMatrix().transpose() * expected.linear()).angle(), 1e-4);
  }
  // Nothing but the three outputs in the folder (no temporaries left behind).
  EXPECT_EQ(listDir(base / "out"),
            (std::vector<std::string>{"rgbd_dataset_freiburg2_synthetic.rawlog", "rgbd_dataset_freiburg2_synthetic_Images",
                                      "rgbd_dataset_freiburg2_synthetic_groundtruth.txt"}));
}

TEST(Dataset2Rawlog, RangeStrideGreyAndNoDepth) {
  const fs::path base = freshDir("app_range");
  const fs::path root = base / "rgbd_dataset_freiburg3_synthetic";
  TumSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.frames = 7;
  writeTumDataset(root, spec);
  Dataset2RawlogOptions opt;
  opt.input = root;
  opt.outDir = base / "out";
  opt.name = "sub";
  opt.first = 1;
  opt.stride = 2;
  opt.count = 2;
  opt.color = "grey";
  opt.noDepth = true;
  opt.progress = false;
  const auto summary = Dataset2RawlogApp(opt).run();
  EXPECT_EQ(summary.frames, 2u);
  EXPECT_EQ(summary.depthFrames, 0u);
  RawlogReader reader(base / "out" / "sub.rawlog");
  Frame f;
  ASSERT_TRUE(reader.next(f));
  EXPECT_EQ(f.timestamp, quantizeStamp(tumStamp(spec.t0 + 1 * spec.dt)));
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_FALSE(f.hasDepth());
  ASSERT_TRUE(reader.next(f));
  EXPECT_EQ(f.timestamp, quantizeStamp(tumStamp(spec.t0 + 3 * spec.dt)));
  EXPECT_FALSE(reader.next(f));
  EXPECT_EQ(RawlogReader::countFrames(base / "out" / "sub.rawlog"), 2u);
}

TEST(Dataset2Rawlog, FailureLeavesNoOutputBehind) {
  const fs::path base = freshDir("app_fail");
  const fs::path root = base / "rgbd_dataset_freiburg3_synthetic";
  TumSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.frames = 4;
  writeTumDataset(root, spec);
  // The last image is corrupt: the conversion fails after three frames were written.
  char name[64];
  std::snprintf(name, sizeof(name), "%.6f.png", spec.t0 + 3 * spec.dt);
  writeText(root / "rgb" / name, "garbage");
  Dataset2RawlogOptions opt;
  opt.input = root;
  opt.outDir = base / "out";
  opt.progress = false;
  try {
    Dataset2RawlogApp(opt).run();
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
  EXPECT_TRUE(listDir(base / "out").empty()) << "rawlog, images folder or ground truth left behind";
}

TEST(Dataset2Rawlog, KittiWithoutCalibAndTimesUsesIniIntrinsicsAndRate) {
  const fs::path base = freshDir("app_kitti");
  const fs::path seq = base / "sequences" / "00";
  char file[32];
  for (int i = 0; i < 3; ++i) {
    std::snprintf(file, sizeof(file), "%06d.png", i);
    writeImage(seq / "image_0" / file, patternImage(1241, 376, i, CV_8UC1));
  }
  std::string poses;
  for (int i = 0; i < 5; ++i) poses += kittiLine(motion(0.1 * i));
  writeText(base / "poses" / "00.txt", poses);

  Dataset2RawlogOptions opt;
  opt.input = seq;
  opt.outDir = base / "out";
  opt.progress = false;
  try {
    Dataset2RawlogApp(opt).run();
    FAIL() << "calib.txt is missing: must ask for intrinsics";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("calib.txt"), std::string::npos) << e.what();
  }
  opt.cameraIni = fs::path(PRIORSLAM_SOURCE_DIR) / "config" / "cameras" / "kitti_00-02.ini";
  const auto summary = Dataset2RawlogApp(opt).run();  // frame rate from the ini's frame_rate_hz
  EXPECT_EQ(summary.frames, 3u);
  EXPECT_EQ(summary.groundTruthPoses, 3u);
  EXPECT_EQ(summary.rawlogPath.filename(), "kitti_00.rawlog");
  bool saidRate = false;
  for (const auto& a : summary.assumptions) saidRate = saidRate || a.find("frame_rate_hz") != std::string::npos;
  EXPECT_TRUE(saidRate);

  RawlogReader reader(summary.rawlogPath);
  Frame f;
  std::vector<double> stamps;
  while (reader.next(f)) {
    EXPECT_EQ(f.camera.fx(), 718.856);
    EXPECT_EQ(f.camera.cx(), 607.1928);
    stamps.push_back(f.timestamp);
  }
  ASSERT_EQ(stamps.size(), 3u);
  EXPECT_EQ(stamps[2], quantizeStamp(0.2));
  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  ASSERT_EQ(gt.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(gt[k].timestamp, stamps[k]);
    const Eigen::Isometry3d expected = motion(0.1 * static_cast<double>(k));
    EXPECT_LT((gt[k].position - expected.translation()).norm(), 1e-7);  // 9 significant digits in the file
  }
}

TEST(Dataset2Rawlog, OptionsCheckNamesTheKeyAndConfigRoundTrips) {
  Dataset2RawlogOptions opt;
  opt.input = "in";
  opt.outDir = "out";
  auto expectKey = [](const Dataset2RawlogOptions& o, const std::string& key) {
    try {
      o.check();
      FAIL() << key << ": no exception";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("[dataset2rawlog] " + key, 0), 0u) << e.what();
    }
  };
  {
    auto o = opt;
    o.imageFormat = "jpg";
    expectKey(o, "image_format");
  }
  {
    auto o = opt;
    o.stride = 0;
    expectKey(o, "stride");
  }
  {
    auto o = opt;
    o.format = "bag";
    expectKey(o, "format = bag: must be one of auto, tum, icl, kitti, euroc, folder");
  }
  {
    auto o = opt;
    o.intrinsics = {1, 2, 3};
    expectKey(o, "intrinsics");
  }
  {
    auto o = opt;
    o.maxDepthDiff = -1;
    expectKey(o, "max_depth_diff");
  }
  {
    auto o = opt;
    o.color = "sepia";
    expectKey(o, "color");
  }
  opt.first = 3;
  opt.stride = 2;
  opt.intrinsics = {700, 701, 600, 180};
  opt.distortion = {0.1, -0.2, 0.001, 0.002};
  opt.rate = 10;
  opt.tumCamera = "fr2";
  mrpt::config::CConfigFileMemory cfg;
  opt.saveToConfigFile(cfg, "dataset2rawlog");
  Dataset2RawlogOptions back;
  back.loadFromConfigFile(cfg, "dataset2rawlog");
  EXPECT_EQ(back.input, opt.input);
  EXPECT_EQ(back.first, 3u);
  EXPECT_EQ(back.stride, 2u);
  EXPECT_EQ(back.intrinsics, opt.intrinsics);
  EXPECT_EQ(back.distortion, opt.distortion);
  EXPECT_EQ(back.rate, 10.0);
  EXPECT_EQ(back.tumCamera, "fr2");
  EXPECT_EQ(back.last, opt.last);
  EXPECT_NO_THROW(back.check());
  const auto loadError = [](const std::string& ini) {
    mrpt::config::CConfigFileMemory cfg(ini);
    Dataset2RawlogOptions o;
    try {
      o.loadFromConfigFile(cfg, "s");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(loadError("[s]\nfirst = -3\n"), "[s] first = -3: integer out of range [0, 18446744073709551615]");
  EXPECT_EQ(loadError("[s]\nstride = 2.5\n"), "[s] stride = 2.5: not an integer");
  EXPECT_EQ(loadError("[s]\nrate = abc\n"), "[s] rate = abc: not a number");
  EXPECT_EQ(loadError("[s]\nrate = 10 Hz\n"), "[s] rate = 10 Hz: not a number");
  EXPECT_EQ(loadError("[s]\nmax_depth_diff = nan\n"), "[s] max_depth_diff = nan: not a number");
  EXPECT_EQ(loadError("[s]\nno_depth = maybe\n"), "[s] no_depth = maybe: not a bool (true or false)");
  EXPECT_EQ(loadError("[s]\nkitti_camera = 1\n"), "[s] kitti_camera = 1: must be 0, 2 or -1 (auto)");
  EXPECT_EQ(loadError("[s]\nintrinsics = 700, 700, x, 180\n"),
            "[s] intrinsics = 700, 700, x, 180: 'x': not a number (expected numbers separated by commas or spaces)");
  EXPECT_EQ(loadError("[s]\nintrinsics = 700 700 600\n"), "[s] intrinsics = 700 700 600: expected 4 values fx,fy,cx,cy");
  EXPECT_EQ(loadError("[s]\ndistortion = 0.1\n"), "[s] distortion = 0.1: only valid together with intrinsics");
  EXPECT_EQ(loadError("[s]\nout_directory = x\n"), "[s] out_directory: unknown key (did you mean out_dir?)");
  EXPECT_EQ(loadError("[s]\ninput = in\n"), "");  // out_dir may still come from the command line
}
