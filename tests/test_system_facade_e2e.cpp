// End-to-end tests of the System façade (doc/api.md) on the short synthetic room clip: poses as CPose3D, the same
// trajectory as slam-run, map save / load and localization, the solver and initializer seams, configuration
// overrides, the image API (track(image, timestamp)) and the landmark-module seam (doc/architecture.md).
#include <algorithm>
#include <atomic>
#include <map>
#include <optional>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/map/Map.h"
#include "pslam/system/RunReport.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam/tracking/LandmarkModule.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/PoseSolver.h"
#include "pslam_test/RoomClip.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path& kConfig = test_support::kSyntheticConfig;
using test_support::errorOf;

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_facade_e2e");
  return root.path;
}

const fs::path& roomRawlog() {
  static const fs::path rawlog = test_support::renderRoomClip(tempRoot() / "synth");
  return rawlog;
}

apps::SlamRunSummary runSlam(const fs::path& out, std::uint32_t seed) {
  return test_support::runSlamRun(out, roomRawlog(), seed);
}
}  // namespace

namespace {
system::System makeSystem(const std::vector<std::string>& overrides = {}, std::uint32_t seed = 1) {
  system::SystemOptions options;
  options.seed = seed;
  return system::System(system::loadSlamParams(kConfig.string(), overrides), options);
}
}  // namespace

TEST(SystemFacade, PosesAreCPose3DAndTheTrajectoryMatchesSlamRun) {
  system::System slam = makeSystem();
  datasets::RawlogReader reader(roomRawlog());
  datasets::Frame f;
  std::size_t withPose = 0;
  mrpt::poses::CPose3D last;
  while (reader.next(f)) {
    const system::FrameResult r = slam.track(f);
    EXPECT_EQ(r.pose.has_value(), r.state == system::TrackingState::Tracking ||
                                      r.state == system::TrackingState::Relocalized);
    if (r.pose) {
      ++withPose;
      last = *r.pose;
    }
  }
  slam.finish();
  const Trajectory traj = system::toTrajectory(slam.trajectory());
  // Every frame with a pose, plus the initialization's reference frame that gets one retroactively.
  EXPECT_EQ(traj.size(), withPose + 1);
  EXPECT_EQ(system::toJson(slam.summary())["frames_tracked"].get<std::size_t>(), withPose);
  // The last frame's pose as tracked and as resolved against its (refined) reference keyframe agree closely.
  const mrpt::poses::CPose3D resolved = traj.back().toCPose3D();
  EXPECT_LT((resolved.asVectorVal() - last.asVectorVal()).norm(), 0.05);
  // slam-run writes exactly this trajectory (same seed, same frames).
  const fs::path out = tempRoot() / "facade_vs_app";
  runSlam(out, 1);
  std::istringstream app(test_support::readBytes(out / "trajectory.txt"));
  std::vector<std::string> lines;
  for (std::string line; std::getline(app, line);)
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  ASSERT_EQ(lines.size(), traj.size());
  for (std::size_t i = 0; i < lines.size(); ++i) EXPECT_EQ(lines[i], formatTumLine(traj[i])) << i;
  EXPECT_EQ(slam.keyFrameTrajectory().size(), slam.mapSnapshot().numKeyFrames());
}

