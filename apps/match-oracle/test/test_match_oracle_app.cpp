// match-oracle on a rendered room clip (depth and ground truth exact): correspondences are found with the true
// poses and lost with wrong ones, and bad input is an error naming the file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/features/MatchOracleApp.h"
#include "pslam/synth/SynthApp.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

const fs::path kSource = fs::path(PRIORSLAM_SOURCE_DIR);

const test_support::TempDir& tempRoot() {
  static const test_support::TempDir root("pslam_match_oracle");
  return root;
}

const synth::SynthSummary& roomClip() {
  static const synth::SynthSummary clip = [] {
    synth::SynthOptions o;
    o.scenario = "room";
    o.frames = 5;
    o.width = 320;
    o.height = 240;
    o.seed = 3;
    o.noiseSigma = 1.0;
    o.outDir = tempRoot().path / "room";
    o.progress = false;
    return synth::SynthApp(o).run();
  }();
  return clip;
}

features::MatchOracleOptions options() {
  features::MatchOracleOptions o;
  o.rawlog = roomClip().rawlog;
  o.config = kSource / "config/slam/synthetic.ini";
  o.steps = 2;
  o.progress = false;
  return o;
}

}  // namespace

TEST(MatchOracle, TruePosesCarryMostKeypointsOntoTheirCorrespondences) {
  const features::MatchOracleResult r = features::runMatchOracle(options());
  ASSERT_EQ(r.pairs.size(), 4u + 3u);  // 4 pairs one frame apart, 3 two frames apart
  for (const features::PairCounts& c : r.pairs) {
    SCOPED_TRACE(std::to_string(c.first) + "->" + std::to_string(c.second));
    EXPECT_GT(c.keypoints, 200u);
    EXPECT_EQ(c.withDepth, c.keypoints);  // rendered depth everywhere
    EXPECT_GT(c.visible, c.withDepth / 2);
    EXPECT_LE(c.repeated, c.visible);
    EXPECT_LE(c.matchable, c.repeated);
    EXPECT_LE(c.foundByDescriptor, c.matchable);
    // A rendered view a frame or two later: most visible keypoints are re-detected and matchable.
    EXPECT_GT(c.matchable, c.visible / 2);
    EXPECT_GT(c.foundByDescriptor, 0u);
  }
  ASSERT_EQ(r.report["per_step"].size(), 2u);
  EXPECT_EQ(r.report["per_step"][0]["pairs"], 4);
}

TEST(MatchOracle, WritesTheJsonAndThePlotTogether) {
  features::MatchOracleOptions o = options();
  o.outputJson = tempRoot().path / "out" / "oracle.json";
  o.outputPlot = tempRoot().path / "out" / "oracle.png";
  fs::create_directories(o.outputJson.parent_path());
  features::runMatchOracle(o);
  EXPECT_GT(fs::file_size(o.outputJson), 100u);
  EXPECT_GT(fs::file_size(o.outputPlot), 1000u);
  // A plot path that cannot be written (a folder): an error before the work, and no JSON either.
  fs::remove(o.outputJson);
  o.outputPlot = tempRoot().path / "out";
  EXPECT_THROW(features::runMatchOracle(o), Error);
  EXPECT_FALSE(fs::exists(o.outputJson));
}

TEST(MatchOracle, WrongPosesFindFewCorrespondences) {
  // The same frames with every ground-truth camera moved 0.3 m sideways per frame: the transfer misses.
  const Trajectory gt = readTumTrajectory(roomClip().groundTruth);
  const fs::path shifted = tempRoot().path / "shifted_groundtruth.txt";
  {
    std::ofstream os(shifted);
    os.precision(17);
    for (std::size_t i = 0; i < gt.size(); ++i) {
      const Eigen::Vector3d p = gt[i].position + gt[i].orientation * Eigen::Vector3d(0.3 * i, 0, 0);
      os << gt[i].timestamp << " " << p.x() << " " << p.y() << " " << p.z() << " " << gt[i].orientation.x() << " "
         << gt[i].orientation.y() << " " << gt[i].orientation.z() << " " << gt[i].orientation.w() << "\n";
    }
  }
  features::MatchOracleOptions o = options();
  const features::MatchOracleResult truth = features::runMatchOracle(o);
  o.groundTruth = shifted;
  const features::MatchOracleResult wrong = features::runMatchOracle(o);
  ASSERT_EQ(truth.pairs.size(), wrong.pairs.size());
  std::size_t matchableTrue = 0, matchableWrong = 0;
  for (std::size_t i = 0; i < truth.pairs.size(); ++i) {
    matchableTrue += truth.pairs[i].matchable;
    matchableWrong += wrong.pairs[i].matchable;
  }
  EXPECT_LT(matchableWrong * 5, matchableTrue);
}

TEST(MatchOracle, BadInputIsAnErrorNamingTheFile) {
  features::MatchOracleOptions o = options();
  o.groundTruth = tempRoot().path / "missing_groundtruth.txt";
  try {
    features::runMatchOracle(o);
    FAIL() << "a missing ground truth must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing_groundtruth.txt"), std::string::npos) << e.what();
  }
  o = options();
  o.steps = 0;
  EXPECT_THROW(features::runMatchOracle(o), Error);
  // Ground truth that covers none of the frames' timestamps.
  const fs::path far = tempRoot().path / "far_groundtruth.txt";
  {
    std::ofstream os(far);
    os << "1e9 0 0 0 0 0 0 1\n";
  }
  o = options();
  o.groundTruth = far;
  try {
    features::runMatchOracle(o);
    FAIL() << "frames without ground truth must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no ground-truth pose"), std::string::npos) << e.what();
  }
}
