#pragma once
// The tracking front end of ORB-SLAM* (thesis §2.4.1, §3.4): initialization, constant-velocity projection
// tracking with a reference-keyframe fallback, local-map tracking, the keyframe decision and relocalization.
// It reads and extends the map (keyframe insertion, point visibility counters); local mapping runs elsewhere.
#include <cstdint>
#include <map>
#include <optional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>
#include <nlohmann/json.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/geometry/Pnp.h"
#include "pslam/map/Map.h"
#include "pslam/map/PointUsePolicy.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/places/KeyFrameDatabase.h"
#include "pslam/places/PlacesParams.h"
#include "pslam/places/Vocabulary.h"
#include "pslam/tracking/DirectPointSource.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/KeyFrameDecision.h"
#include "pslam/tracking/LineSource.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/MonocularInitializer.h"
#include "pslam/tracking/PoseSolver.h"
#include "pslam/tracking/ProjectionSearch.h"

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

/// What the Manhattan path did in one frame (report.json).
struct ManhattanFrameReport {
  bool normals = false;         ///< the frame had a NORMALS channel (and the path is enabled)
  bool frameValid = false;      ///< the mean shift gave a valid Manhattan frame
  int observedAxes = 0;
  std::string mode = "none";    ///< manhattan | fallback | none (path disabled or not tracking)
  double priorDeviationDeg = -1;  ///< angle between the Manhattan rotation and the motion model's prediction
  double refinementDeg = -1;    ///< rotation the 6-DoF refinement applied to the Manhattan rotation
  int validationInView = 0;     ///< points of the last n keyframes in view at the Manhattan pose
  int validationInliers = 0;    ///< ... that are inliers of the frame
  std::string reason;           ///< why the Manhattan pose was not used (empty when it was)
  nlohmann::json toJson() const;
};

enum class FrameStatus { Initializing, Tracking, Lost, Relocalized };
const char* toString(FrameStatus status);

struct FrameReport {
  std::size_t index = 0;
  double timestamp = 0;
  FrameStatus status = FrameStatus::Initializing;
  std::string method;          ///< initializer / motion / reference / relocalization / reset
  int features = 0;
  int matches = 0;             ///< after motion / reference / relocalization search
  int inliers = 0;             ///< after local-map tracking
  int localMapPoints = 0;      ///< candidates projected in local-map tracking
  int activeMatches = 0;       ///< final matches of points the policy lets tracking use (all of them: heuristic)
  int inactiveMatches = 0;     ///< final matches of points it does not (kept as measurements only, §3.4.2)
  int modelUpdates = 0;        ///< depth measurements applied to the points' models in this frame (§3.4.2)
  DirectFrameCounts direct;    ///< direct points (all 0 without a DirectPointSource)
  ManhattanFrameReport manhattan;  ///< the Manhattan path (§4.4; mode "none" when disabled)
  LineFrameCounts lines;       ///< line segments (all 0 without a LineSource)
  bool keyFrame = false;
  std::size_t mapPoints = 0, keyFrames = 0;
  std::string message;
  nlohmann::json toJson() const;
};

class Tracker {
 public:
  /// `initializer` builds the first map (null: twoView with default parameters), `solver` estimates every
  /// frame's pose (null: full6dof with default parameters).
  Tracker(map::Map& map, const geometry::PinholeCamera& camera, TrackerParams params,
          std::unique_ptr<MapInitializer> initializer, std::unique_ptr<PoseSolver> solver, std::uint32_t seed);

  struct Result {
    FrameReport report;
    bool hasPose = false;
    Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
    /// Keyframes inserted by this call (initialization inserts two); local mapping should process them.
    std::vector<map::KeyFrameId> newKeyFrames;
    /// The points' models already got this frame's measurements (LocalMapper::processKeyFrame's
    /// measuredByTracking); false for the keyframes of a new initial map.
    bool measuredByTracking = false;
    bool mapWasReset = false;
    /// The frame needed a keyframe but local mapping was busy (setLocalMappingIdle(false)), so none was made:
    /// ORB-SLAM then interrupts local BA so that mapping takes the next one sooner.
    bool keyFrameWaitsForMapping = false;
    /// ... and the frame tracks fewer than keyFrames.waitRatio of the reference keyframe's points: the map falls
    /// behind the camera, tracking should wait for mapping before the next frame.
    bool keyFrameUrgent = false;
    /// The reference frame of a successful initialization (gets a pose retroactively), else nullopt.
    std::optional<std::pair<double, Eigen::Isometry3d>> initialReferencePose;
    /// > 0: this frame was lost within relocalizationCheckFrames of a relocalization, so that relocalization
    /// was wrong: the poses of the previous retractedFrames frames (the relocalized one and those tracked after
    /// it) are withdrawn. No keyframe was made from them (a keyframe in the window confirms the relocalization).
    std::size_t retractedFrames = 0;
    /// Reference keyframe after this frame (ORB-SLAM stores frame poses relative to it), kNoKeyFrame if none.
    map::KeyFrameId referenceKeyFrame = map::kNoKeyFrame;
    /// Grey and SEMANTIC images of the initializer's reference frame (the first keyframe) after a successful
    /// initialization, for the front ends that keep keyframe images (direct points); empty otherwise.
    cv::Mat initialReferenceGrey, initialReferenceSemantic;
  };
  /// Tracks one frame (stage timings go to `timings`: matching, pose_optimization, local_map, relocalization).
  Result track(Frame frame, StageTimings& timings);

