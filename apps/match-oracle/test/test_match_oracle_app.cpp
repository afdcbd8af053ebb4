// match-oracle on a rendered room clip (depth and ground truth exact): correspondences are found with the true
// poses and lost with wrong ones, and bad input is an error naming the file.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
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

TEST(MatchOracle, KeypointOffsetsAreInLevelPixelsAndCoverEveryMatchableCorrespondence) {
  features::MatchOracleOptions o = options();
  o.radius = 2.0;
  const features::MatchOracleResult r = features::runMatchOracle(o);
  std::size_t matchable = 0, offsets = 0;
  for (const features::PairCounts& c : r.pairs) matchable += c.matchable;
  ASSERT_EQ(r.offsets.size(), 8u);  // synthetic.ini: 8 pyramid levels
  ASSERT_EQ(r.report["keypoint_offsets"].size(), 8u);
  for (const features::LevelOffsets& l : r.offsets) {
    SCOPED_TRACE("level " + std::to_string(l.level));
    ASSERT_EQ(l.dx.size(), l.dy.size());
    offsets += l.dx.size();
    ASSERT_GT(l.dx.size(), 20u);
    // Within the radius of 2 level pixels, and centred: the true poses leave no systematic shift.
    double sx = 0, sy = 0, ss = 0;
    for (std::size_t i = 0; i < l.dx.size(); ++i) {
      EXPECT_LE(std::hypot(l.dx[i], l.dy[i]), 2.0 + 1e-4);
      sx += l.dx[i];
      sy += l.dy[i];
      ss += double(l.dx[i]) * l.dx[i] + double(l.dy[i]) * l.dy[i];
    }
    const double n = static_cast<double>(l.dx.size());
    EXPECT_LT(std::abs(sx / n), 0.3);
    EXPECT_LT(std::abs(sy / n), 0.3);
    // In level pixels every level re-detects alike (in level-0 pixels level 7 would be 1.2^7 = 3.6 times level 0).
    const double rms = std::sqrt(ss / n);
    EXPECT_GT(rms, 0.2);
    EXPECT_LT(rms, 1.2);
    EXPECT_NEAR(r.report["keypoint_offsets"][static_cast<std::size_t>(l.level)]["rms_level_px"].get<double>(), rms,
                1e-6);
  }
  EXPECT_EQ(offsets, matchable);
}

TEST(MatchOracle, AlignedKeypointsSitCloserToTheTrueTransferThanDetectedOnes) {
  features::MatchOracleOptions o = options();
  o.radius = 2.0;
  const features::MatchOracleResult plain = features::runMatchOracle(o);
  for (const features::LevelOffsets& l : plain.offsets) EXPECT_EQ(l.alignTried, 0u);
  o.align = true;
  const features::MatchOracleResult r = features::runMatchOracle(o);
  const auto medianNorm = [](const std::vector<float>& dx, const std::vector<float>& dy) {
    std::vector<double> n;
    for (std::size_t i = 0; i < dx.size(); ++i) n.push_back(std::hypot(dx[i], dy[i]));
    std::sort(n.begin(), n.end());
    return n[n.size() / 2];
  };
  std::size_t tried = 0, accepted = 0;
  for (std::size_t level = 0; level < 3; ++level) {
    const features::LevelOffsets& l = r.offsets[level];
    SCOPED_TRACE("level " + std::to_string(level));
    EXPECT_EQ(l.alignTried, l.dx.size());  // every matchable correspondence is tried
    ASSERT_GT(l.alignedDx.size(), 20u);
    tried += l.alignTried;
    accepted += l.alignedDx.size();
    // The detections are as in the run without --align; the aligned positions sit at least twice as close.
    EXPECT_EQ(l.dx, plain.offsets[level].dx);
    EXPECT_LT(medianNorm(l.alignedDx, l.alignedDy), 0.5 * medianNorm(l.dx, l.dy));
    const nlohmann::json& j = r.report["keypoint_offsets"][level];
    EXPECT_EQ(j["align_accepted"].get<std::size_t>(), l.alignedDx.size());
    double ss = 0;
    for (std::size_t i = 0; i < l.alignedDx.size(); ++i)
      ss += double(l.alignedDx[i]) * l.alignedDx[i] + double(l.alignedDy[i]) * l.alignedDy[i];
    EXPECT_NEAR(j["aligned_rms_level_px"].get<double>(), std::sqrt(ss / double(l.alignedDx.size())), 1e-6);
  }
  EXPECT_GT(accepted, tried / 2);
  EXPECT_NE(r.text.find("aligned to the first keypoint's patch"), std::string::npos);
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
