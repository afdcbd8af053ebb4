#include "pslam/optimize/MapAdapter.h"

#include <cmath>
#include <set>

#include "pslam/core/Error.h"

namespace pslam::optimize {

namespace {

void addKeyFrame(BAProblem& problem, const map::KeyFrame& kf, bool fixed) {
  BAKeyFrame& b = problem.keyframes[kf.id];
  b.T_cam_world = kf.T_cam_world;
  b.camera = kf.camera;
  b.fixed = fixed;
}

void addPointWithObservations(BAProblem& problem, const map::Map& map, const map::MapPoint& p) {
  BAPoint& b = problem.points[p.id];
  b.anchor = p.anchorKeyFrame;
  b.bearing = p.bearing;
  b.inverseDepth = p.inverseDepth;
  for (const auto& [kfId, k] : p.observations) {
    const map::KeyFrame& kf = map.keyFrame(kfId);
    BAObservation o;
    o.keyframe = kfId;
    o.point = p.id;
    o.pixel = kf.pixel(k);
    o.invSigma2 = kf.invSigma2(k);
    problem.observations.push_back(o);
  }
}

}  // namespace

BAProblem makeLocalProblem(const map::Map& map, map::KeyFrameId centre, const BundleAdjustmentParams& params,
                           const PointFilter& usePoint) {
  params.check();
  const map::LocalWindow window = map.localWindow(centre, static_cast<std::size_t>(params.maxLocalKeyFrames));
  BAProblem problem;
  const map::KeyFrameId root = map.rootKeyFrame();
  for (map::KeyFrameId id : window.localKeyFrames) addKeyFrame(problem, map.keyFrame(id), id == root);
  const std::set<map::KeyFrameId> local(window.localKeyFrames.begin(), window.localKeyFrames.end());
  std::set<map::KeyFrameId> fixed;
  for (map::MapPointId id : window.points) {
    const map::MapPoint& p = map.mapPoint(id);
    if (usePoint && !usePoint(p)) continue;
    addPointWithObservations(problem, map, p);
    for (const auto& [kf, k] : p.observations)
      if (!local.count(kf)) fixed.insert(kf);
  }
  for (map::KeyFrameId id : fixed) addKeyFrame(problem, map.keyFrame(id), true);
  return problem;
}

BAProblem makeGlobalProblem(const map::Map& map, const PointFilter& usePoint) {
  BAProblem problem;
  for (const auto& [id, kf] : map.keyFrames()) addKeyFrame(problem, kf, false);
  for (const auto& [id, p] : map.mapPoints())
    if (!p.bad && (!usePoint || usePoint(p))) addPointWithObservations(problem, map, p);
  return problem;
}

MapUpdateSummary applyResult(map::Map& map, const BAProblem& problem, const BAResult& result, bool eraseOutliers) {
  MapUpdateSummary s;
  for (const auto& [id, T] : result.poses) {
    map.setKeyFramePose(id, T);
    ++s.posesUpdated;
  }
  std::set<map::MapPointId> touched;
  for (const auto& [id, rho] : result.inverseDepths) {
    if (!map.hasMapPoint(id)) continue;
    // The bearing is unchanged; a point at or behind infinity keeps its depth, its outlier observations go below.
    if (!isFiniteInverseDepth(rho)) {
      ++s.pointsNotMoved;
      continue;
    }
    map.setInverseDepth(id, rho);
    touched.insert(id);
    ++s.pointsUpdated;
  }
  if (eraseOutliers) {
    for (std::size_t i : result.outliers) {
      const BAObservation& o = problem.observations.at(i);
      if (!map.hasMapPoint(o.point) || !map.mapPoint(o.point).isObservedBy(o.keyframe)) continue;
      ++s.observationsErased;
      if (map.eraseObservation(o.point, o.keyframe)) {
        ++s.pointsErased;
        touched.erase(o.point);
      } else {
        touched.insert(o.point);
      }
    }
  }
  for (map::MapPointId id : touched) map.updateNormalAndDepth(id);
  return s;
}

MapUpdateSummary globalBundleAdjustment(map::Map& map, const BundleAdjustmentParams& params, BAResult* resultOut,
                                        const PointFilter& usePoint) {
  const BAProblem problem = makeGlobalProblem(map, usePoint);
  const BAResult result = globalBundleAdjustment(problem, params);
  if (resultOut) *resultOut = result;
  return applyResult(map, problem, result, false);
}

}  // namespace pslam::optimize
