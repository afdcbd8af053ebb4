// Data tests: converts the shared real datasets (read-only) into a temp folder and checks counts, stamps and
// ground truth against the source files. Skipped when ../shared/data is absent.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <unistd.h>
#include <fstream>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Dataset2RawlogApp.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/datasets/Readers.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::datasets;

namespace {

const fs::path kData = PRIORSLAM_SHARED_DATA_DIR;

fs::path freshOut(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("pslam_test_d2r_data_" + name + "_" + std::to_string(::getpid()));
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

  // Reliability (doc/reliability.md): one byte XORed in the middle of the TUM rawlog (gzip -t: CRC error) is
  // reported as corrupt with the file and the byte offset, not read as all frames with altered data.
  std::string bytes;
  {
    std::ifstream in(summary.rawlogPath, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    bytes = ss.str();
  }
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x01);
  const fs::path xored = opt.outDir / "xored.rawlog";
  std::ofstream(xored, std::ios::binary) << bytes;
  fs::create_directory_symlink(RawlogWriter::imagesDirFor(summary.rawlogPath), RawlogWriter::imagesDirFor(xored));
  try {
    readBack(xored);
    ADD_FAILURE() << "a rawlog with a changed byte was read without an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("xored.rawlog: corrupt rawlog: corrupt gzip data (zlib: "), std::string::npos) << msg;
  }
  fs::remove_all(opt.outDir);
}

TEST(Dataset2RawlogData, IclNuimLivingRoomWithoutDepthIsDetectedAndItsPosesReflected) {
  // The shared lr-kt3 subset: rgb.txt, no depth, livingRoom3n.gt.freiburg (and groundtruth.txt) of frame ids.
  const fs::path root = kData / "icl_nuim" / "living_room_traj3n_first200";
  if (!fs::is_directory(root)) GTEST_SKIP() << "shared data not found: " << root;
  Dataset2RawlogOptions opt;
  opt.input = root;  // format auto
  opt.outDir = freshOut("icl");
  opt.progress = false;
  const auto summary = Dataset2RawlogApp(opt).run();
  std::printf("[ measured ] %s\n", summary.line().c_str());
  EXPECT_EQ(summary.format, "icl");
  EXPECT_EQ(summary.frames, 200u);
  EXPECT_EQ(summary.depthFrames, 0u);
  std::string said;
  for (const std::string& a : summary.assumptions) said += a + "\n";
  EXPECT_NE(said.find("ICL-NUIM pose convention: poses reflected about the XZ plane"), std::string::npos) << said;
  EXPECT_NE(said.find("livingRoom3n.gt.freiburg"), std::string::npos) << said;
  // Frame 0 has no official pose; frames 1..199 do, at id / 30 Hz, reflected: y negated, the rotation S R S.
  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  const Trajectory source = readTumTrajectory(root / "groundtruth.txt");
  ASSERT_EQ(gt.size(), 199u);
  ASSERT_EQ(source.size(), 199u);
  const Eigen::Matrix3d S = Eigen::Vector3d(1, -1, 1).asDiagonal();
  for (std::size_t i = 0; i < gt.size(); ++i) {
    EXPECT_NEAR(gt[i].timestamp, source[i].timestamp / 30.0, 1e-6);
    EXPECT_LT((gt[i].position - S * source[i].position).norm(), 1e-6);
    const Eigen::Matrix3d R = S * source[i].orientation.toRotationMatrix() * S;
    EXPECT_LT((gt[i].orientation.toRotationMatrix() - R).norm(), 1e-6);
  }
  fs::remove_all(opt.outDir);
}

TEST(Dataset2RawlogData, EurocGroundTruthOfV102IsMovedToTheCamera) {
  // The real EuRoC V1_02 body ground truth (ASL csv) with three synthetic images at three of its stamps.
  const fs::path gtCsv = kData / "trajectories_gt_only_evo_testdata" / "V102_groundtruth.csv";
  if (!fs::is_regular_file(gtCsv)) GTEST_SKIP() << "shared data not found: " << gtCsv;
  const fs::path root = freshOut("euroc") / "V1_02_medium";
  const fs::path cam = root / "mav0" / "cam0";
  fs::create_directories(cam / "data");
  fs::create_directories(root / "mav0" / "state_groundtruth_estimate0");
  fs::copy_file(gtCsv, root / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  // cam0 of the Vicon-room sequences (sensor.yaml of V1_02_medium).
  std::ofstream(cam / "sensor.yaml") << "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n"
                                        "  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
                                        "         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
                                        "        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,\n"
                                        "         0.0, 0.0, 0.0, 1.0]\nrate_hz: 20\nresolution: [752, 480]\n"
                                        "camera_model: pinhole\nintrinsics: [458.654, 457.296, 367.215, 248.375]\n"
                                        "distortion_model: radial-tangential\n"
                                        "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n";
  // Pick GT lines 100, 5000, 16000 as camera stamps and keep their body poses for the check.
  std::ifstream in(gtCsv);
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  ASSERT_GT(lines.size(), 16000u);
  std::string csv = "#timestamp [ns],filename\n";
  std::vector<Eigen::Isometry3d> body;
  for (std::size_t k : {100u, 5000u, 16000u}) {
    std::stringstream ss(lines[k]);
    std::string field;
    std::vector<std::string> f;
    while (std::getline(ss, field, ',')) f.push_back(field);
    cv::imwrite((cam / "data" / (f[0] + ".png")).string(), cv::Mat(480, 752, CV_8UC1, cv::Scalar(static_cast<int>(k % 255))));
    csv += f[0] + "," + f[0] + ".png\n";
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(std::stod(f[1]), std::stod(f[2]), std::stod(f[3]));
    T.linear() = Eigen::Quaterniond(std::stod(f[4]), std::stod(f[5]), std::stod(f[6]), std::stod(f[7])).normalized().toRotationMatrix();
    body.push_back(T);
  }
  std::ofstream(cam / "data.csv") << csv;

  Dataset2RawlogOptions opt;
  opt.input = root;
  opt.outDir = root.parent_path() / "out";
  opt.progress = false;
  const auto summary = Dataset2RawlogApp(opt).run();
  EXPECT_EQ(summary.format, "euroc");
  EXPECT_EQ(summary.frames, 3u);
  ASSERT_EQ(summary.groundTruthPoses, 3u);
  EXPECT_EQ(summary.rawlogPath.filename(), "V1_02_medium.rawlog");
  Eigen::Matrix4d tbs;
  tbs << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975, 0.999557249008, 0.0149672133247,
      0.025715529948, -0.064676986768, -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949, 0, 0, 0, 1;
  const Eigen::Isometry3d T_BS(tbs);
  const Trajectory gt = readTumTrajectory(summary.groundTruthPath);
  const ReadBack r = readBack(summary.rawlogPath);
  ASSERT_EQ(gt.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(gt[i].timestamp, r.stamps[i]);
    const Eigen::Isometry3d expected = body[i] * T_BS;  // T_world_cam = T_world_body * T_BS
    EXPECT_LT((gt[i].position - expected.translation()).norm(), 1e-6) << i;
    EXPECT_LT(gt[i].orientation.angularDistance(Eigen::Quaterniond(expected.linear())), 1e-6) << i;
  }
  fs::remove_all(root.parent_path());
}
