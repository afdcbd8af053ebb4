// The threaded mode's global BA (LoopCloser::setAsynchronousGlobalBa): it runs on a copy of the map on a thread of
// its own while the map goes on changing, and its result is written back afterwards. On a synthetic map with
// perturbed keyframes: the keyframes and points of the copy take exactly the poses and depths the in-place global BA
// gives the same map; a keyframe made meanwhile keeps its pose relative to its spanning-tree parent; a point erased
// meanwhile stays erased; the keyframes-moved callback hears of it; a reset drops a running BA. And the loop edges
// saved with the map (its extension "loop_edges").
#include <condition_variable>
#include <mutex>
#include <random>

#include <gtest/gtest.h>

#include "SyntheticScene.h"
#include "pslam/core/Error.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/optimize/MapAdapter.h"

using namespace pslam;
namespace mt = pslam::mapping::testing;

namespace {

struct Fixture {
  mt::Scene scene = mt::makeScene(300, 11);
  map::Map map;
  std::mt19937 rng{3};

  Fixture() {
    for (int slot = 0; slot < 5; ++slot) mt::addKeyFrame(map, scene, slot, rng);
    mt::addTruePoints(map, scene, 0, 300, 0, {0, 1, 2, 3, 4});
    for (const auto& [id, kf] : map.keyFrames()) map.connectToSpanningTree(id);
    // Drift to remove: keyframes 1-4 a few centimetres and a fraction of a degree off.
    for (int slot = 1; slot < 5; ++slot) {
      Eigen::Isometry3d T = map.keyFrame(scene.keyframes[slot]).T_cam_world;
      T.translation() += Eigen::Vector3d(0.01 * slot, -0.005 * slot, 0.02);
      T.linear() = Eigen::AngleAxisd(0.003 * slot, Eigen::Vector3d::UnitY()).toRotationMatrix() * T.linear();
      map.setKeyFramePose(scene.keyframes[slot], T);
    }
  }
};

struct Ready {
  std::mutex m;
  std::condition_variable cv;
  bool ready = false;
  void set() {
    {
      std::lock_guard<std::mutex> lk(m);
      ready = true;
    }
    cv.notify_all();
  }
  void wait() {
    std::unique_lock<std::mutex> lk(m);
    cv.wait(lk, [&] { return ready; });
  }
};

loopclosing::LoopClosingParams enabled() {
  loopclosing::LoopClosingParams p;
  p.enabled = true;
  p.globalBAIterations = 10;
  return p;
}

}  // namespace

