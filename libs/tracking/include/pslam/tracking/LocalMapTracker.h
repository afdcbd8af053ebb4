#pragma once
// Local-map tracking (ORB-SLAM's TrackLocalMap, thesis §2.4.1): the keyframes that share points with the frame and
// their neighbours make the local map; its points in the frustum are searched by projection and the pose is
// optimized once more, with the landmark modules. Keeps ORB-SLAM's visible / found counters of the points (the
// culling's found ratio), or holds them back while an attempt may still be rejected (the Manhattan path).
#include <vector>

#include "pslam/tracking/FramePoseOptimizer.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/TrackingContext.h"

namespace pslam::tracking {

class LocalMapTracker {
 public:
  LocalMapTracker(TrackingContext& context, FramePoseOptimizer& optimizer) : ctx_(context), optimizer_(optimizer) {}

  /// The visibility counters of one local-map search: map points counted as visible / found.
  struct Counters {
    std::vector<map::MapPointId> visible, found;
  };
  /// Searches the local map at frame.T_cam_world and optimizes the pose (OptimizationMode::final, with modules);
  /// returns the keypoint inliers. `radiusFactor` scales [Tracking] localMapRadius (ORB-SLAM: 5 right after a
  /// relocalization). `deferred`: the counters are collected there instead of applied (applyCounters later).
  /// `candidates` (optional): the local-map points projected into the frame.
  int track(Frame& frame, float radiusFactor = 1.f, Counters* deferred = nullptr, int* candidates = nullptr);
  /// Applies counters an attempt held back (nothing in localization-only mode).
  void applyCounters(const Counters& counters);
  void clear() { localKeyFrames_.clear(); }

 private:
  /// The local keyframes of the frame's matches (and the reference keyframe: the one sharing most points).
  void updateLocalKeyFrames(const Frame& frame);

  TrackingContext& ctx_;
  FramePoseOptimizer& optimizer_;
  std::vector<map::KeyFrameId> localKeyFrames_;
};

}  // namespace pslam::tracking
