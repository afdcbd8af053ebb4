// manhattan-eval on a synthetic rawlog: a camera turning inside a box room (exact Manhattan structure), depth
// rendered analytically, ground truth known. Normals from depth; the tracker must follow the rotation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>

#include <Eigen/Geometry>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/manhattan/ManhattanEvalApp.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

/// Depth (u16, 1/5000 m) seen from a camera at `t_room_cam` with orientation R_room_cam inside a box room.
cv::Mat renderRoomDepth(const Eigen::Matrix3d& R_room_cam, const Eigen::Vector3d& t_room_cam,
                        const Eigen::Vector3d& halfSize, double f, int cols, int rows) {
  cv::Mat depth(rows, cols, CV_16UC1);
  for (int v = 0; v < rows; ++v)
    for (int u = 0; u < cols; ++u) {
      const Eigen::Vector3d ray((u - (cols - 1) / 2.0) / f, (v - (rows - 1) / 2.0) / f, 1.0);
      const Eigen::Vector3d r = R_room_cam * ray;
      double best = 1e18;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(r(a)) < 1e-12) continue;
        const double t = ((r(a) > 0 ? halfSize(a) : -halfSize(a)) - t_room_cam(a)) / r(a);
        if (t > 0) best = std::min(best, t);
      }
      depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(best * 5000.0));
    }
  return depth;
}

struct TempDir {
  fs::path path;
  TempDir() : path(fs::temp_directory_path() / ("pslam_manhattan_eval_" + std::to_string(::getpid()))) {
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

}  // namespace

TEST(ManhattanEvalApp, FollowsACameraTurningInsideABoxRoom) {
  TempDir dir;
  const int cols = 320, rows = 240;
  const double f = 260.0;
  const Eigen::Vector3d halfSize(2.5, 1.2, 3.0);
  // The room is the world frame; the camera looks along +z, yaws 12 deg per frame and pitches slightly.
  Trajectory gt;
  {
    datasets::RawlogWriter writer(dir.path / "room.rawlog");
    for (int i = 0; i < 8; ++i) {
      const Eigen::Matrix3d R_w_c = (Eigen::AngleAxisd(0.21 * i, Eigen::Vector3d::UnitY()) *
                                     Eigen::AngleAxisd(0.25 + 0.02 * i, Eigen::Vector3d::UnitX()))
                                        .toRotationMatrix();
      const Eigen::Vector3d t_w_c(0.2 * std::sin(0.5 * i), 0.1, -0.5 + 0.05 * i);
      datasets::Frame fr;
      fr.timestamp = 100.0 + 0.1 * i;
      fr.image = cv::Mat(rows, cols, CV_8UC1, cv::Scalar(128));
      fr.camera.ncols = cols;
      fr.camera.nrows = rows;
      fr.camera.fx(f);
      fr.camera.fy(f);
      fr.camera.cx((cols - 1) / 2.0);
      fr.camera.cy((rows - 1) / 2.0);
      fr.depth = renderRoomDepth(R_w_c, t_w_c, halfSize, f, cols, rows);
      fr.depthUnits = 1.0 / 5000.0;
      writer.write(fr);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = R_w_c;
      T.translation() = t_w_c;
      gt.emplace_back(fr.timestamp, T);
    }
    writer.commit();
  }
  writeTumTrajectory(dir.path / "room_groundtruth.txt", gt);

  manhattan::ManhattanEvalOptions o;
  o.rawlog = dir.path / "room.rawlog";
  o.normals = "depth";
  o.outputJson = dir.path / "out" / "report.json";
  o.outputText = dir.path / "out" / "report.txt";
  o.outputPlot = dir.path / "out" / "errors.png";
  o.progress = false;
  const auto r = manhattan::runManhattanEval(o);
  const auto& s = r.report["summary"];
  EXPECT_EQ(s["frames"].get<int>(), 8);
  EXPECT_DOUBLE_EQ(s["success_share"].get<double>(), 1.0);
  EXPECT_EQ(s["evaluated_frames"].get<int>(), 8);
  EXPECT_LT(s["rotation_error_max_deg"].get<double>(), 0.5);  // exact planes; u16 depth quantization only
  // The last frame is ~85 deg from the first: the errors are not small because nothing moved.
  EXPECT_GT(r.report["frames"].back()["gt_rotation_from_reference_deg"].get<double>(), 80.0);
  EXPECT_LT(s["step_error_max_deg"].get<double>(), 0.5);
  EXPECT_EQ(s["reference_frame"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(o.outputJson));
  EXPECT_TRUE(fs::exists(o.outputText));
  EXPECT_TRUE(fs::exists(o.outputPlot));
  EXPECT_TRUE(s.contains("timings_ms"));

  // Another reference frame: the errors stay small (nothing depends on frame 0 being special).
  o.referenceFrame = 3;
  const auto r3 = manhattan::runManhattanEval(o);
  EXPECT_EQ(r3.report["summary"]["reference_frame"].get<int>(), 3);
  EXPECT_LT(r3.report["summary"]["rotation_error_max_deg"].get<double>(), 0.5);
  EXPECT_NEAR(r3.report["frames"][3]["rotation_error_deg"].get<double>(), 0.0, 1e-4);  // acos resolution

  // Normal accuracy between two sources: rawlog has no NORMALS here, which must be reported by file and frame
  // (reliability: the fuzzed tools said "frame 7: has no NORMALS channel" without the file).
  o.referenceNormals = "rawlog";
  try {
    manhattan::runManhattanEval(o);
    FAIL() << "expected pslam::Error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(o.rawlog.string() + ": frame 0: has no NORMALS channel", 0), 0u) << e.what();
  }
  // Normal accuracy over every pixel with a normal, or over the reference's planes only (a subset).
  o.referenceNormals = "depth";
  o.outputJson = o.outputText = o.outputPlot = fs::path();
  const auto all = manhattan::runManhattanEval(o).report["summary"]["normal_accuracy"];
  o.accuracyPixels = "reference-planar";
  const auto planar = manhattan::runManhattanEval(o).report["summary"]["normal_accuracy"];
  EXPECT_GT(planar["count"].get<std::size_t>(), 0u);
  EXPECT_LE(planar["count"].get<std::size_t>(), all["count"].get<std::size_t>());
  EXPECT_LT(planar["median_deg"].get<double>(), 0.01);  // the same source on both sides
  o.accuracyPixels = "planes";
  try {
    manhattan::runManhattanEval(o);
    FAIL() << "expected pslam::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--accuracy-pixels"), std::string::npos) << e.what();
  }
  o.accuracyPixels = "all";
  // Missing ground truth is named.
  o.referenceNormals.clear();
  o.groundTruth = dir.path / "nope.txt";
  try {
    manhattan::runManhattanEval(o);
    FAIL() << "expected pslam::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nope.txt"), std::string::npos);
  }
  o.groundTruth.clear();
  o.rawlog = dir.path / "missing.rawlog";
  EXPECT_THROW(manhattan::runManhattanEval(o), Error);
}

