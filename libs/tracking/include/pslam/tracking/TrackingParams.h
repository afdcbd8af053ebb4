#pragma once
// Parameters of tracking (thesis §2.4.1, §3.4, §4.4): [Tracking] (ORB-SLAM's tracking thread) and [Manhattan]
// (the structured-scene path of chapter 4). Tables in doc/slam.md.
#include <string>

#include "pslam/core/Params.h"
#include "pslam/features/Matching.h"
#include "pslam/geometry/Pnp.h"
#include "pslam/tracking/KeyFrameDecision.h"

namespace pslam::tracking {

struct TrackerParams {
  float motionModelRadius = 15.f;
  int minMotionMatches = 20;
  int minReferenceMatches = 15;
  float referenceRatio = 0.7f;
  int referenceMaxDistance = features::kOrbThLow;
  int minPoseInliers = 10;
  float localMapRadius = 1.f;
  float localMapRatio = 0.8f;
  int maxLocalKeyFrames = 80;
  int minLocalMapInliers = 30;
  int minInliersAfterReloc = 50;
  int relocalizationCandidates = 5;
  /// A relocalization is kept only if the frames after it are tracked: lost again within this many frames, its
  /// poses are withdrawn (Result::retractedFrames). An aliased place in a repetitive scene passes PnP and the
  /// local map once, but rarely the next frames. 0 = every relocalization counts at once (ORB-SLAM).
  int relocalizationCheckFrames = 2;
  int resetKeyFrames = 5;
  KeyFrameDecisionParams keyFrames;
  geometry::PnpParams pnp;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, motionModelRadius, greaterThan(0), "frame-to-frame search radius factor (ORB-SLAM monocular th = 15)");
    PSLAM_FIELD(v, minMotionMatches, atLeast(1), "below this the search is repeated with twice the radius");
    PSLAM_FIELD(v, minReferenceMatches, atLeast(4), "reference-keyframe / relocalization descriptor matches needed");
    PSLAM_FIELD(v, referenceRatio, inLeftOpen(0, 1), "ratio test of the reference-keyframe matching (SearchByBoW)");
    PSLAM_FIELD(v, referenceMaxDistance, inClosed(0, 256), "descriptor distance of the reference matching (TH_LOW)");
    PSLAM_FIELD(v, minPoseInliers, atLeast(3), "inliers after motion/reference pose optimization");
    PSLAM_FIELD(v, localMapRadius, greaterThan(0), "local-map search radius factor (ORB-SLAM th = 1; 5 after relocalization)");
    PSLAM_FIELD(v, localMapRatio, inLeftOpen(0, 1), "same-level ratio test of the local-map search");
    PSLAM_FIELD(v, maxLocalKeyFrames, atLeast(1), "keyframes of the local map (ORB-SLAM 80)");
    PSLAM_FIELD(v, minLocalMapInliers, atLeast(3), "tracking succeeds with this many inliers after local-map tracking");
    PSLAM_FIELD(v, minInliersAfterReloc,
                satisfies([this](int n) { return n >= minLocalMapInliers; }, "must be >= minLocalMapInliers"),
                "... within keyFrames.maxFrames after a relocalization");
    PSLAM_FIELD(v, relocalizationCandidates, atLeast(1), "keyframes with most descriptor matches tried by PnP");
    PSLAM_FIELD(v, relocalizationCheckFrames, atLeast(0),
                "frames after a relocalization that must be tracked, else its poses are withdrawn (0 = off)");
    PSLAM_FIELD(v, resetKeyFrames, atLeast(2), "lost with at most this many keyframes: reset and re-initialize");
    // Both have a minInliers: both are prefixed (keyFrames.minInliers, pnp.minInliers).
    PSLAM_NESTED(v, keyFrames);
    PSLAM_NESTED(v, pnp);
  }
  PSLAM_PARAMS("Tracking")
};