TEST(SystemFacade, SavedMapIsLoadedAndLocalizationLeavesItUnchanged) {
  const fs::path mapFile = tempRoot() / "facade_map.slammap";
  {
    system::System slam = makeSystem();
    datasets::RawlogReader reader(roomRawlog());
    datasets::Frame f;
    while (reader.next(f) && f.index < 40) slam.track(f);
    ASSERT_TRUE(slam.initialized());
    slam.saveMap(mapFile);
  }
  system::System localizer = makeSystem();
  localizer.setMappingEnabled(false);
  localizer.loadMap(mapFile);
  EXPECT_TRUE(localizer.initialized());
  const map::Map before = localizer.mapSnapshot();
  datasets::RawlogReader reader(roomRawlog());
  datasets::Frame f;
  int frames = 0, located = 0, firstLocated = -1;
  while (reader.next(f)) {
    if (f.index < 30) continue;  // frames 30..59: half inside the mapped part, half beyond it
    const system::FrameResult r = localizer.track(f);
    EXPECT_FALSE(r.keyFrame);
    ++frames;
    if (r.pose) {
      ++located;
      if (firstLocated < 0) firstLocated = frames;
    }
  }
  EXPECT_EQ(firstLocated, 1) << "relocalization against the loaded map on the first frame";
  EXPECT_GE(located, frames * 8 / 10) << located << " of " << frames;
  EXPECT_TRUE(before == localizer.mapSnapshot()) << "localization changed the map";
  // Loading into a run whose camera differs is refused with the file named.
  system::SystemOptions other;
  other.camera = geometry::PinholeCamera(400, 400, 320, 240, 640, 480);
  system::System wrongCamera(system::loadSlamParams(kConfig.string()), other);
  const std::string err = errorOf([&] { wrongCamera.loadMap(mapFile); });
  EXPECT_NE(err.find("facade_map.slammap"), std::string::npos) << err;
  EXPECT_NE(err.find("camera"), std::string::npos) << err;
  EXPECT_NE(errorOf([&] { localizer.loadMap(tempRoot() / "missing.slammap"); }).find("missing.slammap"),
            std::string::npos);
}

namespace {
// Counts the calls reaching the solver / initializer chosen by name in the ini, and delegates to the shipped ones.
std::atomic<int> countingSolverCalls{0}, countingInitializerCalls{0};
struct CountingSolver : tracking::PoseSolver {
  tracking::FullPoseSolver inner;
  explicit CountingSolver(const optimize::PoseOptimizationParams& p) : inner(p) {}
  std::string name() const override { return "counting"; }
  optimize::PoseOptimizationResult solve(const tracking::PoseSolveRequest& r) const override {
    ++countingSolverCalls;
    return inner.solve(r);
  }
};
struct CountingInitializer : tracking::MapInitializer {
  std::unique_ptr<tracking::MapInitializer> inner;
  std::string name() const override { return "counting"; }
  tracking::InitializationOutcome process(tracking::Frame& f, map::Map& m, std::mt19937& rng,
                                          tracking::Frame* ref) override {
    ++countingInitializerCalls;
    return inner->process(f, m, rng, ref);
  }
  void reset() override { inner->reset(); }
  bool hasReference() const override { return inner->hasReference(); }
};
}  // namespace

TEST(SystemFacade, PoseSolverAndInitializerAreChosenByConfig) {
  tracking::registerPoseSolver("counting", [](const optimize::PoseOptimizationParams& p) {
    return std::make_unique<CountingSolver>(p);
  });
  tracking::registerMapInitializer("counting", [](const geometry::PinholeCamera& c, const tracking::InitializerParams& p,
                                                  const optimize::BundleAdjustmentParams& ba) {
    auto init = std::make_unique<CountingInitializer>();
    init->inner = tracking::makeMapInitializer("twoView", c, p, ba);
    return init;
  });
  // The shipped solver and initializer, reached through the same factories, give the reference run.
  system::System reference = makeSystem();
  system::System swapped = makeSystem({"System.poseSolver=counting", "System.initializer=counting"});
  datasets::RawlogReader reader(roomRawlog());
  datasets::Frame f;
  while (reader.next(f) && f.index < 30) {
    const auto a = reference.track(f);
    const auto b = swapped.track(f);
    EXPECT_EQ(a.state, b.state) << f.index;
  }
  EXPECT_GT(countingSolverCalls.load(), 10);
  EXPECT_GT(countingInitializerCalls.load(), 0);
  EXPECT_EQ(system::runReport(swapped)["pose_solver"], "counting");
  // Same computations behind the wrappers: the same trajectory bytes.
  const Trajectory ta = system::toTrajectory(reference.trajectory()), tb = system::toTrajectory(swapped.trajectory());
  ASSERT_EQ(ta.size(), tb.size());
  for (std::size_t i = 0; i < ta.size(); ++i) EXPECT_EQ(formatTumLine(ta[i]), formatTumLine(tb[i]));
  // An unknown name fails when the system is made, naming the key and the choices.
  const std::string err = errorOf([&] { makeSystem({"System.poseSolver=nope"}); });
  EXPECT_NE(err.find("[System] poseSolver = nope"), std::string::npos) << err;
  EXPECT_NE(err.find("full6dof"), std::string::npos) << err;
}