// Reliability (doc/reliability.md): --json / --text / --plot never replace a folder nor an input, and a run that
// cannot write one of its outputs writes none.
TEST(ManhattanEvalApp, OutputsNeverDestroyAFolderOrAnInput) {
  TempDir dir;
  const int cols = 160, rows = 120;
  const double f = 130.0;
  Trajectory gt;
  {
    datasets::RawlogWriter writer(dir.path / "room.rawlog");
    for (int i = 0; i < 2; ++i) {
      const Eigen::Matrix3d R_w_c = Eigen::AngleAxisd(0.1 * i + 0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
      const Eigen::Vector3d t_w_c(0.0, 0.1, -0.5);
      datasets::Frame fr;
      fr.timestamp = 100.0 + 0.1 * i;
      fr.image = cv::Mat(rows, cols, CV_8UC1, cv::Scalar(128));
      fr.camera.ncols = cols;
      fr.camera.nrows = rows;
      fr.camera.fx(f);
      fr.camera.fy(f);
      fr.camera.cx((cols - 1) / 2.0);
      fr.camera.cy((rows - 1) / 2.0);
      fr.depth = renderRoomDepth(R_w_c, t_w_c, Eigen::Vector3d(2.5, 1.2, 3.0), f, cols, rows);
      fr.depthUnits = 1.0 / 5000.0;
      writer.write(fr);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = R_w_c;
      T.translation() = t_w_c;
      gt.emplace_back(fr.timestamp, T);
    }
    writer.commit();
  }
  writeTumTrajectory(dir.path / "room_groundtruth.txt", gt);
  auto readAll = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string rawlog = readAll(dir.path / "room.rawlog"), truth = readAll(dir.path / "room_groundtruth.txt");
  auto errorOf = [](const manhattan::ManhattanEvalOptions& o) {
    try {
      manhattan::runManhattanEval(o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  manhattan::ManhattanEvalOptions base;
  base.rawlog = dir.path / "room.rawlog";
  base.normals = "depth";
  base.progress = false;

  fs::create_directories(dir.path / "X");
  std::ofstream(dir.path / "X" / "keep.txt") << "keep";
  auto o = base;
  o.outputJson = dir.path / "X";
  EXPECT_NE(errorOf(o).find("X: is a folder; refusing to replace it with a file"), std::string::npos) << errorOf(o);
  EXPECT_TRUE(fs::exists(dir.path / "X" / "keep.txt"));

  o = base;
  o.outputJson = dir.path / "room.rawlog";
  EXPECT_NE(errorOf(o).find("is the input"), std::string::npos) << errorOf(o);
  o = base;
  o.outputText = dir.path / "room_groundtruth.txt";
  EXPECT_NE(errorOf(o).find("is the input"), std::string::npos) << errorOf(o);
  EXPECT_EQ(readAll(dir.path / "room.rawlog"), rawlog);
  EXPECT_EQ(readAll(dir.path / "room_groundtruth.txt"), truth);

  // The plot cannot be written: neither is the JSON.
  o = base;
  o.outputJson = dir.path / "r.json";
  o.outputPlot = dir.path / "X";
  EXPECT_NE(errorOf(o).find("X: is a folder"), std::string::npos) << errorOf(o);
  EXPECT_FALSE(fs::exists(dir.path / "r.json"));
}
