// The normal-priors app class on a small rawlog of the synthetic room: NORMALS channel from depth, ground truth
// copied along, errors naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <unistd.h>

#include "RoomScene.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/priors/NormalPriorsApp.h"

using namespace pslam::priors;
using pslam::priors::test::renderRoom;
namespace fs = std::filesystem;

namespace {

const Eigen::Matrix3d kRoomRotation =
    (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX())).toRotationMatrix();
const Eigen::Vector3d kHalfSize(2.0, 1.3, 3.0);
const Eigen::Vector3d kCamInRoom(0.3, -0.2, -1.0);

}  // namespace

TEST(NormalPriorsApp, AddsNormalsChannelFromDepthAndCopiesGroundTruth) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_normal_priors_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  struct Cleanup {
    fs::path p;
    ~Cleanup() { fs::remove_all(p); }
  } cleanup{dir};
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom, 0.0, 1, 320, 240);
  {
    pslam::datasets::RawlogWriter w(dir / "room.rawlog");
    for (int i = 0; i < 2; ++i) {
      pslam::datasets::Frame f;
      f.timestamp = 10.0 + i;
      f.image = cv::Mat(240, 320, CV_8UC3, cv::Scalar(90, 120, 150));
      f.camera.ncols = 320;
      f.camera.nrows = 240;
      f.camera.fx(scene.K.fx);
      f.camera.fy(scene.K.fy);
      f.camera.cx(scene.K.cx);
      f.camera.cy(scene.K.cy);
      scene.depth.convertTo(f.depth, CV_16U, 5000.0);
      f.depthUnits = 1.0 / 5000.0;
      w.write(f);
    }
    w.commit();
  }
  { std::ofstream(dir / "room_groundtruth.txt") << "10 0 0 0 0 0 0 1\n11 0 0 0 0 0 0 1\n"; }
  NormalPriorsOptions o;
  o.input = dir / "room.rawlog";
  o.output = dir / "out" / "room_n.rawlog";
  o.progress = false;
  const NormalPriorsResult r = runNormalPriors(o);
  EXPECT_EQ(r.frames, 2u);
  EXPECT_GT(r.meanPlanarShare, 0.8);
  EXPECT_TRUE(fs::exists(dir / "out" / "room_n_groundtruth.txt"));
  pslam::datasets::RawlogReader reader(o.output);
  pslam::datasets::Frame f;
  std::size_t n = 0;
  while (reader.next(f)) {
    ASSERT_TRUE(f.hasNormals());
    ASSERT_TRUE(f.hasDepth());
    const cv::Mat dec = decodeNormalMap(f.normals);
    NormalErrorAccumulator acc;
    acc.addMaps(dec, scene.normals);
    EXPECT_GT(acc.summary().count, 0.8 * 320 * 240);
    EXPECT_LT(acc.summary().medianDeg, 0.5);  // 8-bit quantization only
    ++n;
  }
  EXPECT_EQ(n, 2u);
  // Bad input names the file.
  o.input = dir / "missing.rawlog";
  try {
    runNormalPriors(o);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find("missing.rawlog"), std::string::npos);
  }
  o.input = dir / "room.rawlog";
  o.source = "magic";
  EXPECT_THROW(runNormalPriors(o), pslam::Error);
  // Reliability (doc/reliability.md): room.copy has the stem of room.rawlog, so its images folder and its
  // ground truth would be the input's: refused before anything is read or written.
  o.source = "depth";
  o.output = dir / "room.copy";
  const auto imagesBefore = std::distance(fs::directory_iterator(dir / "room_Images"), fs::directory_iterator());
  try {
    runNormalPriors(o);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find("is the input"), std::string::npos) << err.what();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir / "room_Images"), fs::directory_iterator()), imagesBefore);
  EXPECT_FALSE(fs::exists(dir / "room.copy"));
}

// --config is read strictly, including the [ManhattanTracker] section of the shared config/manhattan/*.ini.
TEST(NormalPriorsConfig, ReadStrictlyWithTheTrackerSection) {
  for (const auto& e : fs::directory_iterator(fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan"))
    if (e.path().extension() == ".ini") {  // models/ holds the shipped networks
      EXPECT_NO_THROW(NormalPriorsConfig::loadFromFile(e.path())) << e.path();
    }
  const fs::path path = fs::temp_directory_path() / ("pslam_normal_priors_cfg_" + std::to_string(::getpid()) + ".ini");
  const auto errorFor = [&](const std::string& text) {
    std::ofstream(path) << text;
    try {
      NormalPriorsConfig::loadFromFile(path);
    } catch (const pslam::Error& e) {
      const std::string what = e.what();
      return what.rfind(path.string(), 0) == 0 ? "F" + what.substr(path.string().size()) : what;
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("[ManhattanTracker]\nkernelWidth = abc\n"), "F: [ManhattanTracker] kernelWidth = abc: not a number");
  EXPECT_EQ(errorFor("[NormalsFromDepth]\ncellSize = 10 px\n"), "F: [NormalsFromDepth] cellSize = 10 px: not an integer");
  EXPECT_EQ(errorFor("[NormalsFromDepth]\ncellSize = 2000000000\n"),
            "F: [NormalsFromDepth] cellSize = 2000000000: must be in [3, 100]");
  EXPECT_EQ(errorFor("[Normals]\nminDepth = 1\n"), "F: [Normals]: unknown section (did you mean NormalsFromDepth?)");
  fs::remove(path);
}

// Reliability (doc/reliability.md): an empty rawlog became a 0-frame output with exit code 0 (the other tools refuse
// it). Refused naming the file; nothing written.
TEST(NormalPriorsApp, EmptyRawlogIsRefused) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_normal_priors_empty_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  struct Cleanup {
    fs::path p;
    ~Cleanup() { fs::remove_all(p); }
  } cleanup{dir};
  {
    pslam::datasets::RawlogWriter w(dir / "empty.rawlog");
    w.commit();
  }
  NormalPriorsOptions o;
  o.input = dir / "empty.rawlog";
  o.output = dir / "out" / "empty_n.rawlog";
  o.progress = false;
  try {
    runNormalPriors(o);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find((dir / "empty.rawlog").string() + ": rawlog has no CAMERA frame"),
              std::string::npos)
        << err.what();
  }
  EXPECT_FALSE(fs::exists(o.output));
  // A rawlog without DEPTH for normals from depth: the file and the frame (the frame alone was named).
  {
    pslam::datasets::RawlogWriter w(dir / "nodepth.rawlog");
    pslam::datasets::Frame f;
    f.timestamp = 1.0;
    f.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(90));
    f.camera.ncols = 64;
    f.camera.nrows = 48;
    f.camera.fx(50.0);
    f.camera.fy(50.0);
    f.camera.cx(32.0);
    f.camera.cy(24.0);
    w.write(f);
    w.commit();
  }
  o.input = dir / "nodepth.rawlog";
  try {
    runNormalPriors(o);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_EQ(std::string(err.what()).rfind((dir / "nodepth.rawlog").string() + ": frame 0: has no DEPTH channel", 0), 0u)
        << err.what();
  }
}
