// End-to-end test of chapter 3 on a dynamic scene: a traffic-jam clip rendered by the slam-synth library (the ego
// car approaches a queue and stops behind it while the traffic moves on), run by slam-run (SlamRunApp) with the
// heuristic model (ORB-SLAM*) and with the probabilistic model + semantic prior + direct points (§3.4): where the
// semantic model tracks, its trajectory is far closer to the ground truth than the heuristic's on the same frames,
// whose estimate follows the traffic. Measured with the same commands (doc/experiments.md): 0.027 m against
// 2.47 m over 79 frames. A second clip checks that the semantic model initializes on a straight road.
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pslam/apps/SlamRunApp.h"
#include "pslam/core/Trajectory.h"
#include "pslam/synth/SynthApp.h"
#include "pslam_test/SameStampPairs.h"
#include "pslam_test/Sim3Ate.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_dynamic_e2e");
  return root.path;
}

fs::path renderJam(int seed, int frames) {
  synth::SynthOptions o;
  o.scenario = "jam";
  o.frames = frames;
  o.seed = static_cast<unsigned>(seed);
  o.threads = 2;  // the images are the same for any count
  o.outDir = tempRoot() / ("jam" + std::to_string(seed));
  o.progress = false;
  return synth::SynthApp(o).run().rawlog;
}

// The first 130 frames of jam seed 2: the approach (the semantic model initializes at frame 52, from static points
// only) and the start of the stand-still (from frame ~85), where the heuristic follows the queue.
const fs::path& jamRawlog() {
  static const fs::path rawlog = renderJam(2, 130);
  return rawlog;
}

// The semantic model's initialization (§3.4.1) as config/experiments/ch3-direct.yaml runs it.
const std::vector<std::string> kSemanticInit = {"PointModel.model=probabilistic", "PointModel.semantic=true",
                                                "Initializer.minStaticProbability=0.8", "Initializer.minMatches=50",
                                                "Initializer.minMapPoints=50"};

Trajectory runSlam(const std::string& name, const std::vector<std::string>& overrides,
                   const fs::path& rawlog = jamRawlog()) {
  apps::SlamRunOptions o;
  o.config = kConfig;
  o.rawlog = rawlog;
  o.outDir = tempRoot() / name;
  o.seed = 1;
  o.progress = false;
  // As config/experiments/ch3-direct.yaml: the thesis evaluates without place recognition and loop closing.
  o.overrides = overrides;
  o.overrides.push_back("Places.vocabulary=");
  o.overrides.push_back("LoopClosing.enabled=false");
  apps::SlamRunApp(o).run();
  return readTumTrajectory(o.outDir / "trajectory.txt");
}

// Sim(3) ATE (RMSE) of `est` against the ground truth, over the timestamps of `frames` only.
double ateOn(const Trajectory& gt, const Trajectory& est, const Trajectory& frames) {
  return test_support::ateSim3(gt, test_support::sameStampPairs(frames, est).second);
}

}  // namespace

TEST(DynamicE2E, SemanticModelWithDirectPointsBeatsTheHeuristicInATrafficJam) {
  const Trajectory gt = readTumTrajectory(jamRawlog().parent_path() / "jam_groundtruth.txt");
  const Trajectory heuristic = runSlam("heuristic", {"PointModel.model=heuristic"});
  std::vector<std::string> semanticDirect = kSemanticInit;
  semanticDirect.push_back("DirectFeatures.enabled=true");
  const Trajectory semantic = runSlam("prob_semantic_direct", semanticDirect);
  // Measured: the heuristic tracks 129 frames, the semantic model the 79 after its initialization at frame 52.
  ASSERT_GE(heuristic.size(), 120u);
  ASSERT_GE(semantic.size(), 60u) << "the semantic model did not initialize during the approach";
  const double semanticAte = ateOn(gt, semantic, semantic);
  const double heuristicAte = ateOn(gt, heuristic, semantic);
  std::cout << "jam seed 2, 130 frames, " << semantic.size() << " frames of the semantic model: ATE "
            << semanticAte << " m (probabilistic + semantic + direct) against " << heuristicAte
            << " m (heuristic)\n";
  // Measured 0.027 against 2.47 m (0.011x); the thesis' Table 3.4 shows 0.42x over its whole sequence.
  EXPECT_LT(semanticAte, 0.25);
  EXPECT_LT(semanticAte, 0.2 * heuristicAte);
}

// Jam seed 5: the static points the semantic model initializes from lie mostly on the road, and the car drives
// straight on, so the homography's best decomposition ties with the plane's twin. With ORB-SLAM's rule
// (minOffPlaneSupportH = 0) every such frame is skipped and the map starts only after the stand-still (frame 170 of
// the full sequence); the matches off the road resolve the tie (measured: initialized at frame 59, then every frame
// tracked with the direct points).
TEST(DynamicE2E, OffPlaneMatchesLetTheSemanticModelInitializeOnAStraightRoad) {
  const fs::path rawlog = renderJam(5, 75);
  const Trajectory gt = readTumTrajectory(rawlog.parent_path() / "jam_groundtruth.txt");
  std::vector<std::string> resolvedRule = kSemanticInit;
  resolvedRule.push_back("DirectFeatures.enabled=true");
  std::vector<std::string> orbSlamRule = resolvedRule;
  orbSlamRule.push_back("Initializer.minOffPlaneSupportH=0");
  const Trajectory skipped = runSlam("twin_skipped", orbSlamRule, rawlog);
  const Trajectory resolved = runSlam("twin_resolved", resolvedRule, rawlog);
  std::cout << "jam seed 5, 75 frames: " << skipped.size() << " poses with ORB-SLAM's rule, " << resolved.size()
            << " with the off-plane matches\n";
  EXPECT_EQ(skipped.size(), 0u) << "ORB-SLAM's rule initialized during the approach";
  ASSERT_GE(resolved.size(), 12u) << "the semantic model did not initialize or track during the approach";
  const double ate = ateOn(gt, resolved, resolved);
  std::cout << "ATE " << ate << " m over " << resolved.size() << " poses\n";
  // Measured 0.078 m over 17 poses; the twin's motion (towards the road) would be metres off.
  EXPECT_LT(ate, 0.2);
}
