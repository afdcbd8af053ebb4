#include "pslam/tracking/LocalMapTracker.h"

#include <algorithm>
#include <map>
#include <set>

#include "pslam/tracking/ProjectionSearch.h"

namespace pslam::tracking {

void LocalMapTracker::updateLocalKeyFrames(const Frame& frame) {
  const map::Map& map = ctx_.map;
  std::map<map::KeyFrameId, int> counter;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint || !map.hasMapPoint(id)) continue;
    for (const auto& [kf, k] : map.mapPoint(id).observations) ++counter[kf];
  }
  localKeyFrames_.clear();
  // A frame tracked by a module alone (direct points) has no keypoint matches: its local map is then the reference
  // keyframe's neighbourhood, so that keypoint matches can come back (never the case without such a module:
  // local-map tracking needs keypoint inliers then).
  if (counter.empty() && ctx_.moduleTracksWithoutKeypoints() && map.hasKeyFrame(ctx_.referenceKeyFrame))
    counter[ctx_.referenceKeyFrame] = 1;
  if (counter.empty()) return;
  std::set<map::KeyFrameId> inLocal;
  int best = -1;
  for (const auto& [kf, n] : counter) {
    localKeyFrames_.push_back(kf);
    inLocal.insert(kf);
    if (n > best) {
      best = n;
      ctx_.referenceKeyFrame = kf;
    }
  }
  // Neighbours of the local keyframes (ORB-SLAM: 10 best covisible, children and parent).
  const std::vector<map::KeyFrameId> first = localKeyFrames_;
  for (map::KeyFrameId kf : first) {
    if (static_cast<int>(localKeyFrames_.size()) >= ctx_.params.maxLocalKeyFrames) break;
    for (map::KeyFrameId n : map.bestCovisibleKeyFrames(kf, 10))
      if (inLocal.insert(n).second) localKeyFrames_.push_back(n);
    const map::KeyFrame& k = map.keyFrame(kf);
    for (map::KeyFrameId c : k.children)
      if (inLocal.insert(c).second) localKeyFrames_.push_back(c);
    if (k.parent != map::kNoKeyFrame && inLocal.insert(k.parent).second) localKeyFrames_.push_back(k.parent);
  }
}

void LocalMapTracker::applyCounters(const Counters& counters) {
  if (!ctx_.mapUpdates) return;
  for (map::MapPointId id : counters.visible)
    if (ctx_.map.hasMapPoint(id)) ++ctx_.map.mutableMapPoint(id).visibleCount;
  for (map::MapPointId id : counters.found)
    if (ctx_.map.hasMapPoint(id)) ++ctx_.map.mutableMapPoint(id).foundCount;
}

int LocalMapTracker::track(Frame& frame, float radiusFactor, Counters* deferred, int* localCandidates) {
  map::Map& map = ctx_.map;
  updateLocalKeyFrames(frame);
  if (deferred) *deferred = Counters{};
  // ORB-SLAM's visible / found counters (culling's found ratio); held back when `deferred`.
  auto countVisible = [&](map::MapPointId id) {
    if (deferred)
      deferred->visible.push_back(id);
    else if (ctx_.mapUpdates && map.hasMapPoint(id))
      ++map.mutableMapPoint(id).visibleCount;
  };
  std::set<map::MapPointId> matched;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    matched.insert(id);
    countVisible(id);
  }
  std::set<map::MapPointId> localPoints;
  for (map::KeyFrameId kf : localKeyFrames_)
    for (map::MapPointId p : map.pointsOf(kf))
      if (!matched.count(p)) localPoints.insert(p);
  const Eigen::Vector3d centre = frame.cameraCenter();
  const float th = radiusFactor * ctx_.params.localMapRadius;
  std::vector<ProjectionCandidate> cands;
  for (map::MapPointId id : localPoints) {
    if (!ctx_.measurable(id)) continue;
    const map::MapPoint& p = map.mapPoint(id);
    // ORB-SLAM Frame::isInFrustum: in front, inside the image, within the scale-invariance distances, and
    // seen at less than 60 degrees from its mean viewing direction.
    const Eigen::Vector3d pw = map.worldPosition(id);
    const Eigen::Vector3d pc = frame.T_cam_world * pw;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d uv = frame.camera.project(pc);
    if (!frame.bounds.contains(uv.x(), uv.y())) continue;
    const Eigen::Vector3d po = pw - centre;
    const double dist = po.norm();
    if (dist < 0.8 * p.minDistance || dist > 1.2 * p.maxDistance) continue;
    const double viewCos = p.normal.norm() > 0 ? po.dot(p.normal) / dist : 1.0;
    if (viewCos < 0.5) continue;
    countVisible(id);
    ProjectionCandidate c;
    c.id = id;
    c.p_world = pw;
    c.descriptor = p.descriptor;
    c.predictedLevel = predictLevel(dist, p.maxDistance, frame.numLevels() > 1 ? frame.scaleFactors[1] : 1.2,
                                    frame.numLevels());
    c.minLevel = std::max(0, c.predictedLevel - 1);
    c.maxLevel = c.predictedLevel;
    c.radius = th * radiusByViewingCos(viewCos) * static_cast<float>(frame.scaleFactors[c.predictedLevel]);
    cands.push_back(c);
  }
  if (localCandidates) *localCandidates = static_cast<int>(cands.size());
  ProjectionSearchParams sp;
  sp.ratio = ctx_.params.localMapRatio;
  sp.checkOrientation = false;  // ORB-SLAM's local-map search has no rotation check
  searchByProjection(frame, frame.T_cam_world, cands, sp);
  const int inliers = optimizer_.optimize(frame, {/*withModules=*/true, /*final=*/true});
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    if (deferred)
      deferred->found.push_back(id);
    else if (ctx_.mapUpdates && map.hasMapPoint(id))
      ++map.mutableMapPoint(id).foundCount;
  }
  return inliers;
}

}  // namespace pslam::tracking
