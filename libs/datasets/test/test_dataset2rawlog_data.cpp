// Data tests: converts the shared real datasets (read-only) into a temp folder and checks counts, stamps and
// ground truth against the source files. Skipped when ../shared/data is absent.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Dataset2RawlogApp.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::datasets;

namespace {

const fs::path kData = PRIORSLAM_SHARED_DATA_DIR;

fs::path freshOut(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("pslam_test_d2r_data_" + name);
  fs::remove_all(d);
  return d;
}

struct ReadBack {
  std::size_t camera = 0, depth = 0;
  std::vector<double> stamps;
};

ReadBack readBack(const fs::path& rawlog) {
  ReadBack r;
  RawlogReader reader(rawlog);
  Frame f;
  while (reader.next(f)) {
    ++r.camera;
    r.depth += f.hasDepth() ? 1 : 0;
    r.stamps.push_back(f.timestamp);
  }
  return r;
}

}  // namespace

TEST(Dataset2RawlogData, KittiSequence00Subset) {
  const fs::path seq = kData / "kitti_odometry" / "sequences" / "00";
  if (!fs::is_directory(seq)) GTEST_SKIP() << "shared data not found: " << seq;
  Dataset2RawlogOptions opt;
  opt.input = seq;
  opt.outDir = freshOut("kitti");
  opt.cameraIni = fs::path(PRIORSLAM_SOURCE_DIR) / "config" / "cameras" / "kitti_00-02.ini";
  opt.progress = false;
  const auto summary = Dataset2RawlogApp(opt).run();
  std::printf("[ measured ] %s\n", summary.line().c_str());
  EXPECT_EQ(summary.frames, 200u);
  EXPECT_EQ(summary.groundTruthPoses, 200u);
  const ReadBack r = readBack(summary.rawlogPath);
  EXPECT_EQ(r.camera, 200u);
  EXPECT_EQ(r.depth, 0u);
  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  ASSERT_EQ(gt.size(), 200u);
  const Trajectory source = [&] {
    // poses/00.txt line i = T_world_cam0 of frame i.
    Trajectory t;
    std::ifstream in(kData / "kitti_odometry" / "poses" / "00.txt");
    double v[12];
    while (t.size() < 200 && in >> v[0]) {
      for (int k = 1; k < 12; ++k) in >> v[k];
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      for (int row = 0; row < 3; ++row)
        for (int c = 0; c < 4; ++c) T.matrix()(row, c) = v[4 * row + c];
      t.emplace_back(0.0, T);
    }
    return t;
  }();
  ASSERT_EQ(source.size(), 200u);
  for (std::size_t i = 0; i < 200; ++i) {
    EXPECT_EQ(gt[i].timestamp, r.stamps[i]);
    EXPECT_NEAR(r.stamps[i], i * 0.1, 1e-9);  // 10 Hz nominal from the ini (no times.txt here)
    EXPECT_LT((gt[i].position - source[i].position).norm(), 1e-5 * (1.0 + source[i].position.norm()));
    EXPECT_LT(gt[i].orientation.angularDistance(source[i].orientation), 1e-5);
  }
  fs::remove_all(opt.outDir);
}

TEST(Dataset2RawlogData, TumFr3CabinetEvery20th) {
  const fs::path root = kData / "tum_rgbd" / "rgbd_dataset_freiburg3_cabinet_every20th";
  if (!fs::is_directory(root)) GTEST_SKIP() << "shared data not found: " << root;
  Dataset2RawlogOptions opt;
  opt.input = root;
  opt.outDir = freshOut("tum");
  opt.progress = false;
  const auto summary = Dataset2RawlogApp(opt).run();
  std::printf("[ measured ] %s\n", summary.line().c_str());
  EXPECT_EQ(summary.frames, 58u);
  EXPECT_EQ(summary.depthFrames, 58u);
  EXPECT_EQ(summary.groundTruthPoses, 58u);
  const ReadBack r = readBack(summary.rawlogPath);
  EXPECT_EQ(r.camera, 58u);
  EXPECT_EQ(r.depth, 58u);
  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  const Trajectory source = readTumTrajectory(root / "groundtruth.txt");
  ASSERT_EQ(gt.size(), 58u);
  ASSERT_EQ(source.size(), 58u);
  for (std::size_t i = 0; i < 58; ++i) {
    EXPECT_EQ(gt[i].timestamp, r.stamps[i]);
    EXPECT_NEAR(gt[i].timestamp, source[i].timestamp, 1e-6);  // one GT pose per frame, same stamp
    EXPECT_LT((gt[i].position - source[i].position).norm(), 1e-7);
    EXPECT_LT(gt[i].orientation.angularDistance(source[i].orientation), 1e-7);
  }
  fs::remove_all(opt.outDir);
}
