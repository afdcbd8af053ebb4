#pragma once
// Tracking from the last frame (thesis §2.4.1): ORB-SLAM's TrackWithMotionModel (the last frame's points projected
// at the constant-velocity prediction) and TrackReferenceKeyFrame (the reference keyframe's points matched by
// descriptor: by vocabulary node with a vocabulary, exhaustively without), each followed by a pose optimization.
#include "pslam/tracking/FramePoseOptimizer.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/Relocalizer.h"
#include "pslam/tracking/TrackingContext.h"

namespace pslam::tracking {

class MotionTracking {
 public:
  MotionTracking(TrackingContext& context, FramePoseOptimizer& optimizer, Relocalizer& places)
      : ctx_(context), optimizer_(optimizer), places_(places) {}

  /// Projection search of `last`'s points at frame.T_cam_world; returns the matches. The window grows by 2x while
  /// there are too few matches, up to `widestFactor` x motionModelRadius.
  int searchLastFrame(Frame& frame, const Frame& last, float widestFactor = 2.f);
  /// The frame at `predicted` (the motion model's pose), its matches with `last`, the pose optimized.
  bool trackWithMotionModel(Frame& frame, const Frame& last, const Eigen::Isometry3d& predicted);
  /// The reference keyframe's points matched by descriptor, the pose optimized from `last`'s (or the keyframe's).
  bool trackReferenceKeyFrame(Frame& frame, const Frame& last);

 private:
  TrackingContext& ctx_;
  FramePoseOptimizer& optimizer_;
  Relocalizer& places_;
};

}  // namespace pslam::tracking
