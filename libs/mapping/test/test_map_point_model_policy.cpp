// MapPointModelPolicy::observe (§3.4.2): one measurement of a point in a view that is not its anchor is a
// depth triangulated against the anchor keypoint; it moves the inverse-depth mean towards the truth and raises
// the inlier ratio when consistent, lowers it when the point has moved; the class evidence follows the
// [PointModel] semantic switch.
#include <random>

#include <gtest/gtest.h>

#include "SyntheticScene.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/mapping/MapPointModelPolicy.h"

using namespace pslam;
namespace mt = pslam::mapping::testing;

namespace {

landmarks::PointModelParams probabilistic(bool semantic) {
  landmarks::PointModelParams p;
  p.policy.model = landmarks::MapPointModel::Probabilistic;
  p.semantic = semantic;
  return p;
}

/// A map with one keyframe (slot 0) and one point anchored there at its true position.
struct OnePoint {
  mt::Scene scene = mt::makeScene(50, 3);
  map::Map map;
  map::MapPointId id = map::kNoMapPoint;
  int sceneIndex = -1;
  OnePoint() {
    std::mt19937 rng(1);
    mt::addKeyFrame(map, scene, 0, rng);
    for (int i = 0; i < 50 && id == map::kNoMapPoint; ++i)
      if (scene.keypointOf[0][i] >= 0) {
        id = mt::addTruePoints(map, scene, i, i + 1, 0, {0}).at(0);
        sceneIndex = i;
      }
  }
  /// The point seen from `slot` at world position `p_world` (the truth, or where it moved to).
  map::PointMeasurement measurement(int slot, const Eigen::Vector3d& p_world) const {
    map::PointMeasurement m;
    m.T_cam_world = mt::poseOf(slot).inverse();
    m.camera = map.keyFrame(map.mapPoint(id).anchorKeyFrame).camera;
    m.pixel = m.camera.project(m.T_cam_world * p_world);
    m.descriptor = map.mapPoint(id).descriptor;
    return m;
  }
};

}  // namespace

TEST(MapPointModelPolicy, ConsistentMeasurementsActivateAndAMovedPointIsDeactivated) {
  const mapping::MapPointModelPolicy policy(probabilistic(false), 1.0);
  ASSERT_TRUE(policy.learnsFromMeasurements());
  OnePoint w;
  const Eigen::Vector3d truth = w.scene.points[w.sceneIndex];
  map::MapPoint& p = w.map.mutableMapPoint(w.id);
  // Start from a wrong depth (20 % too far) with a wide seed, as a fresh triangulation would.
  const double trueInvZ = p.inverseDepthAlongZ();
  landmarks::KeypointState seed = policy.keypointModel().initialize(0.8 * trueInvZ, 0.01);
  p.landmarkState = mapping::encodeKeypointState(seed);
  const double phi0 = policy.keypointModel().inlierRatio(policy.stateOf(p));
  // Presumed static without semantics: a = b = 10 plus the static class's A = 5 (Table 3.1) give exactly psi_min.
  EXPECT_EQ(phi0, policy.keypointModel().params().psiMin);
  EXPECT_TRUE(policy.mayUse(p)) << "a point presumed static is active from birth";

  for (int slot = 1; slot <= 4; ++slot) EXPECT_TRUE(policy.observe(w.map, p, w.measurement(slot, truth)));
  const landmarks::KeypointState after = policy.stateOf(p);
  EXPECT_EQ(after.depthUpdates, 4u);
  EXPECT_NEAR(after.mu, trueInvZ, 0.05 * trueInvZ) << "the mean moved to the true inverse depth";
  EXPECT_GT(policy.keypointModel().inlierRatio(after), phi0);
  EXPECT_TRUE(policy.mayUse(p)) << "four consistent measurements keep a point presumed static active";

  // The point moves 1.5 m sideways: triangulated against the anchor it is somewhere else, phi drops below
  // psi_min and the point is no longer used.
  const Eigen::Vector3d moved = truth + Eigen::Vector3d(1.5, 0.0, 0.0);
  for (int slot = 5; slot <= 8; ++slot) policy.observe(w.map, p, w.measurement(slot, moved));
  EXPECT_LT(policy.keypointModel().inlierRatio(policy.stateOf(p)), policy.keypointModel().params().psiMin);
  EXPECT_FALSE(policy.mayUse(p));
}

TEST(MapPointModelPolicy, ClassEvidenceFollowsTheSemanticSwitch) {
  const std::array<float, 3> car{0.05f, 0.9f, 0.05f};
  const mapping::MapPointModelPolicy withSemantics(probabilistic(true), 1.0);
  const mapping::MapPointModelPolicy without(probabilistic(false), 1.0);
  ASSERT_TRUE(withSemantics.classEvidence(&car).has_value());
  EXPECT_DOUBLE_EQ((*withSemantics.classEvidence(&car))[1], car[1]);
  EXPECT_FALSE(without.classEvidence(&car).has_value()) << "semantic = false: no evidence (the point stays static)";
  EXPECT_FALSE(withSemantics.classEvidence(nullptr).has_value()) << "no SEMANTIC channel: no evidence";
  // A view of a car makes the point inactive with semantics; without them the same measurement keeps it active.
  for (const auto* policy : {&withSemantics, &without}) {
    OnePoint w;
    map::MapPoint& p = w.map.mutableMapPoint(w.id);
    p.landmarkState = mapping::encodeKeypointState(policy->keypointModel().initialize(p.inverseDepthAlongZ(), 0.01));
    map::PointMeasurement m = w.measurement(2, w.scene.points[w.sceneIndex]);
    m.classProbabilities = &car;
    policy->observe(w.map, p, m);
    EXPECT_EQ(policy->mayUse(p), policy == &without);
  }
}

TEST(MapPointModelPolicy, HeuristicLearnsNothing) {
  landmarks::PointModelParams p;
  const mapping::MapPointModelPolicy heuristic(p, 1.0);
  EXPECT_FALSE(heuristic.learnsFromMeasurements());
  EXPECT_TRUE(heuristic.usesEveryGoodPoint());
}