/// [Manhattan]: the structured-scene path of thesis §4.4 (rotation from the Manhattan frame, translation only,
/// pose validation with fallback to 6-DoF tracking). The mean-shift tracker's own keys are [ManhattanTracker].
struct ManhattanPathParams {
  bool enabled = false;
  /// Pixel stride when collecting the NORMALS of a frame for the mean shift (the tracker subsamples further).
  int normalStride = 4;
  /// The Manhattan rotation is used only when it is within this angle of the motion model's prediction.
  double maxPriorDeviationDeg = 20.0;
  /// Pose validation (§4.4.2): the points of the last `validationKeyFrames` keyframes in view at the estimated
  /// pose; the estimate holds when this many of them and this share are inliers of the frame (matched, with a
  /// whitened reprojection error under chi2 5.991).
  /// Local-map inliers a Manhattan pose needs (the rotation is known: far fewer than 6-DoF tracking's
  /// minLocalMapInliers carry the 3-DoF translation, §4.4.2).
  int minInliers = 15;
  /// Inliers a pose from the Manhattan rotation needs after the motion-model (or reference-keyframe) search, before
  /// the local map: the translation has 3 DoF, where 6-DoF tracking asks for [Tracking] minPoseInliers (ORB-SLAM's
  /// 10) -- about as many inliers per unknown. The local-map step (minInliers) and the validation still follow.
  int minPoseInliers = 6;
  /// With the rotation known, the motion-model search window may grow to this x motionModelRadius (ORB-SLAM: 2),
  /// since only the translation's flow is left to cover.
  int searchRadiusFactor = 4;
  int validationKeyFrames = 3;
  int validationMinInliers = 10;
  double validationMinRatio = 0.2;
  /// §4.4.2 "Pose Refinement": the local-map step optimizes all 6 DoF from the Manhattan estimate (true), or the
  /// translation only with the Manhattan rotation kept (false).
  bool refinePose = true;
  /// > 0: local BA holds every free keyframe whose frame had a validated Manhattan frame near the rotation that
  /// frame gives against the global one (R_kf_mf R_world_mf^T, optimize::RotationPriorFactor, this sigma per
  /// axis), so the map's rotation does not drift away from the Manhattan world. Without it the map drifts by
  /// 2-3 deg over 300 low-texture frames, the Manhattan rotation then disagrees with the map it is tracked
  /// against, its translation-only fit loses half of its matches and tracking is lost (doc/structure.md).
  /// 0 = the thesis' BA, points and lines only (§4.4.2 "Pose Refinement"); 0.5 deg suits normals within a
  /// degree (depth, ground truth).
  double baRotationSigmaDeg = 0.5;
  /// How tracking uses the Manhattan rotation: "fixed" (the thesis, eq. 4.2: the rotation is kept and only the
  /// translation is optimized), or as a soft measurement of a 6-DoF pose optimization (optimize::
  /// RotationPosePriorFactor, sigma trackingRotationSigmaDeg per axis, kept in the local-map step; the search
  /// starts from the motion model's pose): "absolute" R_cam_mf R_world_mf^T, or "relative" the rotation between
  /// the last frame's Manhattan frame and this one's applied to the last frame's rotation. The soft forms are
  /// for normals whose Manhattan frames are degrees off, as a network's: a fixed rotation that far off loses the
  /// matches its translation-only fit needs, and such errors change slowly from frame to frame, so their
  /// increments are far better than their absolute values (doc/structure.md).
  std::string trackingRotation = "fixed";
  double trackingRotationSigmaDeg = 1.0;
  /// After tracking is lost, the Manhattan path keeps trying from the last tracked pose (no motion model) for
  /// this many frames, before relocalization alone is left (0: ORB-SLAM's relocalization only).
  int recoveryFrames = 0;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, enabled, anyValue, "Manhattan rotation + translation-only tracking, with fallback (§4.4); needs NORMALS");
    PSLAM_FIELD(v, normalStride, atLeast(1), "pixel stride of the normals given to the mean shift");
    PSLAM_FIELD(v, maxPriorDeviationDeg, inOpen(0, 45), "Manhattan rotation used only within this angle of the prediction");
    PSLAM_FIELD(v, minInliers, atLeast(3), "local-map inliers a Manhattan pose needs");
    PSLAM_FIELD(v, minPoseInliers, atLeast(2), "inliers after the search with the Manhattan rotation fixed (3 DoF)");
    PSLAM_FIELD(v, searchRadiusFactor, inClosed(2, 16), "widest motion-model search window, x motionModelRadius");
    PSLAM_FIELD(v, validationKeyFrames, atLeast(1), "n of §4.4.2: points of the last n keyframes validate the pose");
    PSLAM_FIELD(v, validationMinInliers, atLeast(0), "... of which this many must be inliers");
    PSLAM_FIELD(v, validationMinRatio, inClosed(0, 1), "... and this share of those in view");
    PSLAM_FIELD(v, refinePose, anyValue, "local-map step: 6 DoF from the Manhattan estimate (true) or translation only");
    PSLAM_FIELD(v, baRotationSigmaDeg, inClosed(0, 45), "local BA: sigma of the keyframes' Manhattan rotation priors, 0 = none");
    PSLAM_FIELD(v, trackingRotation, oneOf({"fixed", "absolute", "relative"}),
                "tracking: Manhattan rotation fixed (eq. 4.2), or a soft prior of a 6-DoF pose (absolute, relative)");
    PSLAM_FIELD(v, trackingRotationSigmaDeg, inOpen(0, 45), "sigma per axis of the soft rotation prior [deg]");
    PSLAM_FIELD(v, recoveryFrames, atLeast(0), "lost: frames the Manhattan path retries from the last tracked pose");
  }
  PSLAM_PARAMS("Manhattan")
};

}  // namespace pslam::tracking
