// Local mapping on synthetic scenes with known geometry: keypoints are the exact projections of known 3D
// points, each point has its own random descriptor (one flipped bit per view) and keypoint angle.
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

TEST(LocalMappingParams, DefaultsAreOrbSlamAndBadValuesNameTheKey) {
  LocalMappingParams p;
  EXPECT_EQ(p.covisibleKeyFrames, 20);
  EXPECT_EQ(p.maxDescriptorDistance, 50);
  EXPECT_DOUBLE_EQ(p.nnRatio, 1.0);  // ORB-SLAM2 SearchForTriangulation: no ratio test
  EXPECT_EQ(p.ba.maxLocalKeyFrames, 20);
  EXPECT_EQ(p.pointModel.policy.model, landmarks::MapPointModel::Heuristic);
  EXPECT_DOUBLE_EQ(p.culling.redundantFraction, 0.9);
  EXPECT_EQ(p.culling.redundantMinObservers, 3);
  EXPECT_NO_THROW(p.check());
  mrpt::config::CConfigFileMemory cfg("[LocalMapping]\nnnRatio = 1.5\n");
  try {
    LocalMappingParams q;
    q.loadFromConfigFile(cfg, "LocalMapping");
    FAIL() << "nnRatio 1.5 accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "[LocalMapping] nnRatio = 1.5: must be in (0, 1]");
  }
  // Keys are the field names; the point model has its own section [PointModel].
  mrpt::config::CConfigFileMemory cfg2(
      "[LocalMapping]\ncovisibleKeyFrames = 7\nepipolarMinDistancePixels = 4\nfusionRadiusPixels = 2.5\n"
      "redundantFraction = 0.8\n");
  LocalMappingParams r;
  r.loadFromConfigFile(cfg2, "LocalMapping");
  EXPECT_EQ(r.covisibleKeyFrames, 7);
  EXPECT_EQ(r.epipolarMinDistancePixels, 4.0);
  EXPECT_EQ(r.fusionRadiusPixels, 2.5);
  EXPECT_EQ(r.culling.redundantFraction, 0.8);
  for (const char* moved : {"model = probabilistic", "covisibleKeyframes = 7", "fusionRadius = 3"}) {
    mrpt::config::CConfigFileMemory old(std::string("[LocalMapping]\n") + moved + "\n");
    EXPECT_THROW(r.loadFromConfigFile(old, "LocalMapping"), Error) << moved;
  }
  // ba and pointModel belong to other sections: not written here, checked under their own names.
  const std::string text = params::toIniText(r, "X");
  EXPECT_EQ(text.find("maxLocalKeyFrames"), std::string::npos) << text;
  EXPECT_EQ(text.find("model"), std::string::npos) << text;
  mrpt::config::CConfigFileMemory cfg3(text);
  LocalMappingParams s;
  s.loadFromConfigFile(cfg3, "X");
  EXPECT_EQ(s.covisibleKeyFrames, 7);
  EXPECT_EQ(params::toIniText(s, "X"), text);
  s.pointModel.keypoint.psiMin = 2;
  try {
    s.check();
    FAIL() << "psiMin 2 accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "[PointModel] psiMin = 2: must be in (0, 1)");
  }
}

TEST(KeypointStateCodec, RoundTripAndBadInput) {
  landmarks::KeypointState st;
  st.mu = 0.25;
  st.sigma2 = 0.01;
  st.aObs = 12.5;
  st.bObs = 9.0;
  st.semanticNll = {0.1, 2.0, 3.0};
  st.depthUpdates = 4;
  st.semanticUpdates = 2;
  const landmarks::KeypointState back = decodeKeypointState(encodeKeypointState(st), "p");
  EXPECT_EQ(back.mu, st.mu);
  EXPECT_EQ(back.sigma2, st.sigma2);
  EXPECT_EQ(back.aObs, st.aObs);
  EXPECT_EQ(back.semanticNll, st.semanticNll);
  EXPECT_EQ(back.depthUpdates, 4u);
  EXPECT_THROW(decodeKeypointState({1.0, 2.0}, "p"), Error);
  std::vector<double> v = encodeKeypointState(st);
  v[1] = std::nan("");
  EXPECT_THROW(decodeKeypointState(v, "p"), Error);
}

