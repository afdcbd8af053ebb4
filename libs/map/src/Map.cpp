#include "pslam/map/Map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "pslam/core/Error.h"

namespace pslam::map {

namespace {
std::string kfName(KeyFrameId id) { return "keyframe " + std::to_string(id); }
std::string ptName(MapPointId id) { return "map point " + std::to_string(id); }
}  // namespace

// ------------------------------------------------------------------------------------------ access

const KeyFrame& Map::keyFrame(KeyFrameId id) const {
  auto it = keyframes_.find(id);
  if (it == keyframes_.end()) throw Error("map: unknown " + kfName(id));
  return it->second;
}
KeyFrame& Map::kfRef(KeyFrameId id) {
  auto it = keyframes_.find(id);
  if (it == keyframes_.end()) throw Error("map: unknown " + kfName(id));
  return it->second;
}
KeyFrame& Map::mutableKeyFrame(KeyFrameId id) { return kfRef(id); }

const MapPoint& Map::mapPoint(MapPointId id) const {
  auto it = points_.find(id);
  if (it == points_.end()) throw Error("map: unknown " + ptName(id));
  return it->second;
}
MapPoint& Map::ptRef(MapPointId id) {
  auto it = points_.find(id);
  if (it == points_.end()) throw Error("map: unknown " + ptName(id));
  return it->second;
}
MapPoint& Map::mutableMapPoint(MapPointId id) { return ptRef(id); }

void Map::setKeyFramePose(KeyFrameId id, const Eigen::Isometry3d& T_cam_world) {
  require(T_cam_world.matrix().allFinite(), "map: " + kfName(id), "pose has NaN/Inf entries");
  kfRef(id).T_cam_world = T_cam_world;
}

// ------------------------------------------------------------------------------------------ keyframes

KeyFrameId Map::addKeyFrame(KeyFrame kf) {
  const KeyFrameId id = nextKeyFrameId_;
  kf.check("map: new keyframe (t=" + std::to_string(kf.timestamp) + ")");
  kf.id = id;
  kf.mapPointIds.assign(kf.keypoints.size(), kNoMapPoint);
  kf.sharedPoints.clear();
  kf.parent = kNoKeyFrame;
  kf.children.clear();
  keyframes_.emplace(id, std::move(kf));
  ++nextKeyFrameId_;
  return id;
}

void Map::eraseKeyFrame(KeyFrameId id) {
  KeyFrame& kf = kfRef(id);
  if (id == rootKeyFrame() && keyframes_.size() > 1)
    throw Error("map: cannot erase the root " + kfName(id) + " while other keyframes exist");
  for (std::size_t k = 0; k < kf.mapPointIds.size(); ++k)
    if (kf.mapPointIds[k] != kNoMapPoint) eraseObservation(kf.mapPointIds[k], id);

  // Spanning tree repair (ORB-SLAM KeyFrame::SetBadFlag): greedily give each child the candidate parent it
  // shares most points with; candidates start with the erased keyframe's parent and grow with every child
  // re-attached. Iteration over ordered sets and strict '>' make ties resolve to the lowest ids.
  std::set<KeyFrameId> candidates;
  if (kf.parent != kNoKeyFrame) candidates.insert(kf.parent);
  std::set<KeyFrameId> orphans = kf.children;
  for (KeyFrameId c : orphans) kfRef(c).parent = kNoKeyFrame;
  while (!orphans.empty()) {
    KeyFrameId bestChild = kNoKeyFrame, bestParent = kNoKeyFrame;
    int bestWeight = 0;
    for (KeyFrameId c : orphans)
      for (KeyFrameId p : candidates) {
        const int w = covisibilityWeight(c, p);
        if (w > bestWeight) bestWeight = w, bestChild = c, bestParent = p;
      }
    if (bestChild == kNoKeyFrame) break;
    setParent(bestChild, bestParent);
    candidates.insert(bestChild);
    orphans.erase(bestChild);
  }
  for (KeyFrameId c : orphans)
    if (kf.parent != kNoKeyFrame) setParent(c, kf.parent);
  if (kf.parent != kNoKeyFrame) {
    kfRef(kf.parent).children.erase(id);
    erased_[id] = ErasedKeyFrame{kf.parent, kf.T_cam_world * keyFrame(kf.parent).T_world_cam()};
  }
  keyframes_.erase(id);
}

std::optional<Eigen::Isometry3d> Map::keyFramePoseIncludingErased(KeyFrameId id) const {
  Eigen::Isometry3d T_cam_current = Eigen::Isometry3d::Identity();  // this keyframe relative to `current`
  KeyFrameId current = id;
  // Each link points to a keyframe that existed when `current` was erased, i.e. to an older erasure or a
  // living keyframe, so the walk ends; the bound guards against a corrupted history.
  for (std::size_t steps = 0; steps <= erased_.size(); ++steps) {
    if (auto it = keyframes_.find(current); it != keyframes_.end()) return T_cam_current * it->second.T_cam_world;
    auto e = erased_.find(current);
    if (e == erased_.end()) return std::nullopt;
    T_cam_current = T_cam_current * e->second.T_cam_parent;
    current = e->second.parent;
  }
  return std::nullopt;
}

void Map::rescaleErasedKeyFrameLinks(const std::map<KeyFrameId, double>& scales) {
  for (auto& [id, record] : erased_) {
    KeyFrameId current = record.parent;
    for (std::size_t steps = 0; steps <= erased_.size() && !keyframes_.count(current); ++steps) {
      const auto e = erased_.find(current);
      if (e == erased_.end()) break;
      current = e->second.parent;
    }
    const auto s = scales.find(current);
    if (keyframes_.count(current) && s != scales.end() && s->second > 0.0) record.T_cam_parent.translation() /= s->second;
  }
}

void Map::setParent(KeyFrameId child, KeyFrameId parent) {
  KeyFrame& c = kfRef(child);
  if (c.parent != kNoKeyFrame && hasKeyFrame(c.parent)) kfRef(c.parent).children.erase(child);
  c.parent = parent;
  if (parent != kNoKeyFrame) kfRef(parent).children.insert(child);
}

// ------------------------------------------------------------------------------------------ points

MapPointId Map::addMapPoint(KeyFrameId anchor, std::size_t keypoint, const Eigen::Vector3d& p_world) {
  const std::string ctx = "map: new point in " + kfName(anchor);
  require(p_world.allFinite(), ctx, "world position has NaN/Inf");
  const Eigen::Vector3d p_anchor = keyFrame(anchor).T_cam_world * p_world;
  const double distance = p_anchor.norm();
  require(distance > 0.0 && p_anchor.z() > 0.0, ctx, "point is not in front of the anchor camera");
  return addMapPointInverseDepth(anchor, keypoint, p_anchor / distance, 1.0 / distance);
}

MapPointId Map::addMapPointInverseDepth(KeyFrameId anchor, std::size_t keypoint, const Eigen::Vector3d& bearing,
                                        double inverseDepth) {
  const std::string ctx = "map: new point in " + kfName(anchor);
  KeyFrame& kf = kfRef(anchor);
  require(keypoint < kf.keypoints.size(), ctx, "keypoint index " + std::to_string(keypoint) + " out of range");
  require(kf.mapPointIds[keypoint] == kNoMapPoint, ctx,
          "keypoint " + std::to_string(keypoint) + " is already matched to a map point");
  require(bearing.allFinite() && bearing.norm() > 0.0, ctx, "bearing must be finite and non-zero");
  require(std::isfinite(inverseDepth) && inverseDepth >= 0.0, ctx, "inverse depth must be finite and >= 0");
  const MapPointId id = nextMapPointId_++;
  MapPoint& p = points_[id];
  p.id = id;
  p.anchorKeyFrame = anchor;
  p.anchorKeypoint = keypoint;
  p.bearing = bearing.normalized();
  p.inverseDepth = inverseDepth;
  p.firstKeyFrame = anchor;
  linkObservation(p, kf, keypoint);
  computeDistinctiveDescriptor(id);
  updateNormalAndDepth(id);
  return id;
}

void Map::eraseMapPoint(MapPointId id) {
  MapPoint& p = ptRef(id);
  while (!p.observations.empty()) unlinkObservation(p, kfRef(p.observations.begin()->first));
  points_.erase(id);
}

Eigen::Vector3d Map::worldPosition(MapPointId id) const {
  const MapPoint& p = mapPoint(id);
  return p.worldPosition(keyFrame(p.anchorKeyFrame).T_world_cam());
}

void Map::setWorldPosition(MapPointId id, const Eigen::Vector3d& p_world) {
  MapPoint& p = ptRef(id);
  require(p_world.allFinite(), "map: " + ptName(id), "world position has NaN/Inf");
  const Eigen::Vector3d p_anchor = keyFrame(p.anchorKeyFrame).T_cam_world * p_world;
  const double distance = p_anchor.norm();
  require(distance > 0.0, "map: " + ptName(id), "world position coincides with the anchor camera centre");
  p.bearing = p_anchor / distance;
  p.inverseDepth = 1.0 / distance;
}

void Map::setInverseDepth(MapPointId id, double inverseDepth) {
  require(std::isfinite(inverseDepth) && inverseDepth >= 0.0, "map: " + ptName(id),
          "inverse depth must be finite and >= 0");
  ptRef(id).inverseDepth = inverseDepth;
}

// ------------------------------------------------------------------------------------------ observations

void Map::linkObservation(MapPoint& p, KeyFrame& kf, std::size_t keypoint) {
  // Covisibility weights are kept exact incrementally: a new observer shares this point with every
  // existing observer.
  for (const auto& [other, k] : p.observations) {
    (void)k;
    ++kf.sharedPoints[other];
    ++kfRef(other).sharedPoints[kf.id];
  }
  p.observations[kf.id] = keypoint;
  kf.mapPointIds[keypoint] = p.id;
}

void Map::unlinkObservation(MapPoint& p, KeyFrame& kf) {
  auto it = p.observations.find(kf.id);
  if (it == p.observations.end()) return;
  kf.mapPointIds[it->second] = kNoMapPoint;
  p.observations.erase(it);
  for (const auto& [other, k] : p.observations) {
    (void)k;
    KeyFrame& o = kfRef(other);
    if (--kf.sharedPoints[other] == 0) kf.sharedPoints.erase(other);
    if (--o.sharedPoints[kf.id] == 0) o.sharedPoints.erase(kf.id);
  }
}

bool Map::addObservation(MapPointId point, KeyFrameId kfId, std::size_t keypoint) {
  MapPoint& p = ptRef(point);
  KeyFrame& kf = kfRef(kfId);
  const std::string ctx = "map: " + ptName(point) + " in " + kfName(kfId);
  require(keypoint < kf.keypoints.size(), ctx, "keypoint index " + std::to_string(keypoint) + " out of range");
  if (p.isObservedBy(kfId)) return false;
  require(kf.mapPointIds[keypoint] == kNoMapPoint, ctx,
          "keypoint " + std::to_string(keypoint) + " is already matched to " + ptName(kf.mapPointIds[keypoint]));
  linkObservation(p, kf, keypoint);
  return true;
}

bool Map::eraseObservation(MapPointId point, KeyFrameId kfId) {
  MapPoint& p = ptRef(point);
  if (!p.isObservedBy(kfId)) return false;
  if (p.observations.size() == 1) {  // the last observer: nothing can anchor the point any more
    eraseMapPoint(point);
    return true;
  }
  if (p.anchorKeyFrame == kfId) {
    // Re-anchor before unlinking, while the old anchor's pose is still at hand. The new anchor is the
    // oldest other observer (deterministic, and the most likely to survive culling).
    KeyFrameId newAnchor = kNoKeyFrame;
    for (const auto& [other, k] : p.observations)
      if (other != kfId) {
        newAnchor = other;
        break;
      }
    reanchor(point, newAnchor);
  }
  unlinkObservation(p, kfRef(kfId));
  return false;
}

void Map::reanchor(MapPointId point, KeyFrameId newAnchor) {
  MapPoint& p = ptRef(point);
  auto obs = p.observations.find(newAnchor);
  require(obs != p.observations.end(), "map: re-anchoring " + ptName(point),
          kfName(newAnchor) + " does not observe the point");
  if (newAnchor == p.anchorKeyFrame) return;
  const Eigen::Isometry3d T_world_old = keyFrame(p.anchorKeyFrame).T_world_cam();
  const Eigen::Isometry3d& T_new_world = keyFrame(newAnchor).T_cam_world;
  if (p.inverseDepth > 0.0) {
    const Eigen::Vector3d p_new = T_new_world * p.worldPosition(T_world_old);
    const double distance = p_new.norm();
    require(distance > 0.0, "map: re-anchoring " + ptName(point), "point coincides with the new anchor centre");
    p.bearing = p_new / distance;
    p.inverseDepth = 1.0 / distance;
  } else {
    // A point at infinity is a direction: only the rotation moves it.
    p.bearing = (T_new_world.linear() * T_world_old.linear() * p.bearing).normalized();
  }
  p.anchorKeyFrame = newAnchor;
  p.anchorKeypoint = obs->second;
}

void Map::fuseMapPoints(MapPointId kept, MapPointId dropped) {
  if (kept == dropped) return;
  MapPoint& pk = ptRef(kept);
  MapPoint& pd = ptRef(dropped);
  const std::map<KeyFrameId, std::size_t> dropObs = pd.observations;
  for (const auto& [kfId, k] : dropObs) {
    KeyFrame& kf = kfRef(kfId);
    unlinkObservation(pd, kf);
    if (!pk.isObservedBy(kfId)) linkObservation(pk, kf, k);
  }
  pk.visibleCount += pd.visibleCount;
  pk.foundCount += pd.foundCount;
  points_.erase(dropped);
  computeDistinctiveDescriptor(kept);
  updateNormalAndDepth(kept);
}

// ------------------------------------------------------------------------------------------ appearance

void Map::computeDistinctiveDescriptor(MapPointId id) {
  MapPoint& p = ptRef(id);
  std::vector<cv::Mat> descs;
  for (const auto& [kfId, k] : p.observations) {
    const KeyFrame& kf = keyFrame(kfId);
    if (!kf.descriptors.empty()) descs.push_back(kf.descriptors.row(static_cast<int>(k)));
  }
  if (descs.empty()) return;
  const std::size_t n = descs.size();
  std::vector<std::vector<int>> dist(n, std::vector<int>(n, 0));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      dist[i][j] = dist[j][i] = static_cast<int>(cv::norm(descs[i], descs[j], cv::NORM_HAMMING));
  int bestMedian = std::numeric_limits<int>::max();
  std::size_t best = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<int> row = dist[i];
    std::sort(row.begin(), row.end());
    const int median = row[(n - 1) / 2];  // ORB-SLAM: vDists[0.5*(N-1)]
    if (median < bestMedian) bestMedian = median, best = i;
  }
  p.descriptor = descs[best].clone();
}

