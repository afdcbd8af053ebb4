// End-to-end tests of the chapter-4 path (config/slam/structure.ini: Manhattan rotation in initialization and
// tracking, §4.4) through the System façade on short synthetic clips rendered by the slam-synth library:
// a low-texture clip that the point-only configuration cannot initialize is initialized and tracked; the keyframes'
// Manhattan rotation priors in local BA keep a longer one tracked where the thesis' BA loses it; frames whose
// normals vanish are tracked by the 6-DoF fallback and the Manhattan path is taken again afterwards; runs repeat
// bit for bit.
#include <filesystem>
#include <map>

#include <gtest/gtest.h>

#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalPriorsApp.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/system/RunReport.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam_test/Sim3Ate.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

const fs::path kSource = fs::path(PRIORSLAM_SOURCE_DIR);

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_structure_e2e");
  return root.path;
}

/// Renders a clip once per process (later calls with the same arguments reuse it).
fs::path render(const std::string& scenario, int frames, std::uint32_t seed, bool textured) {
  static std::map<std::string, fs::path> rendered;
  const std::string key = scenario + "/" + std::to_string(frames) + "/" + std::to_string(seed) + "/" + std::to_string(textured);
  if (const auto it = rendered.find(key); it != rendered.end()) return it->second;
  synth::SynthOptions o;
  o.scenario = scenario;
  o.frames = frames;
  o.seed = seed;
  o.textured = textured;
  o.noiseSigma = 1.0;
  o.outDir = tempRoot() / (scenario + std::to_string(seed));
  o.progress = false;
  return rendered[key] = synth::SynthApp(o).run().rawlog;
}

struct SlamRun {
  std::vector<system::FrameResult> frames;
  Trajectory trajectory;
  nlohmann::json summary;
};

/// Runs `config` (+ overrides) over the rawlog; frames in [dropFrom, dropTo) lose their NORMALS channel.
SlamRun runSystem(const fs::path& rawlog, const std::string& config, const std::vector<std::string>& overrides = {},
              std::size_t dropFrom = 0, std::size_t dropTo = 0) {
  system::SystemOptions options;
  options.seed = 1;
  system::System slam(system::loadSlamParams((kSource / config).string(), overrides), options);
  datasets::RawlogReader reader(rawlog);
  SlamRun run;
  for (datasets::Frame f; reader.next(f);) {
    if (f.index >= dropFrom && f.index < dropTo) f.normals = cv::Mat();
    run.frames.push_back(slam.track(f));
  }
  run.trajectory = system::toTrajectory(slam.trajectory());
  run.summary = system::toJson(slam.summary());
  return run;
}

double ateSim3(const fs::path& groundTruth, const Trajectory& est) {
  return test_support::ateSim3(readTumTrajectory(groundTruth), est);
}

}  // namespace

TEST(StructureE2E, LowTextureClipInitializesAndTracksOnlyWithTheManhattanPath) {
  // White walls, shading only: a few dozen corners per frame, never enough for the H/F initializer's 100 matches.
  const fs::path rawlog = render("lowtexture", 45, 1, false);
  const SlamRun pointOnly = runSystem(rawlog, "config/slam/synthetic.ini");
  EXPECT_FALSE(pointOnly.summary["initialized"].get<bool>());

  const SlamRun structure = runSystem(rawlog, "config/slam/structure.ini");
  ASSERT_TRUE(structure.summary["initialized"].get<bool>());
  EXPECT_LE(structure.summary["initialized_at_frame"].get<long long>(), 15);
  int manhattan = 0;
  for (const auto& r : structure.frames) manhattan += r.manhattanMode == "manhattan" && r.pose ? 1 : 0;
  EXPECT_GE(structure.summary["frames_tracked"].get<std::size_t>(), 30u);
  EXPECT_GE(manhattan, 20) << "the Manhattan rotation should carry most frames";
  EXPECT_LT(ateSim3(rawlog.parent_path() / "lowtexture_groundtruth.txt", structure.trajectory), 0.05);
}

TEST(StructureE2E, ManhattanRotationPriorsInLocalBAKeepTheLowTextureClipTracked) {
  // Without the priors (the thesis' BA) the map's rotation drifts away from the Manhattan world, the Manhattan
  // rotation stops agreeing with the map points and, with a few dozen corners per frame, tracking is lost; with
  // them every frame after initialization is tracked.
  const fs::path rawlog = render("lowtexture", 110, 2, false);
  // Without structure.ini's recovery after a loss, which hides part of the difference (it brings the thesis' BA
  // back after some of its losses).
  const SlamRun thesisBA =
      runSystem(rawlog, "config/slam/structure.ini", {"Manhattan.baRotationSigmaDeg=0", "Manhattan.recoveryFrames=0"});
  const SlamRun priors = runSystem(rawlog, "config/slam/structure.ini", {"Manhattan.recoveryFrames=0"});
  // Both lose frame 7 (two keyframes, too few matches: map reset) and initialize again at frame 15 or so.
  ASSERT_TRUE(priors.summary["initialized"].get<bool>());
  EXPECT_LE(priors.summary["frames_lost"].get<std::size_t>(), 1u);
  EXPECT_GE(priors.summary["frames_tracked"].get<std::size_t>(), 95u);
  EXPECT_GT(thesisBA.summary["frames_lost"].get<std::size_t>(), 20u)
      << "this clip no longer shows what the priors are for; pick one where the thesis' BA loses tracking";
  EXPECT_LT(ateSim3(rawlog.parent_path() / "lowtexture_groundtruth.txt", priors.trajectory), 0.05);
}