// Two keyframes share 40 tracked points; 200 further points are seen by both but unmatched.
TEST(LocalMapper, TriangulatesNewPointsAtTheTruthAnchoredInTheNewKeyFrame) {
  std::mt19937 rng(3);
  Scene s = makeScene(240, 11);
  map::Map map;
  addKeyFrame(map, s, 0, rng);
  const KeyFrameId kf1 = addKeyFrame(map, s, 2, rng);  // 0.5 m baseline
  s.keypointOf.resize(3);
  addTruePoints(map, s, 0, 40, 0, {0, 2});
  LocalMapper mapper(map, heuristicParams());
  const std::vector<MapPointId> created = mapper.createNewMapPoints(kf1);
  map.checkInvariants("after createNewMapPoints");

  int candidates = 0;
  for (int i = 40; i < 240; ++i) candidates += s.keypointOf[0][i] >= 0 && s.keypointOf[2][i] >= 0;
  ASSERT_GT(candidates, 100);
  EXPECT_GE(static_cast<int>(created.size()), candidates * 8 / 10) << "of " << candidates;
  const KeyFrame& kf = map.keyFrame(kf1);
  for (MapPointId id : created) {
    const map::MapPoint& p = map.mapPoint(id);
    ASSERT_EQ(p.anchorKeyFrame, kf1);
    const int i = sceneIndexOf(map, s, id);
    ASSERT_GE(i, 40) << "point " << id << " not anchored on a new scene point's keypoint";
    // The other observation is the same scene point (no wrong association).
    EXPECT_EQ(p.observations.at(s.keyframes[0]), static_cast<std::size_t>(s.keypointOf[0][i]));
    // Inverse-depth anchoring (eq. 3.1): rho = 1 / distance from the anchor centre, bearing = keypoint ray.
    const double trueDistance = (s.points[i] - kf.cameraCenter()).norm();
    EXPECT_NEAR(1.0 / p.inverseDepth, trueDistance, 2e-3 * trueDistance);
    EXPECT_LT((p.bearing - kf.camera.unprojectToBearing(kf.pixel(p.anchorKeypoint))).norm(), 1e-6);
    EXPECT_LT((map.worldPosition(id) - s.points[i]).norm(), 2e-3 * trueDistance);
  }
  EXPECT_EQ(mapper.recentPoints().size(), created.size());
}

// 0.5 px keypoint noise: the checks keep most points and the depth error follows the first-order bound
// sigma_z / z = z * sqrt(2) * sigma_px / (f * baseline) (eq. 2.24-2.29 in its simplest form).
TEST(LocalMapper, TriangulationWithPixelNoiseMeetsTheFirstOrderDepthError) {
  std::mt19937 rng(13);
  Scene s = makeScene(300, 20);
  s.pixelNoise = 0.5;
  map::Map map;
  addKeyFrame(map, s, 0, rng);
  const KeyFrameId kf1 = addKeyFrame(map, s, 2, rng);
  addTruePoints(map, s, 0, 40, 0, {0, 2});
  LocalMapper mapper(map, heuristicParams());
  const std::vector<MapPointId> created = mapper.createNewMapPoints(kf1);
  int candidates = 0;
  for (int i = 40; i < 300; ++i) candidates += s.keypointOf[0][i] >= 0 && s.keypointOf[2][i] >= 0;
  EXPECT_GE(static_cast<int>(created.size()), candidates * 8 / 10) << "of " << candidates;
  const KeyFrame& kf = map.keyFrame(kf1);
  const double baseline = (kf.cameraCenter() - map.keyFrame(s.keyframes[0]).cameraCenter()).norm();
  std::vector<double> normalized;  // |depth error| / predicted sigma
  for (MapPointId id : created) {
    const int i = sceneIndexOf(map, s, id);
    ASSERT_GE(i, 40);
    const double z = (kf.T_cam_world * s.points[i]).z();
    const double sigmaZ = z * z * std::sqrt(2.0) * s.pixelNoise / (kf.camera.fx * baseline);
    normalized.push_back(std::abs((kf.T_cam_world * map.worldPosition(id)).z() - z) / sigmaZ);
  }
  ASSERT_FALSE(normalized.empty());
  std::sort(normalized.begin(), normalized.end());
  std::printf("created %zu of %d, median %.3f, p95 %.3f\n", created.size(), candidates, normalized[normalized.size() / 2], normalized[normalized.size() * 95 / 100]);
  // For a Gaussian error the median |e| / sigma is 0.674 and the 95 % quantile 1.96.
  EXPECT_LT(normalized[normalized.size() / 2], 1.0);
  EXPECT_LT(normalized[normalized.size() * 95 / 100], 3.0);
}

