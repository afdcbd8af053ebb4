// Local mapping with the chapter-3 point models (§3.3-3.4) and the point-use policy, on the synthetic scenes of
// test_local_mapper.cpp: model updates, activation, masking, culling, determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/optimize/PoseParameterization.h"
#include <ceres/autodiff_cost_function.h>
#include "LocalMappingSequence.h"
#include "SyntheticScene.h"

namespace pslam::mapping {
namespace {

using namespace pslam::mapping::testing;

TEST(LocalMapper, ProbabilisticModelUpdatesPointStatesAndActivatesConsistentPoints) {
  LocalMappingParams params = heuristicParams();
  params.pointModel.policy.model = landmarks::MapPointModel::Probabilistic;
  std::vector<LocalMappingReport> reports;
  Scene s;
  const map::Map m = runSequence(params, 12, &reports, &s);
  int updates = 0;
  for (const auto& r : reports) updates += r.landmarkUpdates;
  EXPECT_GT(updates, 100);
  landmarks::KeypointModel model(params.pointModel.keypoint);
  const double freshPhi = model.inlierRatio(model.initialize(0.2, 1e-4));
  // a = b = 10 and no class evidence (static, A = 5): new points start at psi_min exactly, active.
  ASSERT_EQ(freshPhi, params.pointModel.keypoint.psiMin);
  int withState = 0, measured = 0, active = 0, updatedOften = 0;
  for (const auto& [id, p] : m.mapPoints()) {
    if (p.landmarkState.empty()) continue;
    ++withState;
    const landmarks::KeypointState st = decodeKeypointState(p.landmarkState, "test");
    // The filter's inverse depth agrees with the (exact) geometry.
    EXPECT_NEAR(st.mu, p.inverseDepthAlongZ(), 0.02 * p.inverseDepthAlongZ()) << "point " << id;
    if (st.depthUpdates == 0) continue;
    ++measured;
    // Consistent measurements only ever raise the inlier ratio.
    EXPECT_GT(model.inlierRatio(st), freshPhi) << "point " << id;
    // Each inlier adds about one count to a_obs, so phi passes psi_min = 0.6 after a handful (Table 3.2).
    if (st.depthUpdates >= 8) {
      ++updatedOften;
      active += model.isActive(st);
    }
  }
  EXPECT_GT(withState, 100);
  EXPECT_GT(measured, 100);
  ASSERT_GT(updatedOften, 20);
  EXPECT_EQ(active, updatedOften);
}

// Masking model: points whose semantic evidence says "dynamic" are inactive and left out of local BA.
TEST(LocalMapper, MaskingModelDeactivatesDynamicPointsAndKeepsThemOutOfBundleAdjustment) {
  std::mt19937 rng(41);
  Scene s = makeScene(120, 18);
  map::Map map;
  for (int slot = 0; slot < 3; ++slot) {
    const KeyFrameId id = addKeyFrame(map, s, slot, rng);
    KeyFrame& kf = map.mutableKeyFrame(id);
    kf.semanticProbabilities.assign(kf.numKeypoints(), {0.9f, 0.05f, 0.05f});
    for (int i = 0; i < 20; ++i)
      if (s.keypointOf[slot][i] >= 0) kf.semanticProbabilities[s.keypointOf[slot][i]] = {0.05f, 0.9f, 0.05f};
  }
  const auto ids = addTruePoints(map, s, 0, 60, 0, {0, 1, 2});
  LocalMappingParams params = heuristicParams();
  params.pointModel.policy.model = landmarks::MapPointModel::Masking;
  LocalMapper mapper(map, params);
  for (int slot = 0; slot < 3; ++slot) mapper.processNewKeyFrame(s.keyframes[slot], {});
  int dynamicSeen = 0;
  for (int i = 0; i < 60; ++i) {
    const MapPointId id = s.mapPointOf[i];
    if (id == map::kNoMapPoint) continue;
    EXPECT_EQ(mapper.isActive(id), i >= 20) << "scene point " << i;
    dynamicSeen += i < 20;
  }
  ASSERT_GT(dynamicSeen, 5);
  // Perturbed inverse depths: BA moves the static (active) points only.
  std::map<MapPointId, double> before;
  for (MapPointId id : ids) {
    map.setInverseDepth(id, map.mapPoint(id).inverseDepth * 1.05);
    before[id] = map.mapPoint(id).inverseDepth;
  }
  mapper.runLocalBundleAdjustment(s.keyframes[2]);
  map.checkInvariants("after masked BA");
  int movedStatic = 0;
  for (int i = 0; i < 60; ++i) {
    const MapPointId id = s.mapPointOf[i];
    if (id == map::kNoMapPoint) continue;
    if (i < 20)
      EXPECT_EQ(map.mapPoint(id).inverseDepth, before[id]) << "inactive point " << i << " was optimized";
    else
      movedStatic += map.mapPoint(id).inverseDepth != before[id];
  }
  EXPECT_GT(movedStatic, 20);
}

// Probabilistic model: the policy culls a recent point whose inlier ratio collapsed, whatever its counters.
TEST(LocalMapper, ProbabilisticCullingFollowsTheKeypointModel) {
  std::mt19937 rng(43);
  Scene s = makeScene(60, 19);
  map::Map map;
  for (int slot = 0; slot < 2; ++slot) addKeyFrame(map, s, slot, rng);
  const auto ids = addTruePoints(map, s, 0, 60, 0, {0, 1});
  ASSERT_GT(ids.size(), 10u);
  LocalMappingParams params = heuristicParams();
  params.pointModel.policy.model = landmarks::MapPointModel::Probabilistic;
  const landmarks::KeypointModel model(params.pointModel.keypoint);
  landmarks::KeypointState outlier = model.initialize(0.2, 1e-4);
  // Far enough below the culling ratio that the static class evidence of a view without SEMANTIC (a_sem ~ 5,
  // PointModelParams::semantic) does not lift it back above.
  outlier.aObs = 1.0;
  outlier.bObs = 80.0;
  outlier.depthUpdates = params.pointModel.policy.cullMinDepthUpdates;
  ASSERT_LT(model.inlierRatio(outlier), params.pointModel.policy.cullInlierRatio);
  map.mutableMapPoint(ids[0]).landmarkState = encodeKeypointState(outlier);
  LocalMapper mapper(map, params);
  EXPECT_FALSE(mapper.isActive(ids[0]));
  mapper.processNewKeyFrame(s.keyframes[1], ids);
  // processNewKeyFrame added one (consistent) measurement: still far below the culling ratio.
  EXPECT_EQ(mapper.cullRecentPoints(s.keyframes[1]), 1);
  EXPECT_FALSE(map.hasMapPoint(ids[0]));
  for (std::size_t n = 1; n < ids.size(); ++n) EXPECT_TRUE(map.hasMapPoint(ids[n]));
  map.checkInvariants("after probabilistic culling");
  // Also once out of probation: a point the new keyframe observes is checked by the policy.
  map.mutableMapPoint(ids[1]).landmarkState = encodeKeypointState(outlier);
  mapper.reset();
  int byInlierRatio = -1;
  EXPECT_EQ(mapper.cullRecentPoints(s.keyframes[1], &byInlierRatio), 1);
  EXPECT_EQ(byInlierRatio, 1) << "culled by the phi rule, not by ORB-SLAM's recent-point rules";
  EXPECT_FALSE(map.hasMapPoint(ids[1]));
}

TEST(LocalMapper, ProbabilisticSequenceIsDeterministic) {
  LocalMappingParams params = heuristicParams();
  params.pointModel.policy.model = landmarks::MapPointModel::Probabilistic;
  std::vector<LocalMappingReport> r1, r2;
  EXPECT_TRUE(runSequence(params, 6, &r1) == runSequence(params, 6, &r2));
}

// The steps one by one on a noisy sequence (1 px keypoint noise): the map invariants hold after each.
TEST(LocalMapper, InvariantsHoldAfterEveryStep) {
  std::mt19937 rng(51);
  Scene s = makeScene(300, 24);
  s.pixelNoise = 1.0;
  map::Map map;
  addKeyFrame(map, s, 0, rng);
  addKeyFrame(map, s, 1, rng);
  const auto initial = addTruePoints(map, s, 0, 60, 0, {0, 1});
  LocalMapper mapper(map, heuristicParams());
  int erasedObservations = 0;
  for (int slot = 0; slot < 8; ++slot) {
    const KeyFrameId id = slot < 2 ? s.keyframes[slot] : addKeyFrame(map, s, slot, rng);
    if (slot >= 2) trackKeyFrame(map, s, slot);
    const std::string at = "slot " + std::to_string(slot) + " after ";
    mapper.processNewKeyFrame(id, slot == 1 ? initial : std::vector<MapPointId>{});
    map.checkInvariants(at + "processNewKeyFrame");
    mapper.cullRecentPoints(id);
    map.checkInvariants(at + "cullRecentPoints");
    mapper.createNewMapPoints(id);
    map.checkInvariants(at + "createNewMapPoints");
    mapper.searchInNeighbors(id);
    map.checkInvariants(at + "searchInNeighbors");
    if (map.numKeyFrames() > 2) erasedObservations += mapper.runLocalBundleAdjustment(id).observationsErased;
    map.checkInvariants(at + "runLocalBundleAdjustment");
    mapper.cullKeyFrames(id);
    map.checkInvariants(at + "cullKeyFrames");
    learnMapPoints(map, s);
  }
  EXPECT_GT(map.numMapPoints(), 150u);
  std::printf("keyframes %zu, points %zu, BA observations erased %d\n", map.numKeyFrames(), map.numMapPoints(),
              erasedObservations);
}

TEST(LocalMapper, UnknownKeyFrameIsAnError) {
  map::Map map;
  LocalMapper mapper(map, heuristicParams());
  EXPECT_THROW(mapper.processKeyFrame(42, {}), Error);
}


/// A policy that refuses every point with an odd id (and counts how often it was asked).
class OddIdsRefused : public map::PointUsePolicy {
 public:
  std::string name() const override { return "odd-ids-refused"; }
  bool mayUse(const map::MapPoint& p) const override {
    ++asked;
    return !p.bad && p.id % 2 == 0;
  }
  bool shouldCull(const map::MapPoint& p, KeyFrameId) const override { return p.bad; }
  mutable int asked = 0;
};

TEST(LocalMapper, BundleAdjustmentNeverUsesAPointThePolicyRefuses) {
  std::mt19937 rng(21);
  Scene s = makeScene(150, 16);
  map::Map map;
  for (int slot = 0; slot < 6; ++slot) addKeyFrame(map, s, slot, rng);
  const auto ids = addTruePoints(map, s, 0, 150, 0, {0, 1, 2, 3, 4, 5});
  std::normal_distribution<double> n(0.0, 0.05);
  for (MapPointId id : ids) map.setInverseDepth(id, map.mapPoint(id).inverseDepth * (1.0 + n(rng)));
  std::map<MapPointId, double> before;
  for (MapPointId id : ids) before[id] = map.mapPoint(id).inverseDepth;
  LocalMappingParams params = heuristicParams();
  params.ba.maxLocalKeyFrames = 3;
  auto policy = std::make_shared<OddIdsRefused>();
  LocalMapper mapper(map, params, policy);
  EXPECT_EQ(mapper.pointUsePolicy(), policy);
  mapper.runLocalBundleAdjustment(s.keyframes[5]);
  EXPECT_GT(policy->asked, 0);
  int movedEven = 0;
  for (MapPointId id : ids) {
    ASSERT_TRUE(map.hasMapPoint(id));
    if (id % 2 == 1)
      EXPECT_EQ(map.mapPoint(id).inverseDepth, before[id]) << "refused point " << id << " was optimized";
    else
      movedEven += map.mapPoint(id).inverseDepth != before[id] ? 1 : 0;
  }
  EXPECT_GT(movedEven, 30);
  EXPECT_FALSE(mapper.isActive(ids[0] % 2 == 1 ? ids[0] : ids[1]));
}

TEST(LocalMapper, DefaultPolicyIsTheMapPointModel) {
  map::Map map;
  LocalMappingParams params = heuristicParams();
  LocalMapper heuristic(map, params);
  EXPECT_EQ(heuristic.pointUsePolicy()->name(), "heuristic");
  EXPECT_TRUE(heuristic.pointUsePolicy()->usesEveryGoodPoint());
  params.pointModel.policy.model = landmarks::MapPointModel::Probabilistic;
  LocalMapper probabilistic(map, params);
  EXPECT_EQ(probabilistic.pointUsePolicy()->name(), "probabilistic");
  EXPECT_FALSE(probabilistic.pointUsePolicy()->usesEveryGoodPoint());
}

}  // namespace
}  // namespace pslam::mapping