TEST(StructureE2E, NetworkNormalsOnAHeldOutLowTextureClipAreTrackedWithTheRelativeRotationPrior) {
  // Issue 13: monocular normals from the shipped network (config/manhattan/network_normals.ini) on a lowtexture
  // seed it never saw in training. Its Manhattan frames are a few degrees off: fixed in tracking (the thesis'
  // eq. 4.2) they lose the camera; as a frame-to-frame prior of a 6-DoF pose they keep it (doc/structure.md).
  // Measured when written: fixed 77 frames tracked, relative 146 (all after initialization at frame 4), ATE 0.036 m.
  const fs::path rendered = render("lowtexture", 150, 1001, false);
  priors::NormalPriorsOptions np;
  np.input = rendered;
  np.output = rendered.parent_path() / "lowtexture_network.rawlog";
  np.source = "network";
  np.config = kSource / "config/manhattan/network_normals.ini";
  np.progress = false;
  priors::runNormalPriors(np);
  const SlamRun fixed = runSystem(np.output, "config/slam/structure.ini");
  const SlamRun relative = runSystem(np.output, "config/slam/structure.ini", {"Manhattan.trackingRotation=relative"});
  ASSERT_TRUE(relative.summary["initialized"].get<bool>());
  EXPECT_LE(relative.summary["initialized_at_frame"].get<long long>(), 30);
  const auto tracked = relative.summary["frames_tracked"].get<std::size_t>();
  const auto afterInit = 150u - static_cast<std::size_t>(relative.summary["initialized_at_frame"].get<long long>());
  EXPECT_GE(tracked, afterInit * 95 / 100) << "tracked " << tracked << " of " << afterInit << " after initialization";
  EXPECT_LT(fixed.summary["frames_tracked"].get<std::size_t>() + 30u, tracked)
      << "this clip no longer shows what the relative prior is for";
  EXPECT_LT(ateSim3(rendered.parent_path() / "lowtexture_groundtruth.txt", relative.trajectory), 0.1);
}

TEST(StructureE2E, FallbackWhereNormalsVanishThenTheManhattanPathAgain) {
  const fs::path rawlog = render("corridor", 70, 2, true);
  const SlamRun run = runSystem(rawlog, "config/slam/structure.ini", {}, 30, 40);
  ASSERT_TRUE(run.summary["initialized"].get<bool>());
  ASSERT_LT(run.summary["initialized_at_frame"].get<long long>(), 25);
  for (std::size_t i = 30; i < 40; ++i) {
    const auto& r = run.frames[i];
    EXPECT_TRUE(r.pose.has_value()) << "frame " << i;
    EXPECT_EQ(r.manhattanMode, "fallback") << "frame " << i;
    EXPECT_FALSE(r.normals);
  }
  int back = 0;
  for (std::size_t i = 42; i < run.frames.size(); ++i) back += run.frames[i].manhattanMode == "manhattan" ? 1 : 0;
  EXPECT_GE(back, static_cast<int>(run.frames.size() - 42) * 8 / 10) << "the Manhattan path was not taken again";
  EXPECT_EQ(run.summary["frames_lost"].get<std::size_t>(), 0u);
  EXPECT_LT(ateSim3(rawlog.parent_path() / "corridor_groundtruth.txt", run.trajectory), 0.05);
}

TEST(StructureE2E, ManhattanPathRepeatsBitForBitAndDiffersFromPointOnly) {
  const fs::path rawlog = render("corridor", 70, 2, true);
  const SlamRun a = runSystem(rawlog, "config/slam/structure.ini");
  const SlamRun b = runSystem(rawlog, "config/slam/structure.ini");
  const SlamRun pointOnly = runSystem(rawlog, "config/slam/structure.ini",
                                  {"Manhattan.enabled=false", "System.initializer=twoView"});
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].timestamp, b.trajectory[i].timestamp);
    EXPECT_TRUE(a.trajectory[i].position == b.trajectory[i].position && a.trajectory[i].orientation.coeffs() == b.trajectory[i].orientation.coeffs()) << "pose " << i;
  }
  EXPECT_GT(a.summary["manhattan_tracked"].get<std::size_t>(), 0u);
  EXPECT_EQ(pointOnly.summary["manhattan_tracked"].get<std::size_t>(), 0u);
}