// Two scene points on the same epipolar line (same height and depth, 0.3 m apart). With the same descriptor
// the match is ambiguous and the optional ratio test (nnRatio = 0.6) must reject both; with distinct descriptors (control)
// both are triangulated.
TEST(LocalMapper, AmbiguousEpipolarCandidatesFailTheRatioTest) {
  for (const bool sameDescriptor : {true, false}) {
    std::mt19937 rng(3);
    Scene s = makeScene(240, 11);
    s.points[100] = Eigen::Vector3d(0.5, 0.4, 6.0);
    s.points[101] = s.points[100] + Eigen::Vector3d(0.3, 0.0, 0.0);
    if (sameDescriptor) s.descriptors[101] = s.descriptors[100].clone();
    map::Map map;
    addKeyFrame(map, s, 0, rng);
    const KeyFrameId kf1 = addKeyFrame(map, s, 2, rng);
    for (int slot : {0, 2})
      for (int i : {100, 101}) ASSERT_GE(s.keypointOf[slot][i], 0);
    addTruePoints(map, s, 0, 40, 0, {0, 2});
    LocalMappingParams params = heuristicParams();
    params.nnRatio = 0.6;  // the optional ratio test (off by default, as ORB-SLAM2)
    LocalMapper mapper(map, params);
    const std::vector<MapPointId> created = mapper.createNewMapPoints(kf1);
    EXPECT_GT(created.size(), 150u);
    int ambiguousCreated = 0;
    for (MapPointId id : created) {
      const int i = sceneIndexOf(map, s, id);
      ambiguousCreated += i == 100 || i == 101;
    }
    EXPECT_EQ(ambiguousCreated, sameDescriptor ? 0 : 2);
  }
}

TEST(LocalMapper, NoTriangulationWithoutBaseline) {
  std::mt19937 rng(3);
  Scene s = makeScene(120, 12);
  map::Map map;
  addKeyFrame(map, s, 0, rng);
  // Same pose twice: baseline 0.
  KeyFrame copy = map.keyFrame(s.keyframes[0]);
  const KeyFrameId kf1 = map.addKeyFrame(copy);
  s.keyframes.push_back(kf1);
  s.keypointOf.push_back(s.keypointOf[0]);
  addTruePoints(map, s, 0, 40, 0, {0, 1});
  LocalMapper mapper(map, heuristicParams());
  EXPECT_TRUE(mapper.createNewMapPoints(kf1).empty());
}

// Point i exists twice: A (anchored in slot 0, seen by 0 and 1) and B (anchored in slot 2, seen by 2 only).
TEST(LocalMapper, SearchInNeighborsFusesDuplicates) {
  std::mt19937 rng(5);
  Scene s = makeScene(100, 13);
  map::Map map;
  for (int slot = 0; slot < 3; ++slot) addKeyFrame(map, s, slot, rng);
  addTruePoints(map, s, 0, 50, 0, {0, 1, 2});
  addTruePoints(map, s, 50, 100, 0, {0, 1});
  std::vector<MapPointId> duplicates;
  for (int i = 50; i < 100; ++i) {
    const int k = s.keypointOf[2][i];
    if (k < 0 || s.mapPointOf[i] == map::kNoMapPoint) continue;
    // Slightly off the truth, as a second triangulation would be.
    const MapPointId b = map.addMapPoint(s.keyframes[2], k, s.points[i] + Eigen::Vector3d(0.002, -0.001, 0.003));
    map.computeDistinctiveDescriptor(b);
    map.updateNormalAndDepth(b);
    duplicates.push_back(b);
  }
  ASSERT_GT(duplicates.size(), 20u);
  const std::size_t before = map.numMapPoints();
  LocalMapper mapper(map, heuristicParams());
  const int fused = mapper.searchInNeighbors(s.keyframes[2]);
  map.checkInvariants("after searchInNeighbors");
  EXPECT_EQ(fused, static_cast<int>(duplicates.size()));
  EXPECT_EQ(map.numMapPoints(), before - duplicates.size());
  for (MapPointId b : duplicates) EXPECT_FALSE(map.hasMapPoint(b));
  for (int i = 50; i < 100; ++i) {
    if (s.keypointOf[2][i] < 0 || s.mapPointOf[i] == map::kNoMapPoint) continue;
    const map::MapPoint& a = map.mapPoint(s.mapPointOf[i]);  // the better-observed one is kept
    EXPECT_EQ(a.observations.at(s.keyframes[2]), static_cast<std::size_t>(s.keypointOf[2][i]));
  }
}

