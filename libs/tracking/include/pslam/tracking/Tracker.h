#pragma once
// The tracking front end of ORB-SLAM* (thesis §2.4.1, §3.4, §4.4): a short state machine over its parts
// (doc/architecture.md, "Tracking"):
//   not initialized  -> the map initializer (MapInitializer)
//   tracking         -> the Manhattan path (ManhattanPath, when enabled and the frame has a Manhattan frame), else
//                       the motion model or the reference keyframe (MotionTracking), then the local map
//                       (LocalMapTracker); every pose from FramePoseOptimizer, with the landmark modules
//   lost             -> relocalization (Relocalizer)
// then the points' models learn from the frame (§3.4.2), the modules from theirs, and the keyframe decision. It reads
// and extends the map (keyframe insertion, point visibility counters); local mapping runs elsewhere.
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/map/Map.h"
#include "pslam/map/PointUsePolicy.h"
#include "pslam/places/PlacesParams.h"
#include "pslam/places/Vocabulary.h"
#include "pslam/tracking/FramePoseOptimizer.h"
#include "pslam/tracking/FrameReport.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/KeyFrameDecision.h"
#include "pslam/tracking/LandmarkModule.h"
#include "pslam/tracking/LocalMapTracker.h"
#include "pslam/tracking/ManhattanPath.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/MotionTracking.h"
#include "pslam/tracking/PoseSolver.h"
#include "pslam/tracking/Relocalizer.h"
#include "pslam/tracking/TrackingContext.h"
#include "pslam/tracking/TrackingParams.h"

namespace pslam::tracking {

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
    /// initialization, for the modules that keep keyframe images; empty otherwise.
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
  void setMapUpdatesEnabled(bool enabled) { ctx_.mapUpdates = enabled; }
  bool mapUpdatesEnabled() const { return ctx_.mapUpdates; }
  /// A landmark module joins tracking (after those added before).
  void addModule(std::shared_ptr<LandmarkModule> module);
  /// §4.4.2: frames with a Manhattan frame (Frame::R_cam_mf) are first tracked by the ManhattanPath, `solver`
  /// optimizing the translation only (trackingRotation "fixed"); a rejected estimate falls back to 6-DoF tracking.
  void enableManhattanPath(const ManhattanPathParams& params, std::unique_ptr<PoseSolver> solver);
  /// The Manhattan path (null unless enabled): its rotation priors are a local-BA factor source.
  std::shared_ptr<ManhattanPath> manhattanPath() const { return manhattan_; }
  /// R_world_mf of the global Manhattan frame, once known (never without the Manhattan path).
  std::optional<Eigen::Matrix3d> worldManhattanFrame() const;
  /// Bag-of-words place recognition (Relocalizer::setVocabulary); null: exhaustive matching.
  void setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary, const places::PlacesParams& params);
  /// The keyframe tracking last referred to (kNoKeyFrame before the first map).
  map::KeyFrameId referenceKeyFrame() const { return ctx_.referenceKeyFrame; }
  /// The keyframes moved (a loop correction): the last frame's pose follows keyframe `ref`, whose pose was
  /// `T_ref_world_before` and whose camera-frame lengths shrank by `scale` (Sim(3) correction), so that the motion
  /// model predicts the next frame in the corrected map.
  void onKeyFramesMoved(map::KeyFrameId ref, const Eigen::Isometry3d& T_ref_world_before, double scale);
  /// The map was replaced by a loaded one: tracking is initialized and lost, the next frame relocalizes.
  void onMapLoaded();
  void reset();
  bool initialized() const { return initialized_; }
  bool usable(map::MapPointId id) const { return ctx_.usable(id); }
  bool measurable(map::MapPointId id) const { return ctx_.measurable(id); }

  // Building blocks (public for tests)
  /// Local-map tracking of `frame` from its current pose and matches; returns the inliers.
  int trackLocalMap(Frame& frame) { return localMap_.track(frame); }
  /// The point-model updates of the frame's measurements (FramePoseOptimizer::updatePointModels).
  int updatePointModels(const Frame& frame) { return optimizer_.updatePointModels(frame); }
  /// A keyframe from `frame`; `manhattanTracked`: its pose came from the Manhattan path (validated), so its
  /// Manhattan frame is kept for the keyframe's rotation prior.
  map::KeyFrameId createKeyFrame(const Frame& frame, bool manhattanTracked);

 private:
  /// The motion model's pose for the next frame (the last frame's pose without a velocity).
  Eigen::Isometry3d predictedPose() const { return haveVelocity_ ? velocity_ * last_.T_cam_world : last_.T_cam_world; }
  /// Not initialized yet: the frame goes to the map initializer.
  Result initialize(Frame& frame, StageTimings& timings);
  /// The attempts of a frame in a map; true when tracked. `relocalized`, `manhattanTracked`: how.
  bool trackInMap(Frame& frame, FrameReport& report, bool& relocalized, bool& manhattanTracked, StageTimings& timings);
  /// Lost: the counters, the withdrawal of an unconfirmed relocalization and the reset of a young map.
  void onLost(Result& res);
  /// The modules learn from the tracked frame (or only count, in localization) into the report.
  std::vector<ModuleFrameReport> afterTracking(const Frame& frame, FrameReport& report, StageTimings& timings);
  /// ORB-SLAM's NeedNewKeyFrame with this frame's counts; makes the keyframe (or says it waits for mapping).
  void decideKeyFrame(const Frame& frame, bool manhattanTracked, const std::vector<ModuleFrameReport>& modules,
                      Result& res);

  TrackingContext ctx_;
  std::unique_ptr<MapInitializer> initializer_;
  FramePoseOptimizer optimizer_;
  Relocalizer places_;
  MotionTracking motion_;
  LocalMapTracker localMap_;
  std::shared_ptr<ManhattanPath> manhattan_;  ///< null unless enabled
  std::mt19937 rng_;

  bool initialized_ = false;
  bool lost_ = false;
  Frame last_;
  bool haveVelocity_ = false;
  Eigen::Isometry3d velocity_ = Eigen::Isometry3d::Identity();  ///< T_cur_last
  std::size_t lastKeyFrameFrame_ = 0;
  std::size_t lastRelocFrame_ = 0;
  bool relocalizedEver_ = false;
  /// Frames with a pose since the last relocalization that is not yet confirmed (0: none pending).
  std::size_t unconfirmedRelocFrames_ = 0;
  bool localMappingIdle_ = true;
  int weakTrackingInliers_ = 0;
};

}  // namespace pslam::tracking