void Map::updateNormalAndDepth(MapPointId id) {
  MapPoint& p = ptRef(id);
  const KeyFrame& anchor = keyFrame(p.anchorKeyFrame);
  const int level = anchor.keypoints.at(p.anchorKeypoint).octave;
  if (p.inverseDepth <= 0.0) {
    // At infinity every camera sees the same direction; any distance is scale-consistent.
    p.normal = anchor.T_cam_world.linear().transpose() * p.bearing;
    p.minDistance = 0.0;
    p.maxDistance = std::numeric_limits<double>::infinity();
    return;
  }
  const Eigen::Vector3d pw = worldPosition(id);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& [kfId, k] : p.observations) {
    (void)k;
    sum += (pw - keyFrame(kfId).cameraCenter()).normalized();
  }
  p.normal = sum.normalized();
  // ORB-SLAM UpdateNormalAndDepth with the anchor as reference keyframe: a feature seen at level l and
  // distance d is expected between the distances at which it would appear on the finest and coarsest level.
  const double distance = 1.0 / p.inverseDepth;
  p.maxDistance = distance * anchor.scaleFactors.at(level);
  p.minDistance = p.maxDistance / anchor.scaleFactors.back();
}

int Map::predictScale(MapPointId id, double distance, KeyFrameId kfId) const {
  const MapPoint& p = mapPoint(id);
  const KeyFrame& kf = keyFrame(kfId);
  const int last = kf.numLevels() - 1;
  if (last <= 0 || !(distance > 0.0) || !std::isfinite(p.maxDistance)) return 0;
  const double ratio = p.maxDistance / distance;
  // The small epsilon keeps exact powers of the scale factor on their own level despite rounding.
  const int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(kf.scaleFactors[1]) - 1e-9));
  return std::clamp(level, 0, last);
}