TEST(LocalMapper, CullsRecentPointsWithLowFoundRatioOrFewObservers) {
  std::mt19937 rng(7);
  Scene s = makeScene(80, 14);
  map::Map map;
  for (int slot = 0; slot < 4; ++slot) addKeyFrame(map, s, slot, rng);
  // Points created in keyframe 0: 0-29 seen by all 4 (healthy), 30-49 only by 0 and 1 (too few observers
  // after two keyframes), 50-79 seen by all but with a low found/visible ratio.
  const auto healthy = addTruePoints(map, s, 0, 30, 0, {0, 1, 2, 3});
  const auto fewObservers = addTruePoints(map, s, 30, 50, 0, {0, 1});
  const auto lowRatio = addTruePoints(map, s, 50, 80, 0, {0, 1, 2, 3});
  for (MapPointId id : lowRatio) {
    map.mutableMapPoint(id).visibleCount = 10;
    map.mutableMapPoint(id).foundCount = 2;  // 0.2 < 0.25
  }
  for (MapPointId id : healthy) {
    map.mutableMapPoint(id).visibleCount = 10;
    map.mutableMapPoint(id).foundCount = 3;  // 0.3
  }
  std::vector<MapPointId> all = healthy;
  all.insert(all.end(), fewObservers.begin(), fewObservers.end());
  all.insert(all.end(), lowRatio.begin(), lowRatio.end());
  LocalMapper mapper(map, heuristicParams());
  mapper.processNewKeyFrame(s.keyframes[3], all);
  const int culled = mapper.cullRecentPoints(s.keyframes[2]);  // keyframe id 2: 2 keyframes after creation
  map.checkInvariants("after cullRecentPoints");
  EXPECT_EQ(culled, static_cast<int>(fewObservers.size() + lowRatio.size()));
  for (MapPointId id : healthy) EXPECT_TRUE(map.hasMapPoint(id));
  for (MapPointId id : fewObservers) EXPECT_FALSE(map.hasMapPoint(id));
  for (MapPointId id : lowRatio) EXPECT_FALSE(map.hasMapPoint(id));
  // One keyframe earlier the observer rule does not apply yet.
  map::Map map2;
  Scene s2 = makeScene(80, 14);
  std::mt19937 rng2(7);
  for (int slot = 0; slot < 2; ++slot) addKeyFrame(map2, s2, slot, rng2);
  const auto young = addTruePoints(map2, s2, 30, 50, 0, {0, 1});
  LocalMapper mapper2(map2, heuristicParams());
  mapper2.processNewKeyFrame(s2.keyframes[1], young);
  EXPECT_EQ(mapper2.cullRecentPoints(s2.keyframes[1]), 0);
}