TEST(SystemFacade, OverridesApplyAndMalformedOnesAreRejected) {
  const system::SlamParams p = system::loadSlamParams(kConfig.string(), {"ORB.nFeatures=777", "Tracking.minPoseInliers=12"});
  EXPECT_EQ(p.orb.nFeatures, 777);
  EXPECT_EQ(p.tracking.minPoseInliers, 12);
  EXPECT_NE(errorOf([&] { system::loadSlamParams(kConfig.string(), {"ORBnFeatures=7"}); }).find("ORBnFeatures=7"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { system::loadSlamParams(kConfig.string(), {"ORB.nFeatures"}); }).find("ORB.nFeatures"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { system::loadSlamParams(kConfig.string(), {"Tracking.minPoseInliers=1"}); }).find("minPoseInliers"),
            std::string::npos);
  // slam-run keeps the overrides and their effect in the report.
  apps::SlamRunOptions o;
  o.config = kConfig;
  o.overrides = {"ORB.nFeatures=900"};
  o.rawlog = roomRawlog();
  o.outDir = tempRoot() / "overrides";
  o.last = 3;
  o.progress = false;
  apps::SlamRunApp(o).run();
  const auto report = nlohmann::json::parse(test_support::readBytes(o.outDir / "report.json"));
  EXPECT_EQ(report["overrides"][0], "ORB.nFeatures=900");
  EXPECT_NE(report["config"].get<std::string>().find("900"), std::string::npos);
}

// ---------------------------------------------------------------------------------------- the image API

TEST(SystemFacade, ImagesAndTimestampsTrackAsTheRawlogFramesDo) {
  // track(image, timestamp) with the rawlog's camera given up front: the same frames, the same trajectory bytes.
  system::System fromFrames = makeSystem();
  system::SystemOptions options;
  options.seed = 1;
  std::optional<system::System> fromImages;
  datasets::RawlogReader reader(roomRawlog());
  datasets::Frame f;
  std::size_t n = 0;
  while (reader.next(f) && f.index < 40) {
    if (!fromImages) {
      options.camera = geometry::PinholeCamera::fromTCamera(f.camera);
      fromImages.emplace(system::loadSlamParams(kConfig.string()), options);
    }
    const system::FrameResult a = fromFrames.track(f);
    const system::FrameResult b = fromImages->track(f.image, f.timestamp);
    EXPECT_EQ(a.state, b.state) << f.index;
    EXPECT_EQ(b.index, n++);
  }
  const Trajectory ta = system::toTrajectory(fromFrames.trajectory());
  const Trajectory tb = system::toTrajectory(fromImages->trajectory());
  ASSERT_EQ(ta.size(), tb.size());
  ASSERT_GT(ta.size(), 20u);
  for (std::size_t i = 0; i < ta.size(); ++i) EXPECT_EQ(formatTumLine(ta[i]), formatTumLine(tb[i])) << i;
  // Without a camera, or with an image of another size, the error says what is missing.
  system::System noCamera = makeSystem();
  EXPECT_NE(errorOf([&] { noCamera.track(f.image, 0.0); }).find("SystemOptions::camera"), std::string::npos);
  EXPECT_NE(errorOf([&] { fromImages->track(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), 99.0); }).find("10x10"),
            std::string::npos);
  EXPECT_FALSE(errorOf([&] { fromImages->track(cv::Mat(), 99.0); }).empty());
}

// ---------------------------------------------------------------------------------------- the plug-in seam