TEST(AsynchronousGlobalBa, WritesBackTheInPlaceResultAndCarriesWhatChangedMeanwhile) {
  Fixture f;
  optimize::BundleAdjustmentParams ba;
  ba.globalIterations = 10;
  map::Map reference = f.map;  // the in-place global BA of the same map
  optimize::globalBundleAdjustment(reference, ba);

  loopclosing::LoopCloser closer(f.map, enabled(), ba, 1);
  Ready ready;
  closer.setAsynchronousGlobalBa([&] { ready.set(); });
  int moved = 0;
  closer.setKeyFramesMoved([&](const loopclosing::LoopReport& r,
                               const std::map<map::KeyFrameId, Eigen::Isometry3d>& b) {
    ++moved;
    EXPECT_EQ(b.size(), f.map.numKeyFrames());
    for (const auto& [id, s] : r.keyFrameScales) EXPECT_EQ(s, 1.0) << "a global BA keeps the scale";
  });
  const Eigen::Vector3d c4Drifted = f.map.keyFrame(f.scene.keyframes[4]).cameraCenter();
  closer.startGlobalBundleAdjustment(f.scene.keyframes[4]);
  EXPECT_TRUE(closer.globalBaPending());

  // Meanwhile (tracking and local mapping): a new keyframe at slot 5, parented in the spanning tree, and a point
  // fused away.
  const map::KeyFrameId added = mt::addKeyFrame(f.map, f.scene, 5, f.rng);
  mt::trackKeyFrame(f.map, f.scene, 5);
  const map::KeyFrameId parent = f.map.connectToSpanningTree(added);
  ASSERT_NE(parent, map::kNoKeyFrame);
  const Eigen::Isometry3d T_added_parent =
      f.map.keyFrame(added).T_cam_world * f.map.keyFrame(parent).T_cam_world.inverse();
  const map::MapPointId erased = f.map.mapPoints().begin()->first;
  f.map.eraseMapPoint(erased);

  ready.wait();
  const std::optional<nlohmann::json> report = closer.applyGlobalBundleAdjustment();
  ASSERT_TRUE(report.has_value());
  EXPECT_FALSE(closer.globalBaPending());
  EXPECT_EQ(moved, 1);
  EXPECT_EQ((*report)["keyframes_set"], 4);  // every keyframe of the copy but the fixed root
  EXPECT_EQ((*report)["keyframes_made_meanwhile"], 1);
  EXPECT_EQ((*report)["points_fused_or_reanchored_meanwhile"], 1);
  const nlohmann::json& solver = (*report)["solver"];
  EXPECT_GT(solver["iterations"].get<int>(), 0);
  EXPECT_FALSE(solver["stopped"].get<bool>());
  EXPECT_LT(solver["rms_px_after"].get<double>(), solver["rms_px_before"].get<double>()) << solver.dump();
  EXPECT_GT(solver["observations"].get<int>(), 1000);

  // The copy's keyframes and points: the in-place result, bit for bit (the same problem, the same solver).
  for (int slot = 0; slot < 5; ++slot) {
    const map::KeyFrameId id = f.scene.keyframes[slot];
    EXPECT_TRUE(f.map.keyFrame(id).T_cam_world.matrix() == reference.keyFrame(id).T_cam_world.matrix()) << slot;
  }
  int compared = 0;
  for (const auto& [id, p] : reference.mapPoints()) {
    if (id == erased) continue;
    EXPECT_EQ(f.map.mapPoint(id).inverseDepth, p.inverseDepth) << id;
    ++compared;
  }
  EXPECT_GT(compared, 200);
  EXPECT_FALSE(f.map.hasMapPoint(erased));
  // The BA did something: keyframe 4 is nearer its true centre than the drifted one was.
  const Eigen::Vector3d truth4 = mt::poseOf(4).inverse().translation();
  EXPECT_LT((f.map.keyFrame(f.scene.keyframes[4]).cameraCenter() - truth4).norm(), 0.5 * (c4Drifted - truth4).norm());
  // The keyframe made meanwhile moved with its parent.
  const Eigen::Isometry3d after = f.map.keyFrame(added).T_cam_world * f.map.keyFrame(parent).T_cam_world.inverse();
  EXPECT_LT((after.matrix() - T_added_parent.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(closer.applyGlobalBundleAdjustment().has_value()) << "nothing pending any more";
}

TEST(AsynchronousGlobalBa, AResetDropsARunningGlobalBa) {
  Fixture f;
  optimize::BundleAdjustmentParams ba;
  loopclosing::LoopCloser closer(f.map, enabled(), ba, 1);
  closer.setAsynchronousGlobalBa([] {});
  const Eigen::Isometry3d before = f.map.keyFrame(f.scene.keyframes[4]).T_cam_world;
  closer.startGlobalBundleAdjustment(f.scene.keyframes[4]);
  closer.reset();  // waits for the thread, drops its result
  EXPECT_FALSE(closer.globalBaPending());
  EXPECT_FALSE(closer.applyGlobalBundleAdjustment().has_value());
  EXPECT_TRUE(f.map.keyFrame(f.scene.keyframes[4]).T_cam_world.matrix() == before.matrix());
}

TEST(AsynchronousGlobalBa, AbortStopsAndDropsTheRunningBaAndAnotherCanStart) {
  // A loop closed while the previous loop's global BA runs stops that BA (ORB-SLAM's mbStopGBA): its result is
  // dropped, the map keeps the correction it started from, and the new loop's BA can start.
  Fixture f;
  optimize::BundleAdjustmentParams ba;
  loopclosing::LoopClosingParams p = enabled();
  p.globalBAIterations = 1000;  // long enough to be running, or stopped, when the abort comes
  loopclosing::LoopCloser closer(f.map, p, ba, 1);
  int readyCalls = 0;
  Ready second;
  closer.setAsynchronousGlobalBa([&] {
    ++readyCalls;
    second.set();
  });
  EXPECT_FALSE(closer.abortGlobalBundleAdjustment()) << "nothing to abort";
  const Eigen::Isometry3d before = f.map.keyFrame(f.scene.keyframes[4]).T_cam_world;
  closer.startGlobalBundleAdjustment(f.scene.keyframes[4]);
  EXPECT_TRUE(closer.abortGlobalBundleAdjustment());  // does not wait for the thread
  EXPECT_FALSE(closer.globalBaPending());
  EXPECT_FALSE(closer.applyGlobalBundleAdjustment().has_value()) << "a stopped BA's result is dropped";
  // A new loop's BA may start while the stopped one's thread still ends its iteration.
  closer.startGlobalBundleAdjustment(f.scene.keyframes[4]);
  EXPECT_TRUE(closer.abortGlobalBundleAdjustment());
  closer.reset();  // joins the stopped threads
  EXPECT_TRUE(f.map.keyFrame(f.scene.keyframes[4]).T_cam_world.matrix() == before.matrix());
  EXPECT_LE(readyCalls, 2) << "a stopped BA signals at most the race it lost";
  const int readyBefore = readyCalls;
  {
    std::lock_guard<std::mutex> lk(second.m);
    second.ready = false;  // the stopped BAs' threads have ended: no later call of theirs
  }

  closer.startGlobalBundleAdjustment(f.scene.keyframes[4]);
  second.wait();
  EXPECT_TRUE(closer.globalBaFinished());
  EXPECT_EQ(readyCalls, readyBefore + 1);
  ASSERT_TRUE(closer.applyGlobalBundleAdjustment().has_value());
  EXPECT_FALSE(f.map.keyFrame(f.scene.keyframes[4]).T_cam_world.matrix() == before.matrix());
}

TEST(AsynchronousGlobalBa, StartingOneNeedsTheAsynchronousModeAndOneAtATime) {
  Fixture f;
  loopclosing::LoopCloser closer(f.map, enabled(), {}, 1);
  EXPECT_THROW(closer.startGlobalBundleAdjustment(0), Error);
  closer.setAsynchronousGlobalBa([] {});
  closer.startGlobalBundleAdjustment(0);
  EXPECT_THROW(closer.startGlobalBundleAdjustment(0), Error);
}

TEST(LoopEdges, SavedWithTheMapAndCheckedWhenLoaded) {
  // The map extension "loop_edges": edges between keyframes of the map come back as they were; an edge whose
  // keyframe the map culled since is left out when saving; bytes that do not fit the map are refused.
  Fixture f;
  loopclosing::LoopCloser closer(f.map, enabled(), {}, 1);
  const map::KeyFrameId a = f.scene.keyframes[0], b = f.scene.keyframes[4], c = f.scene.keyframes[2];
  std::string bytes;
  auto put = [&](std::uint64_t v) { bytes.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(2);
  put(b);
  put(a);
  put(c);
  put(a);
  closer.restoreLoopEdges(bytes, f.map);
  ASSERT_EQ(closer.loopEdges().size(), 2u);
  EXPECT_EQ(closer.loopEdges()[0], std::make_pair(b, a));
  EXPECT_EQ(closer.serializeLoopEdges(), bytes);

  f.map.eraseKeyFrame(c);
  const std::string saved = closer.serializeLoopEdges();
  EXPECT_EQ(saved.size(), 3 * sizeof(std::uint64_t)) << "the edge of the culled keyframe is left out";

  auto errorOf = [&](const std::string& bad) {
    try {
      closer.restoreLoopEdges(bad, f.map);
    } catch (const Error& e) {
      EXPECT_TRUE(closer.loopEdges().empty());
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(errorOf(bytes).find("does not join two keyframes of the map"), std::string::npos) << errorOf(bytes);
  EXPECT_NE(errorOf(saved.substr(0, 20)).find("truncated"), std::string::npos);
  EXPECT_NE(errorOf(saved + "x").find("unexpected bytes"), std::string::npos);
}
