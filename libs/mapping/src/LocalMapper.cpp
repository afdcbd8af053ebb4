// ORB-SLAM's LocalMapping::Run for one keyframe (thesis §2.4.1, §3.4.3). Step order and constants follow
// ORB-SLAM2's LocalMapping.cc / ORBmatcher.cc (monocular); differences are listed in doc/mapping.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include <Eigen/Dense>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/features/FeatureGrid.h"
#include "pslam/features/Matching.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/landmarks/MeasurementVariance.h"
#include "pslam/mapping/LocalMapper.h"

#include "pslam/map/KeyFrameCulling.h"

namespace pslam::mapping {

using map::KeyFrame;
using map::KeyFrameId;
using map::MapPoint;
using map::MapPointId;

namespace {

using Clock = std::chrono::steady_clock;

/// Median z of the keyframe's points in its own camera (ORB-SLAM ComputeSceneMedianDepth(2)); -1 if none.
double sceneMedianDepth(const map::Map& map, const KeyFrame& kf) {
  std::vector<double> z;
  for (MapPointId p : kf.mapPointIds)
    if (p != map::kNoMapPoint) z.push_back((kf.T_cam_world * map.worldPosition(p)).z());
  if (z.empty()) return -1.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}


}  // namespace

struct LocalMapper::Impl {
  /// The map-point model of params.pointModel.policy (keypoint-model updates read its KeypointModel).
  std::shared_ptr<const MapPointModelPolicy> modelPolicy;
  /// What culling and the BA window ask: modelPolicy unless the caller supplied its own.
  std::shared_ptr<const map::PointUsePolicy> usePolicy;
};

LocalMapper::LocalMapper(map::Map& map, const LocalMappingParams& params,
                         std::shared_ptr<const map::PointUsePolicy> pointUsePolicy)
    : map_(map), params_(params), impl_(std::make_unique<Impl>()) {
  params_.check();
  impl_->modelPolicy = std::make_shared<MapPointModelPolicy>(params_.pointModel, params_.depthPixelNoise);
  impl_->usePolicy = pointUsePolicy ? std::move(pointUsePolicy) : impl_->modelPolicy;
}

LocalMapper::~LocalMapper() = default;

void LocalMapper::reset() { recent_.clear(); }

void LocalMapper::addBAFactorSource(std::shared_ptr<optimize::BAFactorSource> source) {
  require(source != nullptr, "LocalMapper", "null BA factor source");
  baSources_.push_back(std::move(source));
}

landmarks::MapPointModel LocalMapper::model() const { return params_.pointModel.policy.model; }

bool LocalMapper::isActive(MapPointId point) const { return impl_->usePolicy->mayUse(map_.mapPoint(point)); }

std::shared_ptr<const map::PointUsePolicy> LocalMapper::pointUsePolicy() const { return impl_->usePolicy; }

// ------------------------------------------------------------------------------------ probabilistic hook

/// Updates the keypoint model of `pointId` with its observation in keyframe `kfId` (§3.4.2, see
/// MapPointModelPolicy::observe); the anchor's own observation carries no depth, only its class evidence.
/// Returns true if a depth update was applied.
static bool updateLandmarkState(map::Map& map, const MapPointModelPolicy& policy, MapPointId pointId, KeyFrameId kfId) {
  MapPoint& p = map.mutableMapPoint(pointId);
  const KeyFrame& kf = map.keyFrame(kfId);
  const std::size_t k = p.observations.at(kfId);
  const std::array<float, 3>* classes = kf.semanticProbabilities.empty() ? nullptr : &kf.semanticProbabilities.at(k);
  if (kfId != p.anchorKeyFrame) {
    map::PointMeasurement m;
    m.T_cam_world = kf.T_cam_world;
    m.camera = kf.camera;
    m.pixel = kf.pixel(k);
    if (!kf.descriptors.empty()) m.descriptor = kf.descriptors.row(static_cast<int>(k));
    m.classProbabilities = classes;
    return policy.observe(map, p, m);
  }
  // The anchor's class evidence, once; without any (no semantics) only a point without a stored state gets one.
  landmarks::KeypointState state = policy.stateOf(p);
  const std::optional<landmarks::ClassVector> evidence = policy.classEvidence(classes);
  if (state.semanticUpdates == 0 && (evidence || p.landmarkState.empty())) {
    policy.keypointModel().addSemanticObservation(state, evidence, 1.0);
    p.landmarkState = encodeKeypointState(state);
  }
  return false;
}

// ------------------------------------------------------------------------------------ 1. ProcessNewKeyFrame

void LocalMapper::processNewKeyFrame(KeyFrameId kfId, const std::vector<MapPointId>& recentlyAddedByTracking,
                                     bool measuredByTracking) {
  if (!map_.hasKeyFrame(kfId)) throw Error("LocalMapper: keyframe " + std::to_string(kfId) + " is not in the map");
  for (MapPointId id : map_.pointsOf(kfId)) {
    if (map_.mapPoint(id).bad) continue;
    // The model update first: alpha compares the keypoint with the descriptor the tracker matched against.
    // A keyframe the tracker measured (Tracker::track updates every point it matched) is not counted twice.
    if (model() != landmarks::MapPointModel::Heuristic && !measuredByTracking &&
        updateLandmarkState(map_, *impl_->modelPolicy, id, kfId))
      ++landmarkUpdates_;
    map_.updateNormalAndDepth(id);
    map_.computeDistinctiveDescriptor(id);
  }
  // Covisibility weights are kept by Map::addObservation; the spanning tree link is made once.
  map_.connectToSpanningTree(kfId);
  std::set<MapPointId> recent(recent_.begin(), recent_.end());
  for (MapPointId id : recentlyAddedByTracking)
    if (map_.hasMapPoint(id)) recent.insert(id);
  recent_.assign(recent.begin(), recent.end());
}

// ------------------------------------------------------------------------------------ 2. MapPointCulling

int LocalMapper::cullRecentPoints(KeyFrameId kfId, int* byInlierRatio) {
  int culled = 0;
  if (byInlierRatio) *byInlierRatio = 0;
  const auto current = static_cast<std::int64_t>(kfId);
  std::vector<MapPointId> stillRecent;
  for (MapPointId id : recent_) {
    if (!map_.hasMapPoint(id)) continue;  // fused or erased meanwhile
    const MapPoint& p = map_.mapPoint(id);
    const bool cull = impl_->usePolicy->shouldCull(p, kfId);
    if (cull) {
      map_.eraseMapPoint(id);
      ++culled;
      continue;
    }
    // ORB-SLAM: a point that survived three keyframes leaves probation.
    if (current - static_cast<std::int64_t>(p.firstKeyFrame) >= params_.pointModel.policy.observationWindow + 1) continue;
    stillRecent.push_back(id);
  }
  recent_ = std::move(stillRecent);
  // Probabilistic model: phi needs several depth updates (cullMinDepthUpdates) before the policy may cull, more
  // than ORB-SLAM's three-keyframe probation, so every point the keyframe just measured is checked by the
  // model's own rule as well (ORB-SLAM's rules stay with the recent points).
  if (model() == landmarks::MapPointModel::Probabilistic && map_.hasKeyFrame(kfId))
    for (MapPointId id : map_.pointsOf(kfId)) {
      if (!map_.hasMapPoint(id)) continue;
      const MapPoint& p = map_.mapPoint(id);
      if (p.bad || impl_->modelPolicy->inlierRatioSaysCull(p)) {
        map_.eraseMapPoint(id);
        ++culled;
        if (byInlierRatio) ++*byInlierRatio;
      }
    }
  return culled;
}

// ------------------------------------------------------------------------------------ 3. CreateNewMapPoints


std::vector<MapPointId> LocalMapper::createNewMapPoints(KeyFrameId kfId) {
  std::vector<MapPointId> created;
  std::vector<KeyFrameId> neighbours =
      map_.bestCovisibleKeyFrames(kfId, static_cast<std::size_t>(params_.covisibleKeyFrames));
  if (static_cast<int>(neighbours.size()) < params_.minTriangulationNeighbours) {
    const std::set<KeyFrameId> have(neighbours.begin(), neighbours.end());
    for (auto it = map_.keyFrames().rbegin();
         it != map_.keyFrames().rend() && static_cast<int>(neighbours.size()) < params_.minTriangulationNeighbours; ++it)
      if (it->first != kfId && !have.count(it->first)) neighbours.push_back(it->first);
  }
  // Threaded mode: one copy of the new keyframe for every pair's search (its free keypoints refreshed per pair).
  std::optional<KeyFrame> copy1;
  for (KeyFrameId nId : neighbours) {
    const KeyFrame& kf1 = map_.keyFrame(kfId);
    const KeyFrame& kf2 = map_.keyFrame(nId);
    if (kf1.descriptors.empty() || kf2.descriptors.empty()) continue;
    const Eigen::Vector3d O1 = kf1.cameraCenter(), O2 = kf2.cameraCenter();
    const double medianDepth2 = sceneMedianDepth(map_, kf2);
    if (medianDepth2 <= 0.0 || (O2 - O1).norm() / medianDepth2 < params_.minBaselineRatio) continue;

    const Eigen::Matrix3d K1 = kf1.camera.K(), K2 = kf2.camera.K();
    const Eigen::Matrix3d R1 = kf1.T_cam_world.linear(), R2 = kf2.T_cam_world.linear();
    const Eigen::Vector3d t1 = kf1.T_cam_world.translation(), t2 = kf2.T_cam_world.translation();
    const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(K1, R1, t1, K2, R2, t2);
    std::vector<PairMatch> matches;
    if (!outsideMapLock_) {
      matches = searchForTriangulation(kf1, kf2, F12, params_, triangulationSearch_, params_.triangulationThreads);
    } else {
      // The search (most of this step's time) runs outside the map lock on copies of the two keyframes, taken
      // with the lock held: tracking may insert a keyframe and link observations (covisibility) meanwhile.
      // Only this mapper binds keypoints of kf1 and kf2, so the free keypoints the copies show are still free.
      // The previous pairs' new points bound keypoints of kf1: only its keypoint-to-point links change.
      if (!copy1)
        copy1 = kf1;
      else
        copy1->mapPointIds = kf1.mapPointIds;
      const KeyFrame copy2 = kf2;
      const int threads = params_.triangulationThreads;
      if (!runOutsideMapLock(
              [&] { matches = searchForTriangulation(*copy1, copy2, F12, params_, triangulationSearch_, threads); }))
        return {};  // the map was reset: kfId is gone
    }
    const geometry::Matrix34d P1 = geometry::projectionMatrix(K1, R1, t1), P2 = geometry::projectionMatrix(K2, R2, t2);
    const double ratioFactor = params_.scaleConsistencyFactor * kf1.scaleFactors.at(std::min(1, kf1.numLevels() - 1));

    for (const PairMatch& m : matches) {
      const cv::KeyPoint& kp1 = kf1.keypoints[m.i1];
      const cv::KeyPoint& kp2 = kf2.keypoints[m.i2];
      // Parallax of the two rays (ORB-SLAM cosParallaxRays): too small and the DLT is ill-conditioned.
      const Eigen::Vector3d ray1 = R1.transpose() * kf1.camera.unprojectToBearing(kf1.pixel(m.i1));
      const Eigen::Vector3d ray2 = R2.transpose() * kf2.camera.unprojectToBearing(kf2.pixel(m.i2));
      const double cosParallaxRays = ray1.dot(ray2);
      if (!(cosParallaxRays > 0.0 && cosParallaxRays < params_.maxParallaxCos)) continue;
      Eigen::Vector3d X;
      if (!geometry::triangulateDLT(P1, kf1.pixel(m.i1), P2, kf2.pixel(m.i2), X)) continue;
      if (!geometry::hasPositiveDepth(R1, t1, X) || !geometry::hasPositiveDepth(R2, t2, X)) continue;
      // Reprojection chi2 (2 DoF, 5.991) with each keypoint's level variance.
      const double sigma1 = kf1.levelSigma2.at(kp1.octave), sigma2 = kf2.levelSigma2.at(kp2.octave);
      if (!geometry::passesReprojectionTest(geometry::reprojectionErrorSquared(K1, R1, t1, X, kf1.pixel(m.i1)),
                                            sigma1, params_.chi2Threshold) ||
          !geometry::passesReprojectionTest(geometry::reprojectionErrorSquared(K2, R2, t2, X, kf2.pixel(m.i2)),
                                            sigma2, params_.chi2Threshold))
        continue;
      // Scale consistency: the distance ratio must agree with the octave ratio within ratioFactor.
      const double dist1 = (X - O1).norm(), dist2 = (X - O2).norm();
      if (dist1 <= 0.0 || dist2 <= 0.0) continue;
      const double ratioDist = dist2 / dist1;
      const double ratioOctave = kf1.scaleFactors.at(kp1.octave) / kf2.scaleFactors.at(kp2.octave);
      if (ratioDist * ratioFactor < ratioOctave || ratioDist > ratioOctave * ratioFactor) continue;

      // Inverse-depth point (eq. 3.1) anchored in the keypoint of the NEW keyframe, as ORB-SLAM's
      // reference keyframe of a point created here.
      if (kf1.mapPointIds[m.i1] != map::kNoMapPoint || kf2.mapPointIds[m.i2] != map::kNoMapPoint) continue;
      const MapPointId id = map_.addMapPoint(kfId, m.i1, X);
      map_.addObservation(id, nId, m.i2);
      map_.computeDistinctiveDescriptor(id);
      map_.updateNormalAndDepth(id);
      if (model() != landmarks::MapPointModel::Heuristic) {
        // Seed of the keypoint model: the triangulated inverse depth with the eq. 2.24-2.29 variance of
        // this pair (SVO's spread if the pair gives none).
        MapPoint& p = map_.mutableMapPoint(id);
        const Eigen::Vector3d t_ref_cur = kf1.T_cam_world * O2;
        const landmarks::DepthUncertainty tau =
            t_ref_cur.norm() > 0.0 ? landmarks::depthUncertainty(p.bearing, 1.0 / p.inverseDepth, t_ref_cur,
                                                                 kf1.camera.fx, params_.depthPixelNoise)
                                   : landmarks::DepthUncertainty{};
        const double variance = tau.valid && tau.tau2InverseDepth() > 0.0 ? tau.tau2InverseDepth()
                                                                          : initialInverseDepthVariance(params_.pointModel.keypoint);
        landmarks::KeypointState state = impl_->modelPolicy->keypointModel().initialize(p.inverseDepthAlongZ(), variance);
        const MapPointModelPolicy& policy = *impl_->modelPolicy;
        policy.keypointModel().addSemanticObservation(
            state, policy.classEvidence(kf1.semanticProbabilities.empty() ? nullptr : &kf1.semanticProbabilities.at(m.i1)),
            1.0);
        const double alpha = landmarks::matchingAccuracyFromDescriptors(
            kf1.descriptors.row(static_cast<int>(m.i1)), kf2.descriptors.row(static_cast<int>(m.i2)),
            params_.pointModel.matching.hammingMaxDistance);
        policy.keypointModel().addSemanticObservation(
            state, policy.classEvidence(kf2.semanticProbabilities.empty() ? nullptr : &kf2.semanticProbabilities.at(m.i2)),
            alpha);
        p.landmarkState = encodeKeypointState(state);
      }
      created.push_back(id);
    }
  }
  std::set<MapPointId> recent(recent_.begin(), recent_.end());
  recent.insert(created.begin(), created.end());
  recent_.assign(recent.begin(), recent.end());
  return created;
}

// ------------------------------------------------------------------------------------ 4. SearchInNeighbors

/// ORB-SLAM ORBmatcher::Fuse(pKF, vpMapPoints, th): projects each point into `kfId`, picks the best keypoint
/// in a scale-dependent radius at the predicted level (or one finer), gated by the reprojection chi2; a
/// matched keypoint with its own point means a duplicate (the one with more observations is kept), a free
/// keypoint gets the observation. Returns the number of fusions + new observations.
int LocalMapper::fuseInto(KeyFrameId kfId, const std::vector<MapPointId>& points) {
  const KeyFrame& kf0 = map_.keyFrame(kfId);
  if (kf0.descriptors.empty() || kf0.numKeypoints() == 0) return 0;
  const features::FeatureGrid grid = features::FeatureGrid::fromKeypoints(
      kf0.keypoints, cv::Rect2f(0.f, 0.f, float(kf0.camera.width), float(kf0.camera.height)));
  int fused = 0;
  for (MapPointId id : points) {
    if (!map_.hasMapPoint(id)) continue;
    const MapPoint& p = map_.mapPoint(id);
    if (p.bad || p.isObservedBy(kfId) || p.descriptor.empty()) continue;
    const KeyFrame& kf = map_.keyFrame(kfId);
    const Eigen::Vector3d X = map_.worldPosition(id);
    const Eigen::Vector3d Xc = kf.T_cam_world * X;
    if (Xc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = kf.camera.project(Xc);
    if (!kf.camera.inImage(uv)) continue;
    const Eigen::Vector3d PO = X - kf.cameraCenter();
    const double dist3D = PO.norm();
    if (dist3D < (1.0 - params_.fusionDistanceBand) * p.minDistance ||
        dist3D > (1.0 + params_.fusionDistanceBand) * p.maxDistance)
      continue;
    if (PO.dot(p.normal) < 0.5 * dist3D) continue;  // viewing angle > 60 deg from the mean
    const int predictedLevel = map_.predictScale(id, dist3D, kfId);
    const double radius = params_.fusionRadiusPixels * kf.scaleFactors.at(predictedLevel);
    const std::vector<size_t> candidates = grid.featuresInRadius(
        float(uv.x()), float(uv.y()), float(radius), features::OctaveRange{predictedLevel - 1, predictedLevel});
    int bestDist = 256;
    std::size_t bestIdx = 0;
    bool found = false;
    for (size_t c : candidates) {
      const double e2 = (kf.pixel(c) - uv).squaredNorm();
      if (e2 * kf.invSigma2(c) > params_.chi2Threshold) continue;
      const int dist = features::hammingDistance(p.descriptor, 0, kf.descriptors, static_cast<int>(c));
      if (dist < bestDist) {
        bestDist = dist;
        bestIdx = c;
        found = true;
      }
    }
    if (!found || bestDist > features::kOrbThLow) continue;
    const MapPointId existing = kf.mapPointIds[bestIdx];
    if (existing != map::kNoMapPoint) {
      if (map_.mapPoint(existing).bad) continue;
      // Keep the better-established point (more observations; ties keep the one already in the keyframe).
      if (map_.mapPoint(existing).numObservations() >= p.numObservations())
        map_.fuseMapPoints(existing, id);
      else
        map_.fuseMapPoints(id, existing);
    } else {
      map_.addObservation(id, kfId, bestIdx);
    }
    ++fused;
  }
  return fused;
}

int LocalMapper::searchInNeighbors(KeyFrameId kfId) {
  // Targets: first-order neighbours and, for each, its best second-order neighbours (ascending, unique).
  std::vector<KeyFrameId> targets;
  std::set<KeyFrameId> seen{kfId};
  const auto first = map_.bestCovisibleKeyFrames(kfId, static_cast<std::size_t>(params_.fusionNeighbours));
  for (KeyFrameId n : first)
    if (seen.insert(n).second) targets.push_back(n);
  for (KeyFrameId n : first)
    for (KeyFrameId n2 : map_.bestCovisibleKeyFrames(n, static_cast<std::size_t>(params_.fusionSecondOrderNeighbours)))
      if (seen.insert(n2).second) targets.push_back(n2);

  int fused = 0;
  // The keyframe's points into every target.
  for (KeyFrameId t : targets) {
    if (!map_.hasKeyFrame(t) || !map_.hasKeyFrame(kfId)) continue;
    fused += fuseInto(t, map_.pointsOf(kfId));
  }
  // The targets' points into the keyframe.
  std::set<MapPointId> candidates;
  for (KeyFrameId t : targets)
    if (map_.hasKeyFrame(t))
      for (MapPointId id : map_.pointsOf(t)) candidates.insert(id);
  fused += fuseInto(kfId, std::vector<MapPointId>(candidates.begin(), candidates.end()));
  // Appearance of the keyframe's points after the new observations (covisibility is kept by the map).
  for (MapPointId id : map_.pointsOf(kfId)) {
    map_.computeDistinctiveDescriptor(id);
    map_.updateNormalAndDepth(id);
  }
  return fused;
}

// ------------------------------------------------------------------------------------ 5. LocalBundleAdjustment

optimize::MapUpdateSummary LocalMapper::runLocalBundleAdjustment(KeyFrameId kfId, optimize::BAResult* resultOut) {
  // Only points the policy lets us use take part (§3.4.3), and the window's fixed keyframes are those that
  // observe these points: the window is built from the active points, not filtered after it was built.
  const std::shared_ptr<const map::PointUsePolicy>& policy = impl_->usePolicy;
  optimize::PointFilter usePoint;
  if (!policy->usesEveryGoodPoint()) usePoint = [&policy](const MapPoint& p) { return policy->mayUse(p); };
  optimize::BAProblem problem = optimize::makeLocalProblem(map_, kfId, params_.ba, usePoint);
  bool anyFree = false;
  for (const auto& [id, k] : problem.keyframes) anyFree = anyFree || !k.fixed;
  if (problem.observations.empty() || !anyFree) return {};
  // Each source's factors follow the previous source's: [begin_s, begin_s+1) is source s's range.
  std::vector<std::size_t> sourceBegin;
  for (const auto& source : baSources_) {
    sourceBegin.push_back(problem.factors.size());
    std::vector<std::shared_ptr<optimize::BAFactor>> f = source->bundleAdjustmentFactors(map_, problem);
    problem.factors.insert(problem.factors.end(), f.begin(), f.end());
  }
  sourceBegin.push_back(problem.factors.size());
  optimize::BAResult result;
  const auto solve = [&] { result = optimize::localBundleAdjustment(problem, params_.ba, &stopBundleAdjustment_); };
  // The problem holds copies of the poses and points, so its solve may run outside the map lock. Factors of
  // other landmark kinds optimize their landmarks in place (BAFactor::landmarkBlocks), which tracking reads: a
  // problem with any of them is solved with the lock held.
  bool landmarksInPlace = false;
  for (const auto& f : problem.factors) landmarksInPlace = landmarksInPlace || !f->landmarkBlocks().empty();
  if (landmarksInPlace)
    solve();
  else if (!runOutsideMapLock(solve))
    return {};  // the map was reset while solving: nothing to write back
  if (resultOut) *resultOut = result;
  std::vector<bool> outliers(problem.factors.size(), false);
  for (std::size_t i : result.factorOutliers)
    if (i < outliers.size()) outliers[i] = true;
  for (std::size_t s = 0; s < baSources_.size(); ++s)
    baSources_[s]->afterBundleAdjustment(std::vector<bool>(outliers.begin() + static_cast<long>(sourceBegin[s]),
                                                           outliers.begin() + static_cast<long>(sourceBegin[s + 1])));
  const optimize::MapUpdateSummary summary = optimize::applyResult(map_, problem, result, true);
  // §3.4.3: "after the bundle adjustment we update our probabilistic model with the refined depth
  // estimates": the filter mean takes the refined inverse depth; its variance and inlier counts are kept.
  if (model() != landmarks::MapPointModel::Heuristic)
    for (const auto& [id, rho] : result.inverseDepths) {
      if (!map_.hasMapPoint(id) || map_.mapPoint(id).landmarkState.empty()) continue;
      MapPoint& p = map_.mutableMapPoint(id);
      landmarks::KeypointState st = decodeKeypointState(p.landmarkState, "map point " + std::to_string(id));
      st.mu = p.inverseDepthAlongZ();
      p.landmarkState = encodeKeypointState(st);
    }
  return summary;
}

// ------------------------------------------------------------------------------------ 6. KeyFrameCulling

int LocalMapper::cullKeyFrames(KeyFrameId kfId) {
  return map::cullRedundantKeyFrames(map_, kfId, params_.culling);
}

// ------------------------------------------------------------------------------------ all steps

bool LocalMapper::runOutsideMapLock(const std::function<void()>& computation) {
  if (!outsideMapLock_) {
    computation();
    return true;
  }
  if (!outsideMapLock_(computation)) mapChanged_ = true;
  return !mapChanged_;
}

LocalMappingReport LocalMapper::processKeyFrame(KeyFrameId kfId, const std::vector<MapPointId>& recentlyAddedByTracking,
                                                bool measuredByTracking) {
  LocalMappingReport report;
  const auto t0 = Clock::now();
  landmarkUpdates_ = 0;
  mapChanged_ = false;
  stopBundleAdjustment_ = false;
  auto t = Clock::now();
  processNewKeyFrame(kfId, recentlyAddedByTracking, measuredByTracking);
  report.processMs = msSince(t);

  t = Clock::now();
  report.culledPoints = cullRecentPoints(kfId, &report.culledInlierRatio);
  report.culledRecent = report.culledPoints - report.culledInlierRatio;
  report.cullPointsMs = msSince(t);

  t = Clock::now();
  report.newPoints = static_cast<int>(createNewMapPoints(kfId).size());
  report.triangulationMs = msSince(t);
  if (mapChanged_) {
    report.mapChanged = true;
    return report;
  }

  t = Clock::now();
  report.fusedPoints = searchInNeighbors(kfId);
  report.fusionMs = msSince(t);
  if (newPointsReady_) newPointsReady_(kfId);

  if (params_.localBundleAdjustment && map_.numKeyFrames() > 2) {
    t = Clock::now();
    optimize::BAResult result;
    const optimize::MapUpdateSummary summary = runLocalBundleAdjustment(kfId, &result);
    report.baObservationsErased = summary.observationsErased;
    report.baPointsErased = summary.pointsErased;
    report.baInitialRmsPixels = result.initialRmsPixels;
    report.baFinalRmsPixels = result.finalRmsPixels;
    report.baStopped = result.stopped;
    report.localBaMs = msSince(t);
    if (mapChanged_) {
      report.mapChanged = true;
      return report;
    }
  }

  if (params_.cullKeyFrames) {
    t = Clock::now();
    report.culledKeyFrames = cullKeyFrames(kfId);
    report.cullKeyFramesMs = msSince(t);
  }
  report.landmarkUpdates = landmarkUpdates_;
  report.totalMs = msSince(t0);
  return report;
}

}  // namespace pslam::mapping