namespace {
/// A landmark module that contributes nothing and logs every call the system makes on it, in order.
class CountingModule : public tracking::LandmarkModule {
 public:
  explicit CountingModule(std::shared_ptr<std::vector<std::string>> log) : log_(std::move(log)) {}
  std::string name() const override { return "counting"; }
  void prepareFrame(const tracking::Frame& frame, StageTimings&) override {
    add("prepareFrame " + std::to_string(frame.index));
  }
  bool joins(const tracking::PoseAttempt& attempt) const override {
    add(attempt.finalOptimization ? "joins final" : "joins");
    return true;
  }
  tracking::ModulePoseFactors poseFactors(const tracking::Frame& frame, const map::Map&, map::KeyFrameId) override {
    add("poseFactors " + std::to_string(frame.index));
    return {};
  }
  int minInliers() const override { return 1; }
  tracking::ModuleFrameReport afterTracking(const tracking::Frame& frame, const map::Map&,
                                            const std::vector<bool>& factorOutliers, bool learn) override {
    add("afterTracking " + std::to_string(frame.index) + (learn ? "" : " count-only"));
    EXPECT_TRUE(factorOutliers.empty()) << "flags of factors the module never gave";
    tracking::ModuleFrameReport r;
    r.counts = {{"counting_frames", ++frames_}};
    return r;
  }
  void addKeyFrame(const tracking::KeyFrameImages& k) override {
    add("addKeyFrame " + std::to_string(k.id) + (k.fromLastFrame ? "" : " new-map"));
    EXPECT_FALSE(k.grey.empty());
    ++keyFrames_;
  }
  void afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings&, nlohmann::json& log) override {
    add("afterLocalMapping " + std::to_string(kf));
    EXPECT_TRUE(map.hasKeyFrame(kf));
    log["counting_keyframe"] = kf;
  }
  std::vector<std::shared_ptr<optimize::BAFactor>> bundleAdjustmentFactors(const map::Map&,
                                                                          const optimize::BAProblem&) override {
    add("bundleAdjustmentFactors");
    return {};
  }
  void afterBundleAdjustment(const std::vector<bool>& outliers) override {
    add("afterBundleAdjustment");
    EXPECT_TRUE(outliers.empty());
  }
  void reset() override { add("reset"); }
  std::map<std::string, std::size_t> counts() const override { return {{"counting_keyframes", keyFrames_}}; }
  std::string mapExtensionName() const override { return "counting"; }
  std::optional<std::string> mapExtension() const override {
    add("mapExtension");
    return "keyframes " + std::to_string(keyFrames_);
  }
  std::function<void()> prepareLoad(const std::string& bytes, const map::Map&) override {
    add("prepareLoad " + bytes);
    return [this] { add("restored"); };
  }

 private:
  void add(const std::string& call) const { log_->push_back(call); }
  std::shared_ptr<std::vector<std::string>> log_;
  std::size_t frames_ = 0, keyFrames_ = 0;
};

/// Position of the first entry of `log` at or after `from` that starts with `prefix` (log.size() if none).
std::size_t findFrom(const std::vector<std::string>& log, std::size_t from, const std::string& prefix) {
  for (std::size_t i = from; i < log.size(); ++i)
    if (log[i].rfind(prefix, 0) == 0) return i;
  return log.size();
}
}  // namespace