TEST(LocalMapper, CullsARedundantKeyFrameButNeverTheFirstTwo) {
  std::mt19937 rng(9);
  Scene s = makeScene(90, 15);
  map::Map map;
  for (int slot = 0; slot < 5; ++slot) addKeyFrame(map, s, slot, rng);
  // 0-59 seen by every keyframe: redundant everywhere. 60-89 seen only by slots 3 and 4.
  addTruePoints(map, s, 0, 60, 0, {0, 1, 2, 3, 4});
  addTruePoints(map, s, 60, 90, 3, {3, 4});
  int unique3 = 0;
  for (int i = 60; i < 90; ++i) unique3 += s.keypointOf[3][i] >= 0;
  ASSERT_GT(unique3, 10);
  LocalMapper mapper(map, heuristicParams());
  const int culled = mapper.cullKeyFrames(s.keyframes[4]);
  map.checkInvariants("after cullKeyFrames");
  EXPECT_EQ(culled, 1);
  EXPECT_FALSE(map.hasKeyFrame(s.keyframes[2]));
  EXPECT_TRUE(map.hasKeyFrame(s.keyframes[0]));
  EXPECT_TRUE(map.hasKeyFrame(s.keyframes[1]));
  EXPECT_TRUE(map.hasKeyFrame(s.keyframes[3]));  // its own points are seen by one other keyframe only
  EXPECT_TRUE(map.hasKeyFrame(s.keyframes[4]));
}

// Six keyframes see 150 points; the window is the newest keyframe and its 2 best neighbours, the other
// three are fixed (they fix the monocular gauge, scale included). Inverse depths and the newest pose are perturbed,
// the pixels are exact: BA must bring the reprojection error and the 3D error down.
TEST(LocalMapper, LocalBundleAdjustmentReducesReprojectionError) {
  std::mt19937 rng(21);
  Scene s = makeScene(150, 16);
  map::Map map;
  for (int slot = 0; slot < 6; ++slot) addKeyFrame(map, s, slot, rng);
  const auto ids = addTruePoints(map, s, 0, 150, 0, {0, 1, 2, 3, 4, 5});
  // Points have one degree of freedom (eq. 3.1: the ray of the anchor keypoint is fixed), so the error is
  // put into the inverse depth.
  std::normal_distribution<double> n(0.0, 0.05);
  for (MapPointId id : ids) map.setInverseDepth(id, map.mapPoint(id).inverseDepth * (1.0 + n(rng)));
  Eigen::Isometry3d T = map.keyFrame(s.keyframes[5]).T_cam_world;
  T.translation() += Eigen::Vector3d(0.02, -0.01, 0.01);
  map.setKeyFramePose(s.keyframes[5], T);
  auto meanError = [&] {
    double e = 0;
    int count = 0;
    for (int i = 0; i < 150; ++i)
      if (s.mapPointOf[i] != map::kNoMapPoint && map.hasMapPoint(s.mapPointOf[i])) {
        e += (map.worldPosition(s.mapPointOf[i]) - s.points[i]).norm();
        ++count;
      }
    return e / count;
  };
  const double before = meanError();
  LocalMappingParams params = heuristicParams();
  params.ba.maxLocalKeyFrames = 3;
  LocalMapper mapper(map, params);
  optimize::BAResult result;
  mapper.runLocalBundleAdjustment(s.keyframes[5], &result);
  map.checkInvariants("after local BA");
  EXPECT_GT(result.initialRmsPixels, 1.0);
  EXPECT_LT(result.finalRmsPixels, 0.1 * result.initialRmsPixels)
      << result.initialRmsPixels << " -> " << result.finalRmsPixels;
  EXPECT_LT(meanError(), 0.5 * before) << before << " -> " << meanError();
  EXPECT_LT((map.keyFrame(s.keyframes[5]).cameraCenter() - poseOf(5).inverse().translation()).norm(), 0.01);
}

namespace {
/// A factor with a constant residual `value` on one keyframe (chi2 threshold 1): an outlier when |value| > 1.
struct ConstantResidual {
  double value;
  template <typename T>
  bool operator()(const T* /*pose*/, const T* /*x*/, T* r) const {
    r[0] = T(value);
    return true;
  }
};
class ConstantFactor : public optimize::BAFactor {
 public:
  ConstantFactor(map::KeyFrameId kf, double value) : kf_(kf), value_(value) {}
  std::string kind() const override { return "constant"; }
  std::vector<map::KeyFrameId> keyframes() const override { return {kf_}; }
  std::vector<double*> landmarkBlocks() const override { return {&x_}; }
  ceres::CostFunction* newCostFunction() const override {
    return new ceres::AutoDiffCostFunction<ConstantResidual, 1, optimize::kPoseSize, 1>(new ConstantResidual{value_});
  }
  bool landmarkFixed() const override { return true; }
  double huberDelta() const override { return 1.0; }
  double chi2Threshold() const override { return 1.0; }

