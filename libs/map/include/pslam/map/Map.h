#pragma once
// The map: keyframes and map points in ordered containers (std::map by id, so every iteration order is
// deterministic, thesis §3.5.2), with the observation bookkeeping, the covisibility graph and the spanning
// tree kept consistent by every mutating call. Sequential use only (no internal locking).
//
// Invariants (checked by checkInvariants()):
//  * point.observations[kf] == k  <=>  keyframe(kf).mapPointIds[k] == point.id   (symmetric observations)
//  * a point's anchor keyframe is one of its observers, and its anchor keypoint is that observation
//  * keyframe(a).sharedPoints[b] == keyframe(b).sharedPoints[a] == number of points both observe
//  * parent/children links of the spanning tree are mutual
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "pslam/map/KeyFrame.h"
#include "pslam/map/MapPoint.h"
#include "pslam/map/PointUsePolicy.h"

namespace pslam::map {

/// Local window for bundle adjustment (ORB-SLAM LocalBundleAdjustment): the keyframe and its best
/// covisible neighbours are optimized, the points they observe are optimized, every other keyframe that
/// observes one of those points is held fixed.
struct LocalWindow {
  std::vector<KeyFrameId> localKeyFrames;  ///< the centre first, then by covisibility weight
  std::vector<KeyFrameId> fixedKeyFrames;  ///< ascending id
  std::vector<MapPointId> points;          ///< ascending id, bad points excluded
};

class Map {
 public:
  /// ORB-SLAM: keyframes sharing at least this many points are neighbours in the covisibility graph.
  static constexpr int kCovisibilityThreshold = 15;

  // ---- keyframes ----
  /// Validates and inserts `kf`, assigning the next id (returned). mapPointIds is (re)set to "unmatched",
  /// sharedPoints/parent/children are cleared: associations are made with addObservation().
  KeyFrameId addKeyFrame(KeyFrame kf);
  /// Removes the keyframe: its observations are erased (re-anchoring points anchored in it, erasing points
  /// left without observers), its children are re-attached to the spanning tree. The root (the oldest
  /// keyframe) can only be erased when it is the last one. Throws pslam::Error for an unknown id.
  void eraseKeyFrame(KeyFrameId id);
  bool hasKeyFrame(KeyFrameId id) const { return keyframes_.count(id) != 0; }
  const KeyFrame& keyFrame(KeyFrameId id) const;
  /// For updating measurement state (pose, semantics). Do not edit mapPointIds/sharedPoints/parent/children.
  KeyFrame& mutableKeyFrame(KeyFrameId id);
  const std::map<KeyFrameId, KeyFrame>& keyFrames() const { return keyframes_; }
  std::size_t numKeyFrames() const { return keyframes_.size(); }
  void setKeyFramePose(KeyFrameId id, const Eigen::Isometry3d& T_cam_world);
  /// T_cam_world of keyframe `id`, also after it was erased: eraseKeyFrame records the erased keyframe's pose
  /// relative to its spanning-tree parent (ORB-SLAM's KeyFrame::mTcp), and the pose is composed along those
  /// links up to a keyframe still in the map, whose current (bundle-adjusted) pose is used. Frames tracked
  /// against a keyframe that local mapping later culled are placed this way. nullopt for an id never seen or
  /// erased without a parent (the last keyframe). The erasure records are run-time history: not serialized,
  /// not compared by operator==.
  std::optional<Eigen::Isometry3d> keyFramePoseIncludingErased(KeyFrameId id) const;
  /// A Sim(3) correction changed the scale of the keyframes (loop closing): the recorded offset of every erased
  /// keyframe from its parent is divided by `scales[k]` of the living keyframe k its chain of parents ends in
  /// (camera-frame lengths of k before the correction = scales[k] x those after). Keyframes not in `scales` keep 1.
  void rescaleErasedKeyFrameLinks(const std::map<KeyFrameId, double>& scales);

  // ---- map points ----
  /// Creates a point at `p_world` anchored in keypoint `keypoint` of `anchor` (which then observes it).
  /// Appearance (descriptor, normal, distances) is computed. Throws if the point is not in front of the
  /// anchor camera, the keypoint is out of range or already matched.
  MapPointId addMapPoint(KeyFrameId anchor, std::size_t keypoint, const Eigen::Vector3d& p_world);
  /// Same from the inverse-depth parameters directly (bearing is normalized; rho >= 0, 0 = at infinity).
  MapPointId addMapPointInverseDepth(KeyFrameId anchor, std::size_t keypoint, const Eigen::Vector3d& bearing,
                                     double inverseDepth);
  /// Removes the point and every observation of it.
  void eraseMapPoint(MapPointId id);
  bool hasMapPoint(MapPointId id) const { return points_.count(id) != 0; }
  const MapPoint& mapPoint(MapPointId id) const;
  /// For counters, bad flag and landmarkState. Do not edit observations / anchor fields directly.
  MapPoint& mutableMapPoint(MapPointId id);
  const std::map<MapPointId, MapPoint>& mapPoints() const { return points_; }
  std::size_t numMapPoints() const { return points_.size(); }

  Eigen::Vector3d worldPosition(MapPointId id) const;
  /// Moves the point to `p_world`, keeping its anchor (bearing and rho are recomputed).
  void setWorldPosition(MapPointId id, const Eigen::Vector3d& p_world);
  void setInverseDepth(MapPointId id, double inverseDepth);