// ------------------------------------------------------------------------------------------ graph

int Map::covisibilityWeight(KeyFrameId a, KeyFrameId b) const {
  const KeyFrame& kf = keyFrame(a);
  auto it = kf.sharedPoints.find(b);
  return it == kf.sharedPoints.end() ? 0 : it->second;
}

std::vector<KeyFrameId> Map::covisibleKeyFrames(KeyFrameId id, int minWeight) const {
  std::vector<std::pair<int, KeyFrameId>> v;
  for (const auto& [other, w] : keyFrame(id).sharedPoints)
    if (w >= minWeight) v.emplace_back(w, other);
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  std::vector<KeyFrameId> out;
  out.reserve(v.size());
  for (const auto& e : v) out.push_back(e.second);
  return out;
}

std::vector<KeyFrameId> Map::bestCovisibleKeyFrames(KeyFrameId id, std::size_t n) const {
  std::vector<KeyFrameId> v = covisibleKeyFrames(id, kCovisibilityThreshold);
  if (v.empty()) {
    std::vector<KeyFrameId> all = covisibleKeyFrames(id, 1);
    if (!all.empty()) v.push_back(all.front());
  }
  if (v.size() > n) v.resize(n);
  return v;
}

KeyFrameId Map::connectToSpanningTree(KeyFrameId id) {
  KeyFrame& kf = kfRef(id);
  if (kf.parent != kNoKeyFrame || id == rootKeyFrame()) return kf.parent;
  // The heaviest neighbour that is not in id's own subtree (which would close a cycle).
  auto inSubtreeOfId = [&](KeyFrameId c) {
    for (KeyFrameId a = c; a != kNoKeyFrame; a = keyFrame(a).parent)
      if (a == id) return true;
    return false;
  };
  for (KeyFrameId cand : covisibleKeyFrames(id, 1)) {
    if (inSubtreeOfId(cand)) continue;
    setParent(id, cand);
    return cand;
  }
  return kNoKeyFrame;
}