  void setLocalMappingIdle(bool idle) { localMappingIdle_ = idle; }
  /// Threaded live mode: frames with fewer inliers than this need a keyframe (KeyFrameDecisionInput::weakInliers)
  /// and wait for mapping when it is busy; 0 (default, the sequential mode) = ORB-SLAM's decision.
  void setWeakTrackingInliers(int inliers) { weakTrackingInliers_ = inliers; }
  /// The policy that decides which map points tracking may use (null: every point that is not bad). Give it
  /// the same object local mapping uses (LocalMapper::pointUsePolicy()).
  void setPointUsePolicy(std::shared_ptr<const map::PointUsePolicy> policy);
  /// false = localization only: no initialization, no keyframes, no change to the map (not even the points'
  /// visible/found counters), no reset when lost (the map is kept and relocalization retried).
  void setMapUpdatesEnabled(bool enabled) { mapUpdates_ = enabled; }
  /// Direct points join pose optimization through `source` (§3.4.2); null (default) = keypoints only.
  void setDirectPointSource(std::shared_ptr<DirectPointSource> source) { direct_ = std::move(source); }
  /// §4.4.2: frames with a Manhattan frame (Frame::R_cam_mf) are first tracked with its rotation and `solver`
  /// optimizing the translation only; the estimate is validated and, when it fails, the frame is tracked by the
  /// 6-DoF path. The global Manhattan frame is the initial reference frame's (or the first tracked one's).
  void enableManhattanPath(ManhattanPathParams params, std::unique_ptr<PoseSolver> solver);
  /// R_world_mf of the global Manhattan frame, once known.
  const std::optional<Eigen::Matrix3d>& worldManhattanFrame() const { return R_world_mf_; }
  /// Rotation priors for the free keyframes of a BA window (ManhattanPathParams::baRotationSigmaDeg): each
  /// keyframe's Manhattan frame, labelled as its current pose predicts, against the global one. Only keyframes
  /// whose frame the Manhattan path tracked (its rotation validated, §4.4.2) or the decoupled initializer built
  /// have one: a scene whose "Manhattan frames" never validate (a road) gets no prior at all. A keyframe whose
  /// Manhattan frame is more than maxPriorDeviationDeg from its pose gets none. Empty when the sigma is 0.
  std::vector<std::shared_ptr<optimize::BAFactor>> manhattanRotationPriors(const optimize::BAProblem& problem) const;
  /// Line segments join pose optimization through `source` (eq. 2.59, §2.4.4); null (default) = no lines.
  void setLineSource(std::shared_ptr<LineSource> source) { lines_ = std::move(source); }
  /// Bag-of-words place recognition (libs/places, doc/places.md): every new keyframe gets its BoW vector and
  /// direct index; relocalization takes its candidates from the keyframe database and matches them by vocabulary
  /// node (params.relocalization), reference-keyframe tracking matches by node (params.referenceTracking). The
  /// keyframes already in the map get theirs now. Null: no vocabulary (exhaustive matching).
  void setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary, const places::PlacesParams& params);
  const std::shared_ptr<const places::Vocabulary>& vocabulary() const { return vocabulary_; }
  /// The keyframe tracking last referred to (kNoKeyFrame before the first map).
  map::KeyFrameId referenceKeyFrame() const { return referenceKeyFrame_; }
  /// The keyframes moved (a loop correction): the last frame's pose follows keyframe `ref`, whose pose was
  /// `T_ref_world_before` and whose camera-frame lengths shrank by `scale` (Sim(3) correction), so that the motion
  /// model predicts the next frame in the corrected map.
  void onKeyFramesMoved(map::KeyFrameId ref, const Eigen::Isometry3d& T_ref_world_before, double scale);
  bool mapUpdatesEnabled() const { return mapUpdates_; }
  /// The map was replaced by a loaded one: tracking is initialized and lost, the next frame relocalizes.
  void onMapLoaded();
  void reset();
  bool initialized() const { return initialized_; }
  const Frame& lastFrame() const { return last_; }
  const PoseSolver& poseSolver() const { return *solver_; }
  const MapInitializer& mapInitializer() const { return *initializer_; }
  /// May tracking use map point `id` for the pose (exists, not bad, allowed by the point-use policy)?
  bool usable(map::MapPointId id) const;
  /// May tracking search and measure it (exists, not bad)? Matches of measurable points that are not usable
  /// never enter pose optimization; they stay matched when they agree with the estimated pose, so keyframes
  /// observe them and their model is updated (§3.4.2).
  bool measurable(map::MapPointId id) const;
  /// chi_R of Table 3.2: a measured-only match is kept when its whitened squared reprojection error is below.
  static constexpr double kEvidenceChi2 = 5.991;

  // Building blocks (public for tests)
  /// Pose optimization of `frame` against its matches (and, in the tracking attempts, the direct points of the
  /// DirectPointSource, coarse to fine); outliers are unmatched afterwards. Returns the keypoint inliers.
  int optimizeFramePose(Frame& frame);
  /// Did the last optimizeFramePose succeed: `keypointInliers` >= `minKeypointInliers`, or, when direct points
  /// took part, keypoint inliers / minKeypointInliers + direct inliers / DirectPointSource::minInliers >= 1
  /// (+ line inliers / LineSource::minInliers when lines took part).
  bool poseSupported(int keypointInliers, int minKeypointInliers) const;
  bool trackWithMotionModel(Frame& frame);
  bool trackReferenceKeyFrame(Frame& frame);
  /// Returns inliers after local-map tracking.
  int trackLocalMap(Frame& frame, int* localCandidates = nullptr);
  bool relocalize(Frame& frame);
  /// §4.4.2: tracks `frame` with rotation `R_cam_world` fixed (motion-model search, local map) and validates the
  /// pose; fills `report`. False when the estimate is rejected (the caller falls back to 6-DoF tracking).
  bool trackWithManhattanRotation(Frame& frame, const Eigen::Matrix3d& R_cam_world, ManhattanFrameReport& report);
  /// The rotation prior R_cam_world of `frame` from its Manhattan frame and the global one, when it is within
  /// maxPriorDeviationDeg of the motion model's prediction; else nullopt with the reason in `report`.
  std::optional<Eigen::Matrix3d> manhattanRotation(const Frame& frame, ManhattanFrameReport& report) const;
  /// R_cam_world from a Manhattan frame R_cam_mf and the global one (R_world_mf_ must be known), the axes
  /// labelled as the rotation guess R_guess predicts; `deviationDeg` = the angle between the two.
  Eigen::Matrix3d rotationFromManhattanFrame(const Eigen::Matrix3d& R_cam_mf, const Eigen::Matrix3d& R_guess,
                                             double& deviationDeg) const;
  /// `manhattanTracked`: the frame's pose came from the Manhattan path (validated), so its Manhattan frame is kept
  /// for the keyframe's rotation prior.
  map::KeyFrameId createKeyFrame(const Frame& frame, bool manhattanTracked);
  /// §3.4.2: applies the measurements of the frame's matches (every match that entered pose optimization in
  /// the tracking attempt that succeeded, outliers of the pose included) to the points' models. Returns the
  /// number of depth updates. Nothing without a learning policy or in localization-only mode.
  int updatePointModels(const Frame& frame);

 private:
  void updateLocalKeyFrames(const Frame& frame);
  /// Projection search of the last frame's points at frame.T_cam_world (motion-model matching); returns matches.
  /// The window grows by 2x while there are too few matches, up to `widestFactor` x motionModelRadius.
  int searchLastFrame(Frame& frame, float widestFactor = 2.f);
  /// The motion model's pose for the next frame (the last frame's pose without a velocity).
  Eigen::Isometry3d predictedPose() const { return haveVelocity_ ? velocity_ * last_.T_cam_world : last_.T_cam_world; }
  /// The frame's rotationPrior is a soft measurement of its pose (ManhattanPathParams::trackingRotation
  /// "absolute" / "relative"), not a fixed rotation.
  bool softRotationPrior(const Frame& frame) const;
  /// The frame's rotation is fixed by its prior (trackingRotation "fixed" with a translation-only solver): its pose
  /// has 3 DoF.
  bool fixedRotation(const Frame& frame) const;
  /// The pose solver of this frame: the translation-only one when the frame has a fixed rotation prior.
  const PoseSolver& solverFor(const Frame& frame) const;
  /// Inliers the motion-model / reference-keyframe pose of this frame needs: ManhattanPathParams::minPoseInliers
  /// with a fixed rotation (3 DoF), else TrackerParams::minPoseInliers.
  int minPoseInliersFor(const Frame& frame) const;
  /// BoW vector and direct index of keyframe `id` in the vocabulary, when it has none yet.
  void computeKeyFrameBow(map::KeyFrameId id);
  /// Same for a frame (once per frame).
  void computeFrameBow(Frame& frame) const;
  /// The keyframe database holds exactly the map's keyframes (new ones added, culled ones erased).
  void syncKeyFrameDatabase();
  /// Relocalization candidates with their descriptor matches (frame keypoint -> point): by the keyframe database
  /// and node-guided matching with a vocabulary, else by exhaustive matching against every keyframe.
  struct RelocCandidate {
    map::KeyFrameId kf;
    std::vector<std::pair<std::size_t, map::MapPointId>> matches;
  };
  std::vector<RelocCandidate> relocalizationCandidates(Frame& frame);
  /// Every match of `frame` that entered pose optimization (keypoint per point, the last one wins), so that
  /// outliers of the pose are measurements of their points too.
  void recordMeasurements(const Frame& frame);

  map::Map& map_;
  geometry::PinholeCamera camera_;
  TrackerParams params_;
  std::unique_ptr<MapInitializer> initializer_;
  std::unique_ptr<PoseSolver> solver_;
  std::shared_ptr<const map::PointUsePolicy> policy_;
  bool mapUpdates_ = true;
  std::mt19937 rng_;

  bool initialized_ = false;
  bool lost_ = false;
  Frame last_;
  bool haveVelocity_ = false;
  Eigen::Isometry3d velocity_ = Eigen::Isometry3d::Identity();  ///< T_cur_last
  map::KeyFrameId referenceKeyFrame_ = map::kNoKeyFrame;
  std::size_t lastKeyFrameFrame_ = 0;
  std::size_t lastRelocFrame_ = 0;
  bool relocalizedEver_ = false;
  /// Frames with a pose since the last relocalization that is not yet confirmed (0: none pending).
  std::size_t unconfirmedRelocFrames_ = 0;
  bool localMappingIdle_ = true;
  int weakTrackingInliers_ = 0;
  std::vector<map::KeyFrameId> localKeyFrames_;
  StageTimings* timings_ = nullptr;  ///< of the current track() call
  std::map<map::MapPointId, std::size_t> measured_;  ///< of the current track() call (recordMeasurements)
  std::shared_ptr<DirectPointSource> direct_;
  std::shared_ptr<const places::Vocabulary> vocabulary_;
  places::PlacesParams placesParams_;
  places::KeyFrameDatabase keyFrameDatabase_;
  bool manhattan_ = false;
  ManhattanPathParams manhattanParams_;
  std::unique_ptr<PoseSolver> manhattanSolver_;
  std::optional<Eigen::Matrix3d> R_world_mf_;
  /// R_cam_mf of the keyframes whose frame had a Manhattan frame (manhattanRotationPriors).
  std::map<map::KeyFrameId, Eigen::Matrix3d> keyFrameManhattan_;
  /// Visibility counters of local-map tracking are held back while a Manhattan attempt may still be rejected.
  bool deferCounters_ = false;
  std::vector<map::MapPointId> deferredVisible_, deferredFound_;
  bool useDirect_ = false;              ///< direct points take part in the current attempt (not relocalization)
  bool finalOptimization_ = false;      ///< the local-map pose optimization is running
  int directFactors_ = 0;               ///< of the last optimizeFramePose
  int directInliers_ = 0;
  std::vector<bool> directOutliers_;
  // ---- line segments (LineSource), in the same attempts as the direct points
  std::shared_ptr<LineSource> lines_;
  int lineFactors_ = 0;                 ///< of the last optimizeFramePose
  int lineInliers_ = 0;
  std::vector<bool> lineOutliers_;
};

}  // namespace pslam::tracking