TEST(LandmarkModuleSeam, ACountingModuleSeesEveryStageInOrderAndChangesNoPose) {
  auto log = std::make_shared<std::vector<std::string>>();
  system::SystemOptions options;
  options.seed = 1;
  options.modules.push_back([log](const geometry::PinholeCamera&) { return std::make_shared<CountingModule>(log); });
  system::System plain = makeSystem();
  system::System counted(system::loadSlamParams(kConfig.string()), options);
  datasets::RawlogReader reader(roomRawlog());
  std::size_t keyFramesMade = 0, tracked = 0;
  for (datasets::Frame f; reader.next(f);) {
    plain.track(f);
    const system::FrameResult r = counted.track(f);
    keyFramesMade += r.keyFrame ? (r.method == "initializer" ? 2 : 1) : 0;
    tracked += r.pose && r.method != "initializer" ? 1 : 0;
  }
  // No pose changes: the same trajectory and keyframes, byte for byte.
  const Trajectory ta = system::toTrajectory(plain.trajectory()), tb = system::toTrajectory(counted.trajectory());
  ASSERT_EQ(ta.size(), tb.size());
  for (std::size_t i = 0; i < ta.size(); ++i) ASSERT_EQ(formatTumLine(ta[i]), formatTumLine(tb[i])) << i;
  const Trajectory ka = system::toTrajectory(plain.keyFrameTrajectory());
  const Trajectory kb = system::toTrajectory(counted.keyFrameTrajectory());
  ASSERT_EQ(ka.size(), kb.size());
  for (std::size_t i = 0; i < ka.size(); ++i) EXPECT_EQ(formatTumLine(ka[i]), formatTumLine(kb[i])) << i;
  ASSERT_GT(tracked, 40u);

  const std::vector<std::string>& calls = *log;
  // A new map: the module is reset, then gets both keyframes of the initialization (no matches yet), mapped in turn.
  const std::size_t firstReset = findFrom(calls, 0, "reset");
  ASSERT_LT(firstReset, calls.size());
  EXPECT_EQ(calls.at(firstReset + 1).rfind("addKeyFrame ", 0), 0u);
  EXPECT_NE(calls.at(firstReset + 1).find("new-map"), std::string::npos);
  EXPECT_NE(calls.at(firstReset + 2).find("new-map"), std::string::npos);
  // Every tracked frame: prepareFrame, then the module asked to join and give factors (at least the final
  // optimization), then afterTracking, in that order, before the next frame.
  std::size_t frames = 0, keyFrames = 0;
  for (std::size_t i = 0; i < calls.size(); ++i) {
    if (calls[i].rfind("afterTracking ", 0) == 0) {
      ++frames;
      const std::string index = calls[i].substr(14);
      std::size_t prepare = i, final = i, factors = i;
      for (std::size_t k = i; k-- > 0 && calls[k].rfind("afterTracking", 0) != 0;) {
        if (calls[k] == "prepareFrame " + index) prepare = k;
        if (calls[k] == "joins final") final = std::min(final, k);
        if (calls[k] == "poseFactors " + index) factors = std::min(factors, k);
      }
      EXPECT_LT(prepare, final) << "frame " << index;
      EXPECT_LT(final, i) << "frame " << index << ": the final optimization never asked the module";
      EXPECT_LT(prepare, factors) << "frame " << index;
    }
    if (calls[i].rfind("addKeyFrame ", 0) == 0) {
      ++keyFrames;
      // Its local mapping comes before the next keyframe is given (sequential mode), with the module's BA factors
      // asked for and their flags handed back right after the solve.
      const std::string id = calls[i].substr(12, calls[i].find(' ', 12) - 12);
      const std::size_t mapped = findFrom(calls, i, "afterLocalMapping " + id);
      ASSERT_LT(mapped, calls.size()) << "keyframe " << id << " never mapped";
      for (std::size_t k = i; k < mapped; ++k)
        if (calls[k] == "bundleAdjustmentFactors") EXPECT_EQ(calls.at(k + 1), "afterBundleAdjustment");
    }
  }
  EXPECT_EQ(frames, tracked);
  EXPECT_EQ(keyFrames, keyFramesMade);
  EXPECT_GT(std::count(calls.begin(), calls.end(), "bundleAdjustmentFactors"), 5);
  // Its counters reach the summary and the report, its per-frame counts the frame reports.
  EXPECT_EQ(counted.summary().landmarks.at("counting_keyframes"), keyFrames);
  const nlohmann::json report = system::runReport(counted);
  EXPECT_EQ(report["summary"]["counting_keyframes"], keyFrames);
  EXPECT_EQ(report["frames"].back()["counting_frames"], frames);
  EXPECT_TRUE(report["mapping"].back().contains("counting_keyframe"));

  // Its store travels with the map: saved as the extension "counting", checked and restored on load (after the
  // map is in place and the module reset).
  const fs::path mapFile = tempRoot() / "counting.slammap";
  counted.saveMap(mapFile);
  EXPECT_EQ(calls.back(), "mapExtension");
  system::System loader(system::loadSlamParams(kConfig.string()), options);
  loader.setMappingEnabled(false);
  loader.loadMap(mapFile);
  const std::size_t prepared = findFrom(calls, 0, "prepareLoad keyframes " + std::to_string(keyFrames));
  ASSERT_LT(prepared, calls.size());
  const std::size_t reset = findFrom(calls, prepared, "reset");
  EXPECT_LT(reset, findFrom(calls, prepared, "restored"));
  EXPECT_EQ(calls.back(), "restored");
}