// ------------------------------------------------------------------------------------------ queries

std::vector<MapPointId> Map::pointsOf(KeyFrameId id) const {
  std::set<MapPointId> s;
  for (MapPointId p : keyFrame(id).mapPointIds)
    if (p != kNoMapPoint) s.insert(p);
  return {s.begin(), s.end()};
}

int Map::trackedMapPoints(KeyFrameId id, std::size_t minObservations, const PointUsePolicy* policy) const {
  int n = 0;
  for (MapPointId p : keyFrame(id).mapPointIds)
    if (p != kNoMapPoint) {
      const MapPoint& mp = mapPoint(p);
      if (!mp.bad && mp.observations.size() >= minObservations && (!policy || policy->mayUse(mp))) ++n;
    }
  return n;
}

LocalWindow Map::localWindow(KeyFrameId centre, std::size_t maxLocalKeyFrames) const {
  require(maxLocalKeyFrames >= 1, "map: local window", "maxLocalKeyFrames must be >= 1");
  LocalWindow w;
  w.localKeyFrames.push_back(centre);
  for (KeyFrameId k : bestCovisibleKeyFrames(centre, maxLocalKeyFrames - 1)) w.localKeyFrames.push_back(k);
  const std::set<KeyFrameId> local(w.localKeyFrames.begin(), w.localKeyFrames.end());
  std::set<MapPointId> points;
  for (KeyFrameId k : w.localKeyFrames)
    for (MapPointId p : keyFrame(k).mapPointIds)
      if (p != kNoMapPoint && !mapPoint(p).bad) points.insert(p);
  std::set<KeyFrameId> fixed;
  for (MapPointId p : points)
    for (const auto& [kf, k] : mapPoint(p).observations) {
      (void)k;
      if (!local.count(kf)) fixed.insert(kf);
    }
  w.points.assign(points.begin(), points.end());
  w.fixedKeyFrames.assign(fixed.begin(), fixed.end());
  return w;
}