  // ---- observations ----
  /// Associates keypoint `keypoint` of `kf` with the point. Returns false (and changes nothing) when the
  /// keyframe already observes the point; throws if the keypoint is out of range or matched to another.
  bool addObservation(MapPointId point, KeyFrameId kf, std::size_t keypoint);
  /// Removes the association. If `kf` was the anchor the point is re-anchored (world position kept); if no
  /// observer is left the point is erased. Returns true if the point was erased.
  bool eraseObservation(MapPointId point, KeyFrameId kf);
  /// Moves the anchor to another observer `newAnchor`, keeping the world position.
  void reanchor(MapPointId point, KeyFrameId newAnchor);
  /// Fusion of duplicates (ORB-SLAM MapPoint::Replace): every observation of `dropped` moves to `kept`
  /// unless that keyframe already sees `kept` (then its keypoint becomes unmatched); counters are summed,
  /// `dropped` is erased and the appearance of `kept` recomputed.
  void fuseMapPoints(MapPointId kept, MapPointId dropped);

  // ---- appearance (ORB-SLAM) ----
  /// Representative descriptor: the observation descriptor whose median Hamming distance to the others
  /// is least (ties: first in observation order).
  void computeDistinctiveDescriptor(MapPointId id);
  /// Mean viewing direction and the scale-invariance distances from the anchor observation's level.
  void updateNormalAndDepth(MapPointId id);
  /// Pyramid level at which `kf` would see the point at `distance` (ORB-SLAM PredictScale).
  int predictScale(MapPointId id, double distance, KeyFrameId kf) const;

  // ---- covisibility graph and spanning tree ----
  /// Neighbours with weight >= minWeight, by weight descending then id ascending.
  std::vector<KeyFrameId> covisibleKeyFrames(KeyFrameId id, int minWeight = kCovisibilityThreshold) const;
  /// The first n of covisibleKeyFrames(); if none reaches the threshold, the single heaviest neighbour
  /// (ORB-SLAM keeps the best connection even below the threshold).
  std::vector<KeyFrameId> bestCovisibleKeyFrames(KeyFrameId id, std::size_t n) const;
  int covisibilityWeight(KeyFrameId a, KeyFrameId b) const;
  /// Attaches `id` to the spanning tree under its heaviest neighbour if it has no parent yet (ORB-SLAM does
  /// this on the first UpdateConnections). Returns the parent (kNoKeyFrame if it has no neighbour or is
  /// the root).
  KeyFrameId connectToSpanningTree(KeyFrameId id);
  KeyFrameId rootKeyFrame() const { return keyframes_.empty() ? kNoKeyFrame : keyframes_.begin()->first; }

  // ---- queries ----
  /// Local window around `centre` with at most maxLocalKeyFrames local keyframes (Table 3.2: 20).
  LocalWindow localWindow(KeyFrameId centre, std::size_t maxLocalKeyFrames = 20) const;
  /// Points observed by keyframe `id` (ascending, no duplicates).
  std::vector<MapPointId> pointsOf(KeyFrameId id) const;
  /// Number of points of `id` observed by at least minObservations keyframes (ORB-SLAM TrackedMapPoints),
  /// counting only those `policy` lets us use when one is given.
  int trackedMapPoints(KeyFrameId id, std::size_t minObservations, const PointUsePolicy* policy = nullptr) const;

  /// Verifies all invariants listed at the top of this file; throws pslam::Error naming the first
  /// violation (prefixed by `context`).
  void checkInvariants(const std::string& context = "map") const;

  // ---- the bag-of-words vocabulary the map was built with (serialized; informational) ----
  /// places::Vocabulary::fingerprint() of the vocabulary of the run that built the map, empty when it had none.
  /// Keyframes' BoW vectors are not stored: a run recomputes them with its own vocabulary, so another one works
  /// too, but its place-recognition results differ (the System warns).
  const std::string& vocabulary() const { return vocabulary_; }
  void setVocabulary(std::string fingerprint) { vocabulary_ = std::move(fingerprint); }

  // ---- what other libraries keep beside the map (serialized, format 2) ----
  /// Named opaque byte blobs: the landmark kinds and graph edges that live outside the map proper (the line store
  /// of libs/lines as "lines", the loop edges of libs/loopclosing as "loop_edges", the direct points of libs/direct
  /// as "direct_points"). Their owners write them before a save and read and check them after a load; the map only
  /// carries them.
  const std::map<std::string, std::string>& extensions() const { return extensions_; }
  /// Null when absent.
  const std::string* extension(const std::string& name) const;
  void setExtension(const std::string& name, std::string bytes) { extensions_[name] = std::move(bytes); }
  void eraseExtension(const std::string& name) { extensions_.erase(name); }

  // ---- counters for ids (serialized) ----
  KeyFrameId nextKeyFrameId() const { return nextKeyFrameId_; }

  bool operator==(const Map& o) const;
  bool operator!=(const Map& o) const { return !(*this == o); }

 private:
  friend struct MapSerializationAccess;
  KeyFrame& kfRef(KeyFrameId id);
  MapPoint& ptRef(MapPointId id);
  void linkObservation(MapPoint& p, KeyFrame& kf, std::size_t keypoint);
  void unlinkObservation(MapPoint& p, KeyFrame& kf);
  void setParent(KeyFrameId child, KeyFrameId parent);

  std::map<KeyFrameId, KeyFrame> keyframes_;
  std::map<MapPointId, MapPoint> points_;
  struct ErasedKeyFrame {
    KeyFrameId parent;
    Eigen::Isometry3d T_cam_parent;
  };
  std::map<KeyFrameId, ErasedKeyFrame> erased_;  ///< see keyFramePoseIncludingErased
  KeyFrameId nextKeyFrameId_ = 0;
  MapPointId nextMapPointId_ = 0;
  std::string vocabulary_;
  std::map<std::string, std::string> extensions_;
};

/// Exact equality of two keyframes / points (all fields, descriptors byte-wise).
bool equalKeyFrames(const KeyFrame& a, const KeyFrame& b);
bool equalMapPoints(const MapPoint& a, const MapPoint& b);

}  // namespace pslam::map
