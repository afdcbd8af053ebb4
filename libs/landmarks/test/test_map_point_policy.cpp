#include <gtest/gtest.h>

#include <cmath>

#include <mrpt/config/CConfigFile.h>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/landmarks/MatchingAccuracy.h"

using namespace pslam::landmarks;

TEST(MapPointModel, ParseAndPrintRoundTrip) {
  for (auto m : {MapPointModel::Heuristic, MapPointModel::Masking, MapPointModel::Probabilistic})
    EXPECT_EQ(parseMapPointModel(toString(m)), m);
  EXPECT_EQ(parseMapPointModel("Probabilistic"), MapPointModel::Probabilistic);
  EXPECT_THROW(parseMapPointModel("orb"), pslam::Error);
}

TEST(MapPointPolicy, ConfigSelectsTheModel) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("PointModel", "model", "masking");
  MapPointPolicyParams p;
  p.loadFromConfigFile(cfg);
  EXPECT_EQ(makeMapPointPolicy(p, KeypointModel{})->model(), MapPointModel::Masking);
  cfg.write("PointModel", "model", "bogus");
  try {
    p.loadFromConfigFile(cfg);
    FAIL() << "bogus model accepted";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "[PointModel] model = bogus: must be one of heuristic, masking, probabilistic");
  }
}

TEST(MapPointPolicy, HeuristicFollowsOrbSlamCulling) {
  MapPointPolicyParams p;
  p.model = MapPointModel::Heuristic;
  const auto policy = makeMapPointPolicy(p, KeypointModel{});
  MapPointRecord r;
  r.counters = {10, 9, 3, 0, false};
  EXPECT_TRUE(policy->isActive(r));
  EXPECT_FALSE(policy->shouldCull(r, 5));
  r.counters.found = 2;  // 2/10 < 0.25
  EXPECT_TRUE(policy->shouldCull(r, 5));
  r.counters = {10, 9, 2, 0, false};  // only two keyframes see it ...
  EXPECT_FALSE(policy->shouldCull(r, 1));  // ... too early to tell
  EXPECT_TRUE(policy->shouldCull(r, 2));
}

TEST(MapPointPolicy, MaskingDeactivatesDynamicAndProbabilisticUsesInlierRatio) {
  const KeypointModel model{KeypointModelParams{}};
  MapPointPolicyParams p;
  p.model = MapPointModel::Masking;
  const auto masking = makeMapPointPolicy(p, model);
  p.model = MapPointModel::Probabilistic;
  const auto probabilistic = makeMapPointPolicy(p, model);
  MapPointRecord car;
  car.model = model.initialize(0.5, 1e-3);
  model.addSemanticObservation(car.model, {0.1, 0.85, 0.05}, 1.0);
  EXPECT_FALSE(masking->isActive(car));
  EXPECT_FALSE(probabilistic->isActive(car));
  // Consistent depth: the probabilistic model activates the parked car, masking never does.
  for (int i = 0; i < 30; ++i) model.updateDepth(car.model, 0.5, 1e-4, 1.0);
  EXPECT_TRUE(probabilistic->isActive(car));
  EXPECT_FALSE(masking->isActive(car));
  // Inconsistent depth: the probabilistic model culls it after enough evidence.
  MapPointRecord moving = car;
  moving.model = model.initialize(0.5, 1e-3);
  // Each outlier adds ~1 to b: without class evidence the point is static (a_sem = 5), so phi = (10 + 5) / (25 + n)
  // falls below 0.1 after ~125 of them.
  for (int i = 0; i < 160; ++i) model.updateDepth(moving.model, i % 2 ? 3.0 : 7.0, 1e-4, 1.0);
  EXPECT_TRUE(probabilistic->shouldCull(moving, 0));
  EXPECT_FALSE(probabilistic->shouldCull(car, 0));
}

// The shipped config reproduces the defaults (Table 3.1, Table 3.2), through the one [PointModel] section.
TEST(MapPointPolicy, ShippedKeypointModelIniLoads) {
  mrpt::config::CConfigFile cfg(std::string(PRIORSLAM_SOURCE_DIR) + "/config/semantic/keypoint_model.ini");
  PointModelParams pm;
  pm.loadFromConfigFile(cfg);
  const KeypointModelParams& k = pm.keypoint;
  const KeypointModelParams defaults;
  EXPECT_EQ(k.priorA, defaults.priorA);
  EXPECT_EQ(k.priorB[0], defaults.priorB[0]);
  EXPECT_EQ(k.priorB[1], defaults.priorB[1]);
  EXPECT_TRUE(std::isinf(k.priorB[2]));
  EXPECT_EQ(k.psiMin, 0.6);
  EXPECT_EQ(k.initialCount, defaults.initialCount);
  EXPECT_EQ(pm.matching.hammingMaxDistance, 100);
  EXPECT_EQ(pm.policy.model, MapPointModel::Probabilistic);
  EXPECT_EQ(pm.policy.maskingDynamicThreshold, 0.5);
}

// [PointModel]: the three structs flattened into one section; SLAM's default model is heuristic.
TEST(PointModelParams, OneSectionRoundTripAndHeuristicDefault) {
  EXPECT_EQ(PointModelParams{}.policy.model, MapPointModel::Heuristic);
  EXPECT_EQ(MapPointPolicyParams{}.model, MapPointModel::Probabilistic);
  PointModelParams p;
  p.policy.model = MapPointModel::Masking;
  p.keypoint.priorB[1] = std::numeric_limits<double>::infinity();
  p.keypoint.probabilityFloor = 1.0 / 510.0;
  p.matching.photometricMaxSsd = 1234.5;
  const std::string text = pslam::params::toIniText(p, "PointModel");
  for (const char* key : {"model = masking", "minFoundRatio", "psiMin", "A_static", "B_dynamic = inf",
                          "hammingMaxDistance", "photometricMaxSsd = 1234.5"})
    EXPECT_NE(text.find(key), std::string::npos) << key << " in\n" << text;
  mrpt::config::CConfigFileMemory cfg(text);
  PointModelParams q;
  q.loadFromConfigFile(cfg);
  EXPECT_EQ(q.policy.model, MapPointModel::Masking);
  EXPECT_TRUE(std::isinf(q.keypoint.priorB[1]));
  EXPECT_EQ(q.keypoint.probabilityFloor, 1.0 / 510.0);
  EXPECT_EQ(pslam::params::toIniText(q, "PointModel"), text);
  mrpt::config::CConfigFileMemory typo("[PointModel]\npsiMn = 0.5\n");
  try {
    q.loadFromConfigFile(typo);
    FAIL() << "typo accepted";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "[PointModel] psiMn: unknown key (did you mean psiMin?)");
  }
}
