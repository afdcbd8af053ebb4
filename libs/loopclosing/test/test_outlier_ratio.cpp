// loopclosing::outlierRatio, the test a loop correction must pass (LoopClosingParams::maxCorrectionOutlierRatio): a map
// whose keypoints are the exact projections of its points has none; keyframes moved against their measurements
// (what a false loop's correction does to the loop's keyframes) fail with nearly every observation, and only the
// keyframes from the given one on are counted; points moved alone are refit before the test.
#include <random>

#include <gtest/gtest.h>

#include "SyntheticScene.h"
#include "pslam/loopclosing/LoopCloser.h"

using namespace pslam;
namespace mt = pslam::mapping::testing;

TEST(LoopOutlierRatio, AConsistentMapHasNoneAndKeyFramesMovedAgainstTheirMeasurementsFailEveryObservation) {
  mt::Scene scene = mt::makeScene(300, 11);
  map::Map map;
  std::mt19937 rng{3};
  for (int slot = 0; slot < 5; ++slot) mt::addKeyFrame(map, scene, slot, rng);
  mt::addTruePoints(map, scene, 0, 300, 0, {0, 1, 2, 3, 4});
  const map::KeyFrameId first = scene.keyframes[0], fourth = scene.keyframes[3];
  EXPECT_EQ(loopclosing::outlierRatio(map, first, 5.991), 0.0);

  // Keyframes 3 and 4 moved 0.3 m sideways (the points stay): each of their observations is tens of pixels off.
  for (int slot = 3; slot < 5; ++slot) {
    Eigen::Isometry3d T = map.keyFrame(scene.keyframes[slot]).T_cam_world;
    T.translation() += Eigen::Vector3d(0.3, 0.0, 0.0);
    map.setKeyFramePose(scene.keyframes[slot], T);
  }
  std::size_t all = 0, moved = 0;
  for (const auto& [id, kf] : map.keyFrames())
    for (map::MapPointId p : kf.mapPointIds)
      if (p != map::kNoMapPoint) {
        ++all;
        if (id >= fourth) ++moved;
      }
  ASSERT_GT(moved, 100u);
  // Refit to all five keyframes, each point settles between the two groups: nearly every observation of the moved
  // keyframes fails, and most of the others too (a bent map fails broadly, not just where it was bent).
  const double fromFourth = loopclosing::outlierRatio(map, fourth, 5.991);
  const double fromFirst = loopclosing::outlierRatio(map, first, 5.991);
  EXPECT_GT(fromFourth, 0.95);
  EXPECT_GT(fromFirst, double(moved) / double(all));
  EXPECT_LT(fromFirst, fromFourth);  // only the keyframes from the given one on are counted
  // A test wide enough to take tens of pixels passes them all.
  EXPECT_EQ(loopclosing::outlierRatio(map, first, 1e9), 0.0);
  // No observations at all: 0.
  EXPECT_EQ(loopclosing::outlierRatio(map::Map(), 0, 5.991), 0.0);
}

TEST(LoopOutlierRatio, PointsMovedAloneAreRefitBeforeTheTest) {
  // What a correction does to points alone (each follows one keyframe) is not counted: the points are refit to
  // their observations first. All 300 points 5 cm off (several pixels at 4-8 m) with the poses right: no outlier.
  mt::Scene scene = mt::makeScene(300, 11);
  map::Map map;
  std::mt19937 rng{3};
  for (int slot = 0; slot < 5; ++slot) mt::addKeyFrame(map, scene, slot, rng);
  const std::vector<map::MapPointId> ids = mt::addTruePoints(map, scene, 0, 300, 0, {0, 1, 2, 3, 4});
  std::size_t farOff = 0;
  for (map::MapPointId id : ids) {
    const Eigen::Vector3d X = map.worldPosition(id) + Eigen::Vector3d(0.05, -0.03, 0.02);
    map.setWorldPosition(id, X);
    const map::KeyFrame& kf = map.keyFrame(scene.keyframes[2]);
    const std::size_t k = map.mapPoint(id).observations.at(kf.id);
    if ((kf.pixel(k) - kf.camera.project(kf.T_cam_world * X)).squaredNorm() * kf.invSigma2(k) > 5.991) ++farOff;
  }
  ASSERT_GT(farOff, 150u);  // without the refit most observations would fail
  EXPECT_EQ(loopclosing::outlierRatio(map, scene.keyframes[0], 5.991), 0.0);
}