 private:
  map::KeyFrameId kf_;
  double value_;
  mutable double x_ = 0.0;
};
}  // namespace

/// A BA factor source that returns fixed factors and keeps the flags it is given (and how many factors the problem
/// held when it was asked).
class RecordingSource : public optimize::BAFactorSource {
 public:
  explicit RecordingSource(std::vector<std::shared_ptr<optimize::BAFactor>> factors) : factors_(std::move(factors)) {}
  std::vector<std::shared_ptr<optimize::BAFactor>> bundleAdjustmentFactors(const map::Map&,
                                                                          const optimize::BAProblem& problem) override {
    factorsBefore = problem.factors.size();
    return factors_;
  }
  void afterBundleAdjustment(const std::vector<bool>& outliers) override { flags = outliers; }
  std::size_t factorsBefore = 0;
  std::vector<bool> flags;

 private:
  std::vector<std::shared_ptr<optimize::BAFactor>> factors_;
};

TEST(LocalMapper, EveryBAFactorSourceGetsTheOutlierFlagsOfItsOwnFactors) {
  std::mt19937 rng(21);
  Scene s = makeScene(150, 16);
  map::Map map;
  for (int slot = 0; slot < 6; ++slot) addKeyFrame(map, s, slot, rng);
  addTruePoints(map, s, 0, 150, 0, {0, 1, 2, 3, 4, 5});
  LocalMappingParams params = heuristicParams();
  params.ba.maxLocalKeyFrames = 3;
  LocalMapper mapper(map, params);
  const map::KeyFrameId kf = s.keyframes[5];
  auto first = std::make_shared<RecordingSource>(std::vector<std::shared_ptr<optimize::BAFactor>>{
      std::make_shared<ConstantFactor>(kf, 0.1), std::make_shared<ConstantFactor>(kf, 10.0)});
  auto second = std::make_shared<RecordingSource>(
      std::vector<std::shared_ptr<optimize::BAFactor>>{std::make_shared<ConstantFactor>(kf, 5.0)});
  mapper.addBAFactorSource(first);
  mapper.addBAFactorSource(second);
  mapper.runLocalBundleAdjustment(kf);
  EXPECT_EQ(first->factorsBefore, 0u);
  EXPECT_EQ(second->factorsBefore, 2u) << "the first source's factors come first";
  EXPECT_EQ(first->flags, (std::vector<bool>{false, true}));
  EXPECT_EQ(second->flags, (std::vector<bool>{true}));
}

