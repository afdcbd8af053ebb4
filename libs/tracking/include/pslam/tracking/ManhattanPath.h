#pragma once
// The structured-scene path of tracking (thesis §4.4, doc/structure.md): a frame with a Manhattan frame (its
// NORMALS through the mean-shift tracker) is first tracked with the rotation R_cam_mf R_world_mf^T (eq. 4.2: kept
// fixed with a translation-only solver, or a soft prior of a 6-DoF pose), refined on the local map and validated
// against the points of the last keyframes; the caller falls back to 6-DoF tracking when it is rejected. The global
// Manhattan frame is the initial reference frame's (§4.4.1) or the first tracked one's. As an
// optimize::BAFactorSource it holds local BA's free keyframes near the rotation their validated Manhattan frame
// gives ([Manhattan] baRotationSigmaDeg).
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "pslam/optimize/BAFactorSource.h"
#include "pslam/tracking/FrameReport.h"
#include "pslam/tracking/FramePoseOptimizer.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/LocalMapTracker.h"
#include "pslam/tracking/MotionTracking.h"
#include "pslam/tracking/TrackingContext.h"

namespace pslam::tracking {

/// Where tracking stands before a frame: the last frame, whether it was lost, and the motion model's prediction.
struct MotionState {
  const Frame& last;
  bool lost = false;
  Eigen::Isometry3d predicted = Eigen::Isometry3d::Identity();  ///< the last frame's pose without a velocity
  float localMapRadiusFactor = 1.f;  ///< LocalMapTracker::track's (5 right after a relocalization)
};

class ManhattanPath : public optimize::BAFactorSource {
 public:
  /// Checks `params`.
  ManhattanPath(TrackingContext& context, FramePoseOptimizer& optimizer, MotionTracking& motion,
                LocalMapTracker& localMap, const ManhattanPathParams& params);

  /// The rotation prior R_cam_world of `frame` from its Manhattan frame and the global one, when it is within
  /// maxPriorDeviationDeg of the prediction; else nullopt with the reason in `report`.
  std::optional<Eigen::Matrix3d> rotation(const Frame& frame, const MotionState& state,
                                          ManhattanFrameReport& report) const;
  /// §4.4.2: tracks `frame` with rotation `R_cam_world` (motion-model search, else the reference keyframe; the local
  /// map) and validates the pose; fills `report`. False when the estimate is rejected.
  bool track(Frame& frame, const Eigen::Matrix3d& R_cam_world, const MotionState& state, ManhattanFrameReport& report);
  /// R_cam_world from a Manhattan frame R_cam_mf and the global one (which must be known), the axes labelled as the
  /// rotation guess R_guess predicts; `deviationDeg` = the angle between the two.
  Eigen::Matrix3d rotationFromManhattanFrame(const Eigen::Matrix3d& R_cam_mf, const Eigen::Matrix3d& R_guess,
                                             double& deviationDeg) const;

  /// A new map: the global Manhattan frame from the reference frame's (or the second frame's); with a Manhattan
  /// initialization both keyframes keep their Manhattan frames for the BA priors.
  void onInitialized(const Frame& reference, const Frame& frame, map::KeyFrameId kf1, map::KeyFrameId kf2,
                     bool manhattanInitialization);
  /// A tracked frame: a map without a global Manhattan frame takes the frame's.
  void onTracked(const Frame& frame);
  /// A keyframe made from `frame`: its Manhattan frame is kept when the path tracked the frame (validated).
  void onKeyFrame(map::KeyFrameId id, const Frame& frame, bool manhattanTracked);
  void reset();
  const std::optional<Eigen::Matrix3d>& worldManhattanFrame() const { return R_world_mf_; }
  const ManhattanPathParams& params() const { return params_; }

  /// optimize::BAFactorSource: rotation priors for the free keyframes of a BA window, each keyframe's Manhattan
  /// frame labelled as its current pose predicts, against the global one. Only keyframes whose frame the path
  /// tracked (validated) or the Manhattan initializer built have one; a keyframe whose Manhattan frame is more than
  /// maxPriorDeviationDeg from its pose gets none. Empty when the sigma is 0.
  std::vector<std::shared_ptr<optimize::BAFactor>> bundleAdjustmentFactors(const map::Map& map,
                                                                          const optimize::BAProblem& problem) override;

 private:
  TrackingContext& ctx_;
  FramePoseOptimizer& optimizer_;
  MotionTracking& motion_;
  LocalMapTracker& localMap_;
  ManhattanPathParams params_;
  std::optional<Eigen::Matrix3d> R_world_mf_;
  /// R_cam_mf of the keyframes whose frame had a validated Manhattan frame.
  std::map<map::KeyFrameId, Eigen::Matrix3d> keyFrameManhattan_;
};

}  // namespace pslam::tracking