void Map::checkInvariants(const std::string& context) const {
  auto fail = [&](const std::string& msg) { throw Error(context + ": " + msg); };
  for (const auto& [pid, p] : points_) {
    if (p.id != pid) fail(ptName(pid) + " stores id " + std::to_string(p.id));
    if (p.observations.empty()) fail(ptName(pid) + " has no observations");
    for (const auto& [kfId, k] : p.observations) {
      auto it = keyframes_.find(kfId);
      if (it == keyframes_.end()) fail(ptName(pid) + " observed by missing " + kfName(kfId));
      if (k >= it->second.mapPointIds.size() || it->second.mapPointIds[k] != pid)
        fail(ptName(pid) + " observation in " + kfName(kfId) + " keypoint " + std::to_string(k) +
             " is not mirrored by the keyframe");
    }
    auto a = p.observations.find(p.anchorKeyFrame);
    if (a == p.observations.end()) fail(ptName(pid) + " anchor " + kfName(p.anchorKeyFrame) + " does not observe it");
    if (a->second != p.anchorKeypoint) fail(ptName(pid) + " anchor keypoint differs from the anchor observation");
    if (!p.bearing.allFinite() || std::abs(p.bearing.norm() - 1.0) > 1e-9) fail(ptName(pid) + " bearing is not unit");
    if (!std::isfinite(p.inverseDepth) || p.inverseDepth < 0.0) fail(ptName(pid) + " has an invalid inverse depth");
  }
  std::map<std::pair<KeyFrameId, KeyFrameId>, int> shared;
  for (const auto& [pid, p] : points_)
    for (auto i = p.observations.begin(); i != p.observations.end(); ++i)
      for (auto j = std::next(i); j != p.observations.end(); ++j) ++shared[{i->first, j->first}];
  for (const auto& [kid, kf] : keyframes_) {
    if (kf.id != kid) fail(kfName(kid) + " stores id " + std::to_string(kf.id));
    if (kf.mapPointIds.size() != kf.keypoints.size()) fail(kfName(kid) + " mapPointIds size differs from keypoints");
    for (std::size_t k = 0; k < kf.mapPointIds.size(); ++k) {
      const MapPointId pid = kf.mapPointIds[k];
      if (pid == kNoMapPoint) continue;
      auto it = points_.find(pid);
      if (it == points_.end()) fail(kfName(kid) + " keypoint " + std::to_string(k) + " refers to missing " + ptName(pid));
      auto o = it->second.observations.find(kid);
      if (o == it->second.observations.end() || o->second != k)
        fail(kfName(kid) + " keypoint " + std::to_string(k) + " is not mirrored by " + ptName(pid));
    }
    for (const auto& [other, w] : kf.sharedPoints) {
      const auto key = kid < other ? std::make_pair(kid, other) : std::make_pair(other, kid);
      auto it = shared.find(key);
      const int truth = it == shared.end() ? 0 : it->second;
      if (w != truth)
        fail("covisibility weight " + kfName(kid) + " -> " + std::to_string(other) + " is " + std::to_string(w) +
             ", shared points " + std::to_string(truth));
    }
    if (kf.parent != kNoKeyFrame) {
      auto it = keyframes_.find(kf.parent);
      if (it == keyframes_.end() || !it->second.children.count(kid))
        fail(kfName(kid) + " parent " + std::to_string(kf.parent) + " does not list it as child");
    }
    for (KeyFrameId c : kf.children) {
      auto it = keyframes_.find(c);
      if (it == keyframes_.end() || it->second.parent != kid)
        fail(kfName(kid) + " child " + std::to_string(c) + " does not have it as parent");
    }
  }
  for (const auto& [key, n] : shared)
    if (covisibilityWeight(key.first, key.second) != n)
      fail("missing covisibility weight between " + kfName(key.first) + " and " + std::to_string(key.second));
}