TEST(LocalMapper, SequenceKeepsInvariantsGrowsAnAccurateMapAndIsDeterministic) {
  std::vector<LocalMappingReport> r1, r2;
  Scene s;
  const map::Map a = runSequence(heuristicParams(), 6, &r1, &s);
  const map::Map b = runSequence(heuristicParams(), 6, &r2);
  EXPECT_TRUE(a == b) << "same input gave different maps";
  int created = 0;
  for (const auto& r : r1) {
    created += r.newPoints;
    EXPECT_EQ(r.landmarkUpdates, 0);  // heuristic = ORB-SLAM*: the keypoint model is not involved
  }
  for (const auto& [id, p] : a.mapPoints()) EXPECT_TRUE(p.landmarkState.empty()) << "point " << id;
  EXPECT_GT(created, 100);
  EXPECT_GT(a.numMapPoints(), 160u);
  // Every point is at its scene point (exact pixels: triangulation and BA keep it there).
  int checked = 0;
  std::vector<int> mapPointsOfScene(s.points.size(), 0);
  for (const auto& [id, p] : a.mapPoints()) {
    const int i = sceneIndexOf(a, s, id);
    ASSERT_GE(i, 0);
    EXPECT_EQ(++mapPointsOfScene[i], 1) << "scene point " << i << " mapped twice";
    EXPECT_LT((a.worldPosition(id) - s.points[i]).norm(), 0.01) << "point " << id;
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

// Threaded mode: the triangulation search runs on copies of the keyframe pair and the BA solve on its problem,
// outside the map lock. With a runner that only runs them, the map is the sequential one bit for bit.
TEST(LocalMapper, ComputationsOutsideTheMapLockGiveTheSequentialMap) {
  for (const auto model : {landmarks::MapPointModel::Heuristic, landmarks::MapPointModel::Probabilistic}) {
    LocalMappingParams params = heuristicParams();
    params.pointModel.policy.model = model;
    std::vector<LocalMappingReport> r1, r2;
    int calls = 0;
    const map::Map inPlace = runSequence(params, 6, &r1);
    const map::Map outside = runSequence(params, 6, &r2, nullptr, [&](const std::function<void()>& computation) {
      ++calls;
      computation();
      return true;
    });
    EXPECT_TRUE(inPlace == outside) << "the computations on copies changed the map";
    // Slots 2..5 each search their covisible keyframes and solve one local BA; slot 1 has its BA too.
    EXPECT_GE(calls, 4 * 2 + 1);
    for (const auto& r : r2) EXPECT_FALSE(r.mapChanged);
  }
}

// A reset of the map while a computation runs outside the lock (the runner says so by returning false) stops the
// keyframe's mapping there: nothing computed for the old map is written into whatever map there is now.
TEST(LocalMapper, AMapResetWhileOutsideTheLockStopsTheKeyFrame) {
  const auto prefix = [](map::Map& map, Scene& s, std::mt19937& rng, LocalMapper& mapper) {
    addKeyFrame(map, s, 0, rng);
    addKeyFrame(map, s, 1, rng);
    const auto initial = addTruePoints(map, s, 0, 60, 0, {0, 1});
    mapper.processKeyFrame(s.keyframes[0], {});
    mapper.processKeyFrame(s.keyframes[1], initial);
    learnMapPoints(map, s);
    for (int slot = 2; slot < 5; ++slot) {
      addKeyFrame(map, s, slot, rng);
      trackKeyFrame(map, s, slot);
      mapper.processKeyFrame(s.keyframes[slot], {});
      learnMapPoints(map, s);
    }
    addKeyFrame(map, s, 5, rng);
    trackKeyFrame(map, s, 5);
  };
  // How many computations slot 5 runs outside the lock (the last one is its local BA).
  int total = 0;
  {
    std::mt19937 rng(31);
    Scene s = makeScene(300, 17);
    map::Map map;
    LocalMapper mapper(map, heuristicParams());
    prefix(map, s, rng, mapper);
    mapper.setOutsideMapLock([&](const std::function<void()>& c) {
      ++total;
      c();
      return true;
    });
    mapper.processKeyFrame(s.keyframes[5], {});
  }
  ASSERT_GE(total, 2);
  for (const int failAt : {1, total}) {
    std::mt19937 rng(31);
    Scene s = makeScene(300, 17);
    map::Map map;
    LocalMapper mapper(map, heuristicParams());
    prefix(map, s, rng, mapper);
    const map::Map before = map;
    int calls = 0;
    mapper.setOutsideMapLock([&](const std::function<void()>& c) {
      c();
      return ++calls != failAt;  // the map was "reset" while this computation ran
    });
    const LocalMappingReport r = mapper.processKeyFrame(s.keyframes[5], {});
    EXPECT_TRUE(r.mapChanged) << "fail at " << failAt;
    EXPECT_EQ(calls, failAt) << "no computation after the reset";
    EXPECT_EQ(r.fusedPoints, 0);
    EXPECT_EQ(r.culledKeyFrames, 0);
    if (failAt == 1) {
      EXPECT_EQ(r.newPoints, 0) << "a point of the first pair's search was created in a reset map";
      // Only the point culling before triangulation changed the map.
      EXPECT_EQ(map.numMapPoints() + static_cast<std::size_t>(r.culledPoints), before.numMapPoints());
    } else {
      // The BA result is dropped: every keyframe is where triangulation and fusion left it.
      EXPECT_GT(r.newPoints, 0);
      EXPECT_EQ(r.baObservationsErased, 0);
      for (const auto& [id, kf] : before.keyFrames())
        EXPECT_TRUE(map.keyFrame(id).T_cam_world.isApprox(kf.T_cam_world, 0.0)) << "keyframe " << id << " moved";
    }
  }
}

}  // namespace
}  // namespace pslam::mapping
