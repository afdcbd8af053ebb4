// End-to-end tests of slam-run (SlamRunApp and the CLI) on a short synthetic room sequence rendered by the
// slam-synth library in the test: initialization, tracking, ATE against the known ground truth, bit-identical
// repeated runs, the threaded mode, a sequence that never initializes, and bad inputs.
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/serialization/CArchive.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/Metrics.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/system/SlamRunApp.h"
#include "pslam/system/SlamSystem.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";
constexpr int kFrames = 60;

// Per-process temporary folder, removed at exit (the guard owns its own copy of the path, so static
// destruction order does not matter).
struct TempRoot {
  fs::path path = fs::temp_directory_path() / ("pslam_slam_e2e_" + std::to_string(::getpid()));
  TempRoot() { fs::create_directories(path); }
  ~TempRoot() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
const fs::path& tempRoot() {
  static const TempRoot root;
  return root.path;
}

// Renders the first seconds of the room scenario once (translation first: parallax for initialization) at
// 640x480 (at 320x240 too few level-0 corners match for the two-view initialization).
const fs::path& roomRawlog() {
  static const fs::path rawlog = [] {
    synth::SynthOptions o;
    o.scenario = "room";
    o.frames = kFrames;
    o.seed = 3;
    o.noiseSigma = 1.0;
    o.outDir = tempRoot() / "synth";
    o.progress = false;
    return synth::SynthApp(o).run().rawlog;
  }();
  return rawlog;
}

system::SlamRunSummary runSlam(const fs::path& out, std::uint32_t seed = 1, bool threaded = false,
                               const fs::path& rawlog = roomRawlog(), const fs::path& config = kConfig) {
  system::SlamRunOptions o;
  o.config = config;
  o.rawlog = rawlog;
  o.outDir = out;
  o.seed = seed;
  o.threaded = threaded;
  o.progress = false;
  return system::SlamRunApp(o).run();
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Sim(3) ATE (RMSE) of an estimate against the ground truth; poses paired by equal timestamps.
double ateSim3(const Trajectory& gt, const Trajectory& est) {
  Trajectory g, e;
  for (const auto& p : est) {
    for (const auto& q : gt)
      if (std::abs(q.timestamp - p.timestamp) < 1e-4) {
        g.push_back(q);
        e.push_back(p);
        break;
      }
  }
  EXPECT_EQ(e.size(), est.size());
  const auto a = eval::alignTrajectories(g, e, eval::AlignmentMode::Sim3);
  return eval::computeAte(g, eval::applyAlignment(e, a)).stats.rmse;
}

template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SlamE2E, InitializesTracksAndStaysCloseToGroundTruth) {
  const fs::path out = tempRoot() / "run1";
  const auto s = runSlam(out);
  ASSERT_TRUE(s.initialized());
  EXPECT_LT(s.initializedAtFrame, 30);
  // Every frame after initialization is tracked (the reference frame and the initializing frame included).
  EXPECT_EQ(s.framesLost, 0u);
  EXPECT_GE(s.framesTracked, static_cast<std::size_t>(kFrames - s.initializedAtFrame));
  EXPECT_GE(s.keyFrames, 3u);
  for (const char* f : {"trajectory.txt", "keyframes.txt", "map.slammap", "report.json"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;

  const Trajectory est = readTumTrajectory(out / "trajectory.txt");
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  ASSERT_GE(est.size(), static_cast<std::size_t>(kFrames - 30));
  const double ate = ateSim3(gt, est);
  // The room is 6 x 5 m and the camera travels ~1-2 m here: 5 cm is loose for noise-free geometry.
  EXPECT_LT(ate, 0.05) << "ATE " << ate << " m";

  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_EQ(report["frames"].size(), static_cast<std::size_t>(kFrames));
  EXPECT_TRUE(report["timings"].contains("extraction"));
  EXPECT_TRUE(report["timings"].contains("local_ba"));
  EXPECT_TRUE(report["config"].get<std::string>().find("nFeatures") != std::string::npos);
  EXPECT_EQ(report["summary"]["frames_tracked"], s.framesTracked);
}

// Runs the room with the shipped config but ORB-SLAM's fusion distance band ([LocalMapping] fusionDistanceBand,
// shipped 0) and checks it tracks closely, culls consistently and reports the mapper.
void expectTracksWithFusionBand(const std::string& band) {
  std::string ini = readText(kConfig);
  const std::regex key(R"(\nfusionDistanceBand *= *[0-9.]+)");
  ASSERT_TRUE(std::regex_search(ini, key)) << "the shipped synthetic.ini sets fusionDistanceBand";
  ini = std::regex_replace(ini, key, "\nfusionDistanceBand = " + band);
  const std::string mapper = "band_" + band;
  const fs::path config = tempRoot() / ("synthetic_" + mapper + ".ini");
  std::ofstream(config) << ini;
  const fs::path out = tempRoot() / ("mapper_" + mapper);
  const auto s = runSlam(out, 1, false, roomRawlog(), config);
  ASSERT_TRUE(s.initialized());
  EXPECT_EQ(s.framesLost, 0u);
  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_EQ(report["local_mapper"], "mapping");
  EXPECT_NE(report["local_mapper_config"].get<std::string>().find("fusionDistanceBand"), std::string::npos);
  // Every mapped keyframe is either still in the map or was culled as redundant.
  int mapped = 0, culled = 0, generation = 0;
  for (const auto& m : report["mapping"]) generation = std::max(generation, m.at("generation").get<int>());
  for (const auto& m : report["mapping"]) {
    if (m.at("generation").get<int>() != generation) continue;  // keyframes of a map discarded by a reset
    ++mapped;
    culled += m.at("culled_keyframes").get<int>();
  }
  EXPECT_GT(mapped, 2);
  EXPECT_EQ(mapped - culled, report["summary"]["keyframes"].get<int>());
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  EXPECT_LT(ateSim3(gt, readTumTrajectory(out / "trajectory.txt")), 0.05);
}

TEST(SlamE2E, ShippedFusionBandTracks) { expectTracksWithFusionBand("0"); }

TEST(SlamE2E, OrbSlamFusionBandTracks) { expectTracksWithFusionBand("0.2"); }

TEST(SlamE2E, SameSeedGivesBitIdenticalTrajectories) {
  const fs::path a = tempRoot() / "det_a", b = tempRoot() / "det_b";
  runSlam(a, 5);
  runSlam(b, 5);
  const std::string ta = readText(a / "trajectory.txt");
  ASSERT_GE(readTumTrajectory(a / "trajectory.txt").size(), 20u);
  EXPECT_EQ(ta, readText(b / "trajectory.txt"));
  EXPECT_EQ(readText(a / "keyframes.txt"), readText(b / "keyframes.txt"));
}

TEST(SlamE2E, ThreadedModeTracks) {
  const fs::path out = tempRoot() / "threaded";
  const auto s = runSlam(out, 1, true);
  ASSERT_TRUE(s.initialized());
  EXPECT_GE(s.framesTracked, static_cast<std::size_t>(kFrames / 2));
  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_EQ(report["mode"], "threaded");
}

TEST(SlamE2E, RelocalizesAfterAnUntrackableFrame) {
  // Frames 0..44 of the room, then one blank frame (no corners: tracking is lost), then the sequence goes on:
  // relocalization against the keyframes must recover the pose.
  const system::SlamParams params = system::loadSlamParams(kConfig.string());
  datasets::RawlogReader reader(roomRawlog());
  std::unique_ptr<system::SlamSystem> slam;
  datasets::Frame f;
  bool lostSeen = false, relocalized = false;
  int framesAfterLoss = 0;
  while (reader.next(f)) {
    if (!slam) slam = std::make_unique<system::SlamSystem>(params, geometry::PinholeCamera::fromTCamera(f.camera), 1, false);
    if (f.index == 45) {
      datasets::Frame blank = f;
      blank.image = cv::Mat(f.image.size(), f.image.type(), cv::Scalar::all(128));
      const auto r = slam->processFrame(blank);
      ASSERT_GE(slam->map().numKeyFrames(), 6u) << "the map should be past the reset threshold";
      EXPECT_EQ(r.report.status, tracking::FrameStatus::Lost);
      lostSeen = true;
    }
    const auto r = slam->processFrame(f);
    if (lostSeen) {
      ++framesAfterLoss;
      if (r.report.status == tracking::FrameStatus::Relocalized) {
        relocalized = true;
        break;
      }
    }
  }
  EXPECT_TRUE(lostSeen);
  EXPECT_TRUE(relocalized);
  EXPECT_LE(framesAfterLoss, 3);
}

TEST(SlamE2E, SequenceWithoutStructureEndsWithEmptyTrajectoryAndWarning) {
  // Uniform grey frames: no keypoints, initialization can never succeed.
  const fs::path rawlog = tempRoot() / "blank" / "blank.rawlog";
  fs::create_directories(rawlog.parent_path());
  {
    datasets::RawlogWriter w(rawlog);
    for (int i = 0; i < 5; ++i) {
      datasets::Frame f;
      f.timestamp = 0.1 * i;
      f.image = cv::Mat(120, 160, CV_8UC1, cv::Scalar(128));
      f.camera.ncols = 160;
      f.camera.nrows = 120;
      f.camera.setIntrinsicParamsFromValues(150, 150, 79.5, 59.5);
      w.write(f);
    }
    w.commit();
  }
  const fs::path out = tempRoot() / "blank_out";
  const auto s = runSlam(out, 1, false, rawlog);
  EXPECT_FALSE(s.initialized());
  EXPECT_EQ(s.framesTracked, 0u);
  EXPECT_TRUE(readTumTrajectory(out / "trajectory.txt").empty());
  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_TRUE(report.contains("warning"));
  EXPECT_EQ(report["frames"].size(), 5u);
  EXPECT_EQ(report["frames"][0]["status"], "initializing");
}

TEST(SlamE2E, BadInputsAreNamed) {
  const fs::path out = tempRoot() / "bad";
  // Missing config / rawlog.
  EXPECT_NE(errorOf([&] { runSlam(out, 1, false, roomRawlog(), tempRoot() / "nope.ini"); }).find("nope.ini"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { runSlam(out, 1, false, tempRoot() / "nope.rawlog"); }).find("nope.rawlog"), std::string::npos);
  // Invalid config value: the message names the key.
  const fs::path badIni = tempRoot() / "bad.ini";
  std::ofstream(badIni) << "[Tracking]\nminLocalMapInliers = -3\n";
  EXPECT_NE(errorOf([&] { runSlam(out, 1, false, roomRawlog(), badIni); }).find("minLocalMapInliers"), std::string::npos);
  const fs::path badOrb = tempRoot() / "bad_orb.ini";
  std::ofstream(badOrb) << "[ORB]\nnFeatures = 0\n";
  EXPECT_NE(errorOf([&] { runSlam(out, 1, false, roomRawlog(), badOrb); }).find("nFeatures"), std::string::npos);

  // A rawlog whose observations are not labelled CAMERA.
  const fs::path noCam = tempRoot() / "nocam.rawlog";
  {
    mrpt::io::CFileGZOutputStream fo(noCam.string());
    auto arch = mrpt::serialization::archiveFrom(fo);
    auto obs = mrpt::obs::CObservationImage::Create();
    obs->sensorLabel = "LEFT";
    obs->image = mrpt::img::CImage(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), mrpt::img::DEEP_COPY);
    arch << *obs;
  }
  EXPECT_NE(errorOf([&] { runSlam(out, 1, false, noCam); }).find("CAMERA"), std::string::npos);

  // A CAMERA without intrinsics (fx = fy = 0).
  const fs::path noK = tempRoot() / "nointrinsics.rawlog";
  {
    mrpt::io::CFileGZOutputStream fo(noK.string());
    auto arch = mrpt::serialization::archiveFrom(fo);
    auto obs = mrpt::obs::CObservationImage::Create();
    obs->sensorLabel = datasets::kCameraLabel;
    obs->image = mrpt::img::CImage(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), mrpt::img::DEEP_COPY);
    obs->cameraParams.ncols = 10;
    obs->cameraParams.nrows = 10;
    obs->cameraParams.setIntrinsicParamsFromValues(0, 0, 5, 5);
    arch << *obs;
  }
  const std::string noKError = errorOf([&] { runSlam(out, 1, false, noK); });
  EXPECT_NE(noKError.find("nointrinsics.rawlog"), std::string::npos) << noKError;

  // Images that change size: frame 3's image file is replaced by a smaller one.
  const fs::path dir = tempRoot() / "resize";
  fs::create_directories(dir);
  fs::copy(roomRawlog(), dir / "room.rawlog");
  fs::copy(roomRawlog().parent_path() / "room_Images", dir / "room_Images", fs::copy_options::recursive);
  std::vector<fs::path> images;
  for (const auto& e : fs::directory_iterator(dir / "room_Images")) images.push_back(e.path());
  std::sort(images.begin(), images.end());
  ASSERT_GT(images.size(), 3u);
  cv::imwrite(images[3].string(), cv::Mat(100, 100, CV_8UC1, cv::Scalar(50)));
  const std::string resizeError = errorOf([&] { runSlam(out, 1, false, dir / "room.rawlog"); });
  EXPECT_NE(resizeError.find("size"), std::string::npos) << resizeError;
  // No output of a failed run is left half-written.
  EXPECT_FALSE(fs::exists(out / "trajectory.txt"));
}

TEST(SlamE2E, FrameRangeIsRespected) {
  system::SlamRunOptions o;
  o.config = kConfig;
  o.rawlog = roomRawlog();
  o.outDir = tempRoot() / "range";
  o.first = 10;
  o.last = 14;
  o.progress = false;
  const auto s = system::SlamRunApp(o).run();
  EXPECT_EQ(s.framesProcessed, 5u);
  const auto report = nlohmann::json::parse(readText(o.outDir / "report.json"));
  ASSERT_EQ(report["frames"].size(), 5u);
  EXPECT_EQ(report["frames"][0]["index"], 10);
  EXPECT_EQ(report["frames"][4]["index"], 14);
  o.first = 20;
  o.last = 5;
  EXPECT_THROW(system::SlamRunApp(o).run(), Error);
}

TEST(SlamE2E, CliPrintsOneErrorLineAndExitsNonZero) {
  const fs::path exe = fs::path(PRIORSLAM_BINARY_DIR) / "bin/slam-run";
  if (!fs::exists(exe)) GTEST_SKIP() << "slam-run binary not built in this configuration";
  const fs::path err = tempRoot() / "cli_err.txt";
  const std::string cmd = exe.string() + " --config " + kConfig.string() + " --rawlog " +
                          (tempRoot() / "missing.rawlog").string() + " --out " + (tempRoot() / "cli").string() +
                          " -q 2> " + err.string();
  const int rc = std::system(cmd.c_str());
  EXPECT_NE(rc, 0);
  const std::string text = readText(err);
  EXPECT_EQ(text.rfind("slam-run: error: ", 0), 0u) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1);
}
