#pragma once
// Pose optimization of a tracked frame (ORB-SLAM's PoseOptimization, thesis §2.4.1, eq. 3.6): the keypoint matches
// the point-use policy allows, the factors of the landmark modules that join the attempt (photometric ones coarse
// to fine), and the frame's rotation prior (fixed: translation-only solver, eq. 4.2; or soft: a 6-DoF prior). It
// also keeps the frame's measurements (§3.4.2: every match that entered the optimization of the attempt that
// succeeded updates its point's model) and each module's outlier flags of the last optimization.
#include <cstddef>
#include <map>
#include <memory>
#include <vector>

#include "pslam/tracking/Frame.h"
#include "pslam/tracking/PoseSolver.h"
#include "pslam/tracking/TrackingContext.h"

namespace pslam::tracking {

/// How one pose optimization is run; the attempt says it.
struct OptimizationMode {
  /// The attempt starts from a pose guess (motion model, reference keyframe, local map, Manhattan rotation): the
  /// landmark modules may join. Relocalization (a pose from PnP) runs on keypoints alone.
  bool withModules = false;
  bool final = false;  ///< the frame's last optimization, after the local-map search
};

class FramePoseOptimizer {
 public:
  /// `solver` estimates every pose (null: full6dof with default parameters).
  FramePoseOptimizer(TrackingContext& context, std::unique_ptr<PoseSolver> solver);

  /// The Manhattan path's use of a frame's rotation prior ([Manhattan] trackingRotation): "fixed" optimizes the
  /// translation only with `translationOnly`, "absolute" / "relative" add the prior as a soft measurement.
  void setRotationPriors(const ManhattanPathParams& params, std::unique_ptr<PoseSolver> translationOnly);

  /// Optimizes frame.T_cam_world against its matches; outliers are unmatched afterwards, matches of points the
  /// policy does not allow stay when they agree with the pose (chi_R of Table 3.2). Returns the keypoint inliers.
  int optimize(Frame& frame, OptimizationMode mode);
  /// Did the last optimize() succeed: `keypointInliers` >= `minKeypointInliers`, or, with modules that took part,
  /// keypoint inliers / minKeypointInliers + each module's inliers / its minInliers() >= 1.
  bool poseSupported(int keypointInliers, int minKeypointInliers) const;
  /// Inliers the motion-model / reference-keyframe pose of this frame needs: [Manhattan] minPoseInliers with a
  /// fixed rotation (3 DoF), else [Tracking] minPoseInliers.
  int minPoseInliersFor(const Frame& frame) const;
  /// The frame's rotation prior is a soft measurement of its pose (trackingRotation "absolute" / "relative").
  bool softRotationPrior(const Frame& frame) const;

  /// Forgets the measurements recorded so far (a new attempt starts).
  void clearMeasurements() { measured_.clear(); }
  bool hasMeasurements() const { return !measured_.empty(); }
  /// §3.4.2: applies the measurements of the frame's matches (every match that entered pose optimization in the
  /// attempt that succeeded, outliers of the pose included) to the points' models. Returns the depth updates.
  /// Nothing without a learning policy or in localization-only mode.
  int updatePointModels(const Frame& frame);

  /// Module `m`'s factors in the last optimization, their inliers and outlier flags ({pyramid, factors}).
  int moduleFactors(std::size_t m) const { return records_.size() > m ? records_[m].factors : 0; }
  int moduleInliers(std::size_t m) const { return records_.size() > m ? records_[m].inliers : 0; }
  const std::vector<bool>& moduleOutliers(std::size_t m) const;
  /// Module `m`'s inliers alone would have carried the last pose.
  bool moduleCarriedPose(std::size_t m) const;

  /// chi_R of Table 3.2: a measured-only match is kept when its whitened squared reprojection error is below.
  static constexpr double kEvidenceChi2 = 5.991;

 private:
  /// Every match of `frame` that enters pose optimization (keypoint per point, the last one wins), so that
  /// outliers of the pose are measurements of their points too.
  void recordMeasurements(const Frame& frame);
  /// The rotation of this frame is fixed by its prior (trackingRotation "fixed" with a translation-only solver).
  bool fixedRotation(const Frame& frame) const;
  const PoseSolver& solverFor(const Frame& frame) const;

  TrackingContext& ctx_;
  std::unique_ptr<PoseSolver> solver_;
  std::unique_ptr<PoseSolver> translationOnly_;  ///< null without the Manhattan path
  std::string trackingRotation_ = "fixed";
  double trackingRotationSigmaDeg_ = 1.0;
  int fixedRotationMinPoseInliers_ = 6;
  std::map<map::MapPointId, std::size_t> measured_;
  struct ModuleRecord {
    int factors = 0, inliers = 0;
    std::vector<bool> outliers;
  };
  std::vector<ModuleRecord> records_;  ///< per module, of the last optimize()
};

}  // namespace pslam::tracking