// ------------------------------------------------------------------------------------------ equality

namespace {
bool equalMats(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() && b.empty()) return true;
  if (a.rows != b.rows || a.cols != b.cols || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r)
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  return true;
}
bool equalKeypoints(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].pt != b[i].pt || a[i].size != b[i].size || a[i].angle != b[i].angle ||
        a[i].response != b[i].response || a[i].octave != b[i].octave || a[i].class_id != b[i].class_id)
      return false;
  return true;
}
}  // namespace

bool equalKeyFrames(const KeyFrame& a, const KeyFrame& b) {
  return a.id == b.id && a.timestamp == b.timestamp && a.T_cam_world.matrix() == b.T_cam_world.matrix() &&
         a.camera == b.camera && equalKeypoints(a.keypoints, b.keypoints) && equalMats(a.descriptors, b.descriptors) &&
         a.scaleFactors == b.scaleFactors && a.levelSigma2 == b.levelSigma2 &&
         a.semanticProbabilities == b.semanticProbabilities && a.mapPointIds == b.mapPointIds &&
         a.sharedPoints == b.sharedPoints && a.parent == b.parent && a.children == b.children;
}

bool equalMapPoints(const MapPoint& a, const MapPoint& b) {
  auto sameDouble = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
  return a.id == b.id && a.anchorKeyFrame == b.anchorKeyFrame && a.anchorKeypoint == b.anchorKeypoint &&
         a.bearing == b.bearing && a.inverseDepth == b.inverseDepth && a.observations == b.observations &&
         equalMats(a.descriptor, b.descriptor) && a.normal == b.normal && sameDouble(a.minDistance, b.minDistance) &&
         sameDouble(a.maxDistance, b.maxDistance) && a.visibleCount == b.visibleCount &&
         a.foundCount == b.foundCount && a.bad == b.bad && a.firstKeyFrame == b.firstKeyFrame &&
         a.landmarkState == b.landmarkState;
}

const std::string* Map::extension(const std::string& name) const {
  const auto it = extensions_.find(name);
  return it == extensions_.end() ? nullptr : &it->second;
}

bool Map::operator==(const Map& o) const {
  if (nextKeyFrameId_ != o.nextKeyFrameId_ || nextMapPointId_ != o.nextMapPointId_ || vocabulary_ != o.vocabulary_ ||
      extensions_ != o.extensions_ ||
      keyframes_.size() != o.keyframes_.size() || points_.size() != o.points_.size())
    return false;
  for (auto a = keyframes_.begin(), b = o.keyframes_.begin(); a != keyframes_.end(); ++a, ++b)
    if (a->first != b->first || !equalKeyFrames(a->second, b->second)) return false;
  for (auto a = points_.begin(), b = o.points_.begin(); a != points_.end(); ++a, ++b)
    if (a->first != b->first || !equalMapPoints(a->second, b->second)) return false;
  return true;
}

}  // namespace pslam::map
