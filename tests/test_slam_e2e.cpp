// End-to-end tests of slam-run (SlamRunApp and the CLI) on a short synthetic room sequence rendered by the
// slam-synth library in the test: initialization, tracking, ATE against the known ground truth, bit-identical
// repeated runs, the threaded mode, a sequence that never initializes, and bad inputs.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <functional>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/serialization/CArchive.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/DepthRatio.h"
#include "pslam/eval/Metrics.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/apps/SlamRunApp.h"
#include "pslam/system/RunReport.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/PoseSolver.h"
#include "pslam_test/RoomClip.h"
#include "pslam_test/SameStampPairs.h"
#include "pslam_test/Sim3Ate.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";
constexpr int kFrames = 60;

using test_support::errorOf;

// Per-process temporary folder, removed at exit (the guard owns its own copy of the path, so static
// destruction order does not matter).
const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_slam_e2e");
  return root.path;
}

// The room clip, rendered once.
const fs::path& roomRawlog() {
  static const fs::path rawlog = test_support::renderRoomClip(tempRoot() / "synth", kFrames);
  return rawlog;
}

apps::SlamRunSummary runSlam(const fs::path& out, std::uint32_t seed = 1, bool threaded = false,
                             const fs::path& rawlog = roomRawlog(), const fs::path& config = kConfig,
                             const std::vector<std::string>& overrides = {}) {
  return test_support::runSlamRun(out, rawlog, seed, threaded, config, overrides);
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Sim(3) ATE (RMSE) of an estimate against the ground truth; every estimated pose must have a ground-truth stamp.
double ateSim3(const Trajectory& gt, const Trajectory& est) {
  EXPECT_EQ(test_support::sameStampPairs(gt, est).second.size(), est.size());
  return test_support::ateSim3(gt, est);
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
  // every step of local mapping per keyframe
  for (const char* stage : {"mapping_insert", "culling_points", "triangulation", "fusion", "culling_keyframes",
                            "mapping_total"})
    EXPECT_TRUE(report["timings"].contains(stage)) << stage;
  EXPECT_TRUE(report["config"].get<std::string>().find("nFeatures") != std::string::npos);
  EXPECT_EQ(report["summary"]["frames_tracked"], s.framesTracked);
  // The run's time split: the frames (tracking and mapping) and the outputs after them, inside the run's wall time.
  const auto& summary = report["summary"];
  EXPECT_GT(summary["frames_wall_seconds"].get<double>(), 0.0);
  EXPECT_GT(summary["frames_cpu_seconds"].get<double>(), 0.0);
  EXPECT_GT(summary["outputs_wall_seconds"].get<double>(), 0.0);
  EXPECT_LE(summary["frames_wall_seconds"].get<double>() + summary["outputs_wall_seconds"].get<double>(),
            summary["wall_seconds"].get<double>());
  EXPECT_LE(summary["frames_cpu_seconds"].get<double>(), summary["cpu_seconds"].get<double>());
}

// Runs the room with the shipped config but ORB-SLAM's fusion distance band ([LocalMapping] fusionDistanceBand,
// shipped 0) and checks it tracks closely, culls consistently and reports the mapper.
void expectTracksWithFusionBand(const std::string& band) {
  std::string ini = readText(kConfig);
  const std::regex key(R"(\nfusionDistanceBand *= *[0-9.]+)");
  ASSERT_TRUE(std::regex_search(ini, key)) << "the shipped synthetic.ini sets fusionDistanceBand";
  ini = std::regex_replace(ini, key, "\nfusionDistanceBand = " + band);
  // The copy lives elsewhere: its vocabulary path (relative to the config's folder) becomes absolute.
  ini = std::regex_replace(ini, std::regex(R"(\nvocabulary *= *\.\./)"),
                           "\nvocabulary = " + (kConfig.parent_path() / "..").lexically_normal().string() + "/");
  const std::string mapper = "band_" + band;
  const fs::path config = tempRoot() / ("synthetic_" + mapper + ".ini");
  std::ofstream(config) << ini;
  const fs::path out = tempRoot() / ("mapper_" + mapper);
  const auto s = runSlam(out, 1, false, roomRawlog(), config);
  ASSERT_TRUE(s.initialized());
  EXPECT_EQ(s.framesLost, 0u);
  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_EQ(report["point_policy"], "heuristic");
  EXPECT_NE(report["config"].get<std::string>().find("fusionDistanceBand"), std::string::npos);
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

// §3.4.2 end to end: the probabilistic model without semantics tracks the room, every tracked frame feeds the
// points' models, the run repeats bit for bit, and the map-point depths of depths.txt are mostly right (DR).
TEST(SlamE2E, ProbabilisticModelLearnsFromEveryTrackedFrameDeterministically) {
  const std::vector<std::string> sets{"PointModel.model=probabilistic", "PointModel.semantic=false"};
  const fs::path a = tempRoot() / "prob_a", b = tempRoot() / "prob_b";
  const auto s = runSlam(a, 5, false, roomRawlog(), kConfig, sets);
  runSlam(b, 5, false, roomRawlog(), kConfig, sets);
  ASSERT_TRUE(s.initialized());
  EXPECT_GE(s.framesTracked, static_cast<std::size_t>(kFrames / 2));
  EXPECT_EQ(readText(a / "trajectory.txt"), readText(b / "trajectory.txt"));
  EXPECT_EQ(readText(a / "depths.txt"), readText(b / "depths.txt"));
  const auto report = nlohmann::json::parse(readText(a / "report.json"));
  EXPECT_EQ(report["point_policy"], "probabilistic");
  int tracked = 0, learned = 0, active = 0;
  for (const auto& f : report["frames"]) {
    if (f["status"] != "tracking" || f["method"] == "initializer") continue;
    ++tracked;
    learned += f["model_updates"].get<int>() > 0 ? 1 : 0;
    active += f["active_matches"].get<int>();
  }
  ASSERT_GT(tracked, 10);
  EXPECT_EQ(learned, tracked) << "a tracked frame did not update any point model";
  EXPECT_GT(active, 30 * tracked);
  // DR (eq. 2.104) of the run's depths against the DEPTH channel, scaled by the Sim(3) alignment.
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  const Trajectory est = readTumTrajectory(a / "trajectory.txt");
  const auto [g, e] = test_support::sameStampPairs(gt, est);
  eval::DepthRatioOptions dro;
  dro.scale = eval::alignTrajectories(g, e, eval::AlignmentMode::Sim3).scale;
  const auto dr = eval::computeDepthRatio(eval::readDepthSamples(a / "depths.txt"), roomRawlog(), dro);
  EXPECT_GT(dr.evaluated, 500u);
  EXPECT_GT(dr.ratio, 0.8) << "map-point depths of a static room should be within 10 % of the truth";
}

TEST(SlamE2E, DirectFeaturesJoinTrackingAndRepeatBitForBit) {
  // §3.4: direct points made on keyframes join every frame's pose optimization and local BA; the run stays
  // deterministic and tracks the static room as well as the keypoints alone.
  const std::vector<std::string> sets{"PointModel.model=probabilistic", "PointModel.semantic=false",
                                      "DirectFeatures.enabled=true"};
  const fs::path a = tempRoot() / "direct_a", b = tempRoot() / "direct_b", orb = tempRoot() / "direct_orb";
  const auto s = runSlam(a, 5, false, roomRawlog(), kConfig, sets);
  runSlam(b, 5, false, roomRawlog(), kConfig, sets);
  runSlam(orb, 5, false, roomRawlog(), kConfig, {"PointModel.model=probabilistic", "PointModel.semantic=false"});
  ASSERT_TRUE(s.initialized());
  EXPECT_GE(s.framesTracked, static_cast<std::size_t>(kFrames / 2));
  EXPECT_EQ(readText(a / "trajectory.txt"), readText(b / "trajectory.txt"));
  EXPECT_EQ(readText(a / "map.slammap"), readText(b / "map.slammap"));
  EXPECT_NE(readText(a / "trajectory.txt"), readText(orb / "trajectory.txt")) << "direct points changed nothing";
  const auto report = nlohmann::json::parse(readText(a / "report.json"));
  int tracked = 0, withDirect = 0;
  long factors = 0, inliers = 0;
  for (const auto& f : report["frames"]) {
    if (f["status"] != "tracking" || f["method"] == "initializer") continue;
    ++tracked;
    withDirect += f["direct_factors"].get<double>() > 0 ? 1 : 0;
    factors += f["direct_factors"].get<long>();
    inliers += f["direct_inliers"].get<long>();
  }
  ASSERT_GT(tracked, 10);
  EXPECT_GE(withDirect, tracked * 9 / 10) << "direct points should join nearly every frame's pose";
  EXPECT_GT(inliers, factors * 8 / 10);
  long created = 0;
  for (const auto& m : report["mapping"]) created += m["direct_created"].get<long>();
  EXPECT_GT(created, 500);
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  const double ateDirect = ateSim3(gt, readTumTrajectory(a / "trajectory.txt"));
  const double ateOrb = ateSim3(gt, readTumTrajectory(orb / "trajectory.txt"));
  EXPECT_LT(ateDirect, 0.05);
  EXPECT_LT(ateDirect, 2.0 * ateOrb + 0.005) << "direct points made the static room much worse";
}

// Both ways tracking waits for the mapping thread ([System] threadedTracking), frames as fast as tracking takes
// them: local mapping runs concurrently (its triangulation search and local BA outside the map lock), every frame
// after initialization is tracked, and the trajectory stays as close to the ground truth as the sequential run's
// bound. Not bit-deterministic, so the bounds are those of the sequential test, not its numbers. Also the test
// the ThreadSanitizer job runs (scripts/run-sanitizers.sh --thread).
TEST(SlamE2E, ThreadedModeTracksWithEitherWaitPolicy) {
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  for (const char* policy : {"live", "afterNewPoints"}) {
    SCOPED_TRACE(policy);
    const fs::path out = tempRoot() / (std::string("threaded_") + policy);
    const auto s = runSlam(out, 1, true, roomRawlog(), kConfig, {std::string("System.threadedTracking=") + policy});
    ASSERT_TRUE(s.initialized());
    EXPECT_LT(s.initializedAtFrame, 30);
    EXPECT_EQ(s.framesLost, 0u);
    EXPECT_EQ(s.resets, 0u);
    EXPECT_GE(s.keyFrames, 3u);
    const Trajectory est = readTumTrajectory(out / "trajectory.txt");
    ASSERT_GE(est.size(), static_cast<std::size_t>(kFrames - 30));
    EXPECT_LT(ateSim3(gt, est), 0.05);
    const auto report = nlohmann::json::parse(readText(out / "report.json"));
    EXPECT_EQ(report["mode"], "threaded");
    EXPECT_TRUE(report["timings"].contains("local_ba"));
    EXPECT_TRUE(report["timings"].contains("triangulation"));
  }
}

// [System] weakKeyFrameInliers: in the live policy a keyframe made at fewer local-map inliers holds tracking until
// its new points are in the map. With the threshold above any count, every keyframe (the two of the initialization
// included) waits once, and the run tracks as the live one does; at 0 none waits.
TEST(SlamE2E, ThreadedLiveKeyFramesAtFewInliersWaitForTheirPoints) {
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  const fs::path out = tempRoot() / "threaded_weak_keyframes";
  // Taken after the next frame's extraction (the default) or at the end of the keyframe's own frame: once per
  // keyframe either way, the last one's by finish().
  for (const char* after : {"true", "false"}) {
    SCOPED_TRACE(std::string("waitAfterNextExtraction=") + after);
    const std::vector<std::string> sets{"System.weakKeyFrameInliers=1000000",
                                        std::string("System.waitAfterNextExtraction=") + after};
    const auto s = runSlam(out, 1, true, roomRawlog(), kConfig, sets);
    ASSERT_TRUE(s.initialized());
    EXPECT_EQ(s.framesLost, 0u);
    EXPECT_LT(ateSim3(gt, readTumTrajectory(out / "trajectory.txt")), 0.05);
    const auto report = nlohmann::json::parse(readText(out / "report.json"));
    std::size_t keyFrameFrames = 0;
    for (const auto& f : report["frames"]) keyFrameFrames += f["keyframe"].get<bool>();
    ASSERT_TRUE(report["timings"].contains("wait_for_weak_keyframe"));
    EXPECT_EQ(report["timings"]["wait_for_weak_keyframe"]["count"].get<std::size_t>(), keyFrameFrames);
    // Every frame is weak at that threshold, so every frame needs a keyframe (KeyFrameDecisionInput::weakInliers):
    // made when mapping is idle, else tracking waits until it is (urgent) and the next frame makes it. No two
    // tracked frames in a row without a keyframe.
    std::size_t withoutKeyFrame = 0, longestRun = 0;
    for (const auto& f : report["frames"]) {
      if (f["status"] != "tracking") continue;
      withoutKeyFrame = f["keyframe"].get<bool>() ? 0 : withoutKeyFrame + 1;
      longestRun = std::max(longestRun, withoutKeyFrame);
    }
    EXPECT_LE(longestRun, 1u);
  }
  const fs::path plain = tempRoot() / "threaded_plain_keyframes";
  runSlam(plain, 1, true, roomRawlog(), kConfig, {"System.weakKeyFrameInliers=0"});
  EXPECT_FALSE(nlohmann::json::parse(readText(plain / "report.json"))["timings"].contains("wait_for_weak_keyframe"));
}

// --realtime hands frames over at their timestamps (here 2 s of a 30 fps clip): the run lasts at least the clip's
// duration and is otherwise a normal run.
TEST(SlamE2E, RealtimePacingTakesTheClipsDuration) {
  const fs::path out = tempRoot() / "realtime";
  apps::SlamRunOptions o;
  o.config = kConfig;
  o.rawlog = roomRawlog();
  o.outDir = out;
  o.seed = 1;
  o.threaded = true;
  o.realtime = true;
  o.progress = false;
  const auto s = apps::SlamRunApp(o).run();
  ASSERT_TRUE(s.initialized());
  const Trajectory gt = readTumTrajectory(roomRawlog().parent_path() / "room_groundtruth.txt");
  const double duration = gt.back().timestamp - gt.front().timestamp;
  EXPECT_GE(s.wallSeconds, duration);
  EXPECT_LE(s.framesLate, s.framesProcessed);
  const auto report = nlohmann::json::parse(readText(out / "report.json"));
  EXPECT_TRUE(report["summary"].contains("frames_late"));
  EXPECT_TRUE(report["summary"].contains("max_lateness_seconds"));
}

namespace {
/// The first `n` frames of the room clip with new stamps, written to `rawlog`.
void restamp(const fs::path& rawlog, std::size_t n, const std::function<double(std::size_t, double)>& stamp) {
  datasets::RawlogReader in(roomRawlog());
  datasets::RawlogWriter out(rawlog);
  datasets::Frame f;
  for (std::size_t i = 0; i < n && in.next(f); ++i) {
    f.timestamp = stamp(i, f.timestamp);
    out.write(f);
  }
  out.commit();
}
}  // namespace

// Reliability (doc/reliability.md): --realtime on stamps that jump 1e6 s ahead waited it out (11.6 days) without a
// word. The wait is bounded (--realtime-max-wait) and the cut named in a warning; the frames after it keep their
// pace. Run through the executable under `timeout`, so that a hang fails the test instead of stalling it.
TEST(SlamE2E, RealtimeNeverWaitsLongerThanItsBound) {
  const fs::path exe = fs::path(PRIORSLAM_BINARY_DIR) / "bin/slam-run";
  if (!fs::exists(exe)) GTEST_SKIP() << "slam-run binary not built in this configuration";
  const fs::path rawlog = tempRoot() / "jump" / "jump.rawlog";
  restamp(rawlog, 20, [](std::size_t i, double t) { return i >= 10 ? t + 1e6 : t; });
  const fs::path err = tempRoot() / "jump_err.txt";
  const std::string cmd = "timeout 120 " + exe.string() + " --config " + kConfig.string() + " --rawlog " +
                          rawlog.string() + " --out " + (tempRoot() / "jump_out").string() +
                          " --realtime --realtime-max-wait 0.5 -q 2> " + err.string() + " > /dev/null";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 0) << readText(err);
  const std::string text = readText(err);
  EXPECT_NE(text.find("slam-run: warning: " + rawlog.string() +
                      ": frame 10: its stamp is 1000000.0"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("--realtime waited 0.500 s (--realtime-max-wait)"), std::string::npos) << text;
  const auto report = nlohmann::json::parse(readText(tempRoot() / "jump_out" / "report.json"));
  EXPECT_EQ(report["summary"]["realtime_waits_cut"].get<int>(), 1);
}

// Reliability: a frame stamped before the one before it (frame 15 stamped as frame 5) was read in the rawlog's order
// and the trajectory sorted by stamp, scoring the run wrong. It is an error naming the frame; --sort-stamps reads the
// frames in stamp order with a warning.
TEST(SlamE2E, StampsGoingBackAreAnErrorUnlessSorted) {
  const fs::path rawlog = tempRoot() / "back" / "back.rawlog";
  double stamp5 = 0;
  restamp(rawlog, 20, [&](std::size_t i, double t) {
    if (i == 5) stamp5 = t;
    return i == 15 ? stamp5 + 0.001 : t;
  });
  apps::SlamRunOptions o;
  o.config = kConfig;
  o.rawlog = rawlog;
  o.outDir = tempRoot() / "back_out";
  o.progress = false;
  const std::string error = errorOf([&] { apps::SlamRunApp(o).run(); });
  EXPECT_NE(error.find(rawlog.string() + ": frame 15: timestamp "), std::string::npos) << error;
  EXPECT_NE(error.find("is before the previous frame's"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(o.outDir / "trajectory.txt"));
  o.sortStamps = true;
  const auto s = apps::SlamRunApp(o).run();
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("1 frame(s) stamped before the frame before them"), std::string::npos) << s.warnings[0];
  EXPECT_EQ(s.framesProcessed, 20u);
}

TEST(SlamE2E, RelocalizesAfterAnUntrackableFrame) {
  // Frames 0..44 of the room, then one blank frame (no corners: tracking is lost), then the sequence goes on:
  // relocalization against the keyframes must recover the pose.
  system::SystemOptions options;
  options.seed = 1;
  system::System slam(system::loadSlamParams(kConfig.string()), options);
  datasets::RawlogReader reader(roomRawlog());
  datasets::Frame f;
  bool lostSeen = false, relocalized = false;
  int framesAfterLoss = 0;
  while (reader.next(f)) {
    if (f.index == 45) {
      datasets::Frame blank = f;
      blank.image = cv::Mat(f.image.size(), f.image.type(), cv::Scalar::all(128));
      const auto r = slam.track(blank);
      ASSERT_GE(slam.mapSnapshot().numKeyFrames(), 6u) << "the map should be past the reset threshold";
      EXPECT_EQ(r.state, system::TrackingState::Lost);
      EXPECT_FALSE(r.pose.has_value());
      lostSeen = true;
    }
    const auto r = slam.track(f);
    if (lostSeen) {
      ++framesAfterLoss;
      if (r.state == system::TrackingState::Relocalized) {
        relocalized = true;
        break;
      }
    }
  }
  EXPECT_TRUE(lostSeen);
  EXPECT_TRUE(relocalized);
  EXPECT_LE(framesAfterLoss, 3);
}

// Threaded mode through map resets: a blank frame soon after each initialization (the map still has at most
// resetKeyFrames keyframes) loses tracking and resets the map while the mapping thread may be mapping one of its
// keyframes, possibly outside the map lock. Keyframes of the old map must never reach the new one: the run goes
// on, re-initializes, and ends with a consistent map and a trajectory of the last map only.
TEST(SlamE2E, ThreadedModeSurvivesMapResetsWhileMapping) {
  for (const char* policy : {"live", "afterNewPoints"}) {
    SCOPED_TRACE(policy);
    system::SlamParams params = system::loadSlamParams(kConfig.string());
    params.system.threadedTracking = policy;
    system::SystemOptions options;
    options.seed = 1;
    options.threaded = true;
    system::System slam(params, options);
    datasets::RawlogReader reader(roomRawlog());
    std::size_t resets = 0, sinceInit = 0;
    for (datasets::Frame f; reader.next(f);) {
      if (slam.initialized() && ++sinceInit == 3) {  // 3 frames after each initialization
        datasets::Frame blank = f;
        blank.image = cv::Mat(f.image.size(), f.image.type(), cv::Scalar::all(128));
        if (slam.track(blank).mapWasReset) ++resets;
        sinceInit = 0;
      }
      if (slam.track(f).mapWasReset) ++resets;
    }
    slam.finish();
    EXPECT_GE(resets, 2u);
    const nlohmann::json summary = system::toJson(slam.summary());
    EXPECT_EQ(summary["resets"].get<std::size_t>(), resets);
    const map::Map m = slam.mapSnapshot();
    EXPECT_NO_THROW(m.checkInvariants("after the threaded run"));
    for (const auto& p : system::toTrajectory(slam.trajectory())) EXPECT_TRUE(p.position.allFinite());
  }
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

// Reliability (doc/reliability.md): an output folder whose map.slammap is a folder keeps it, and the run writes
// none of its outputs; an output that is an input is refused.
TEST(SlamE2E, OutputsNeverReplaceAFolderOrAnInput) {
  const fs::path out = tempRoot() / "folder_map";
  fs::create_directories(out / "map.slammap");
  std::ofstream(out / "map.slammap" / "notes.txt") << "precious";
  const std::string folderError = errorOf([&] { runSlam(out); });
  EXPECT_NE(folderError.find("map.slammap: is a folder; refusing to replace it with a file"), std::string::npos)
      << folderError;
  EXPECT_EQ(readText(out / "map.slammap" / "notes.txt"), "precious");
  for (const char* name : {"trajectory.txt", "keyframes.txt", "report.json"})
    EXPECT_FALSE(fs::exists(out / name)) << name;
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();

  // The config file is one of the outputs' names.
  const fs::path out2 = tempRoot() / "config_is_output";
  fs::create_directories(out2);
  fs::copy_file(kConfig, out2 / "report.json");
  const std::string config = readText(out2 / "report.json");
  const std::string inputError = errorOf([&] { runSlam(out2, 1, false, roomRawlog(), out2 / "report.json"); });
  EXPECT_NE(inputError.find("is the input"), std::string::npos) << inputError;
  EXPECT_EQ(readText(out2 / "report.json"), config);
}

// Reliability: a rawlog whose gzip data is corrupt is reported as corrupt (not as a rawlog without frames).
TEST(SlamE2E, CorruptRawlogIsNamedCorrupt) {
  const fs::path dir = tempRoot() / "corrupt";
  fs::create_directories(dir);
  std::string bytes = readText(roomRawlog());
  ASSERT_GT(bytes.size(), 100u);
  bytes[20] = static_cast<char>(bytes[20] ^ 0x55);  // inside the first deflate block
  std::ofstream(dir / "room.rawlog", std::ios::binary) << bytes;
  fs::copy(roomRawlog().parent_path() / "room_Images", dir / "room_Images", fs::copy_options::recursive);
  const std::string error = errorOf([&] { runSlam(dir / "out", 1, false, dir / "room.rawlog"); });
  EXPECT_NE(error.find("room.rawlog"), std::string::npos) << error;
  EXPECT_NE(error.find("corrupt"), std::string::npos) << error;
  EXPECT_EQ(error.find("no CAMERA frame"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(dir / "out" / "trajectory.txt"));
}

// With progress output the rawlog's frames are counted first (the progress total); without, the range ends where
// the rawlog does: the same frames, the same range in report.json, the same errors.
TEST(SlamE2E, FrameRangeIsRespected) {
  for (const bool progress : {false, true}) {
    SCOPED_TRACE(progress ? "counted" : "not counted");
    apps::SlamRunOptions o;
    o.config = kConfig;
    o.rawlog = roomRawlog();
    o.outDir = tempRoot() / "range";
    o.first = 10;
    o.last = 14;
    o.progress = progress;
    const auto s = apps::SlamRunApp(o).run();
    EXPECT_EQ(s.framesProcessed, 5u);
    const auto report = nlohmann::json::parse(readText(o.outDir / "report.json"));
    ASSERT_EQ(report["frames"].size(), 5u);
    EXPECT_EQ(report["frames"][0]["index"], 10);
    EXPECT_EQ(report["frames"][4]["index"], 14);
    EXPECT_EQ(report["last"], 14);
    // A range past the rawlog's end ends at its last frame.
    o.first = kFrames - 3;
    o.last = 100000;
    EXPECT_EQ(apps::SlamRunApp(o).run().framesProcessed, 3u);
    EXPECT_EQ(nlohmann::json::parse(readText(o.outDir / "report.json"))["last"], kFrames - 1);
    o.first = 20;
    o.last = 5;
    EXPECT_THROW(apps::SlamRunApp(o).run(), Error);
    o.first = kFrames + 5;
    o.last = -1;
    const std::string past = errorOf([&] { apps::SlamRunApp(o).run(); });
    EXPECT_NE(past.find("no frame in the range [" + std::to_string(kFrames + 5) + ", " + std::to_string(kFrames - 1) +
                        "]"),
              std::string::npos)
        << past;
  }
  // A rawlog without a CAMERA frame is named, counted or not.
  const fs::path empty = tempRoot() / "empty" / "empty.rawlog";
  fs::create_directories(empty.parent_path());
  {
    datasets::RawlogWriter writer(empty);
    writer.commit();
  }
  for (const bool progress : {false, true}) {
    apps::SlamRunOptions o;
    o.config = kConfig;
    o.rawlog = empty;
    o.outDir = tempRoot() / "empty_out";
    o.progress = progress;
    const std::string error = errorOf([&] { apps::SlamRunApp(o).run(); });
    EXPECT_NE(error.find("empty.rawlog: rawlog has no CAMERA frame"), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(o.outDir / "trajectory.txt"));
  }
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
