#include "pslam/tracking/Tracker.h"

#include <algorithm>

#include "pslam/core/Error.h"
#include "pslam/tracking/MonocularInitializer.h"

namespace pslam::tracking {

Tracker::Tracker(map::Map& map, const geometry::PinholeCamera& camera, TrackerParams params,
                 std::unique_ptr<MapInitializer> initializer, std::unique_ptr<PoseSolver> solver, std::uint32_t seed)
    : ctx_(map, camera, params),
      initializer_(initializer ? std::move(initializer)
                               : std::make_unique<MonocularInitializer>(camera, InitializerParams{},
                                                                        optimize::BundleAdjustmentParams{})),
      optimizer_(ctx_, std::move(solver)),
      places_(ctx_, optimizer_),
      motion_(ctx_, optimizer_, places_),
      localMap_(ctx_, optimizer_),
      rng_(seed) {
  ctx_.params.check();
}

void Tracker::enableManhattanPath(const ManhattanPathParams& params, std::unique_ptr<PoseSolver> solver) {
  manhattan_ = std::make_shared<ManhattanPath>(ctx_, optimizer_, motion_, localMap_, params);
  optimizer_.setRotationPriors(params, std::move(solver));
}

std::optional<Eigen::Matrix3d> Tracker::worldManhattanFrame() const {
  return manhattan_ ? manhattan_->worldManhattanFrame() : std::nullopt;
}

void Tracker::addModule(std::shared_ptr<LandmarkModule> module) {
  require(module != nullptr, "Tracker", "null landmark module");
  ctx_.modules.push_back(std::move(module));
}

void Tracker::setPointUsePolicy(std::shared_ptr<const map::PointUsePolicy> policy) {
  // ORB-SLAM*'s policy (every good point) is the same as none: skip the per-point call.
  ctx_.policy = policy && !policy->usesEveryGoodPoint() ? std::move(policy) : nullptr;
}

void Tracker::setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary, const places::PlacesParams& params) {
  places_.setVocabulary(std::move(vocabulary), params);
}

void Tracker::onMapLoaded() {
  initializer_->reset();
  initialized_ = !ctx_.map.keyFrames().empty();
  lost_ = true;
  haveVelocity_ = false;
  ctx_.referenceKeyFrame = map::kNoKeyFrame;
  relocalizedEver_ = false;
  unconfirmedRelocFrames_ = 0;
  localMap_.clear();
  last_ = Frame();
  if (manhattan_) manhattan_->reset();
  places_.onMapReplaced();
}

void Tracker::reset() {
  ctx_.map = map::Map();
  initializer_->reset();
  initialized_ = false;
  lost_ = false;
  haveVelocity_ = false;
  ctx_.referenceKeyFrame = map::kNoKeyFrame;
  relocalizedEver_ = false;
  unconfirmedRelocFrames_ = 0;
  localMap_.clear();
  last_ = Frame();
  if (manhattan_) manhattan_->reset();
  places_.clear();  // keyframe ids start again at 0
}

void Tracker::onKeyFramesMoved(map::KeyFrameId ref, const Eigen::Isometry3d& T_ref_world_before, double scale) {
  if (!last_.hasPose || !ctx_.map.hasKeyFrame(ref) || !(scale > 0.0)) return;
  Eigen::Isometry3d T_last_ref = last_.T_cam_world * T_ref_world_before.inverse();
  T_last_ref.translation() /= scale;
  last_.T_cam_world = T_last_ref * ctx_.map.keyFrame(ref).T_cam_world;
  velocity_.translation() /= scale;
}

map::KeyFrameId Tracker::createKeyFrame(const Frame& frame, bool manhattanTracked) {
  map::Map& map = ctx_.map;
  const map::KeyFrameId id = map.addKeyFrame(toKeyFrame(frame));
  std::vector<map::MapPointId> touched;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId p = frame.mapPointIds[i];
    if (frame.outlier[i] || !ctx_.measurable(p)) continue;
    if (map.addObservation(p, id, i)) touched.push_back(p);
  }
  for (map::MapPointId p : touched) {
    map.computeDistinctiveDescriptor(p);
    map.updateNormalAndDepth(p);
  }
  map.connectToSpanningTree(id);
  if (manhattan_) manhattan_->onKeyFrame(id, frame, manhattanTracked);
  ctx_.referenceKeyFrame = id;
  lastKeyFrameFrame_ = frame.index;
  return id;
}

Tracker::Result Tracker::initialize(Frame& frame, StageTimings& timings) {
  Result res;
  FrameReport& rep = res.report;
  rep.status = FrameStatus::Initializing;
  rep.method = "initializer";
  if (!ctx_.mapUpdates) {
    rep.message = "localization only and no map: nothing to track against";
    return res;
  }
  InitializationOutcome init;
  Frame reference;
  {
    ScopedStage st(timings, "initialization");
    init = initializer_->process(frame, ctx_.map, rng_, &reference);
  }
  rep.matches = init.matches;
  rep.message = init.message;
  if (init.initialized) {
    res.initialReferenceGrey = reference.grey;
    res.initialReferenceSemantic = reference.semantic;
    initialized_ = true;
    lost_ = false;
    rep.status = FrameStatus::Tracking;
    rep.inliers = frame.numMatchedInliers();
    rep.keyFrame = true;
    res.newKeyFrames = {init.kf1, init.kf2};
    for (map::KeyFrameId id : res.newKeyFrames) places_.computeKeyFrameBow(id);
    res.initialReferencePose = std::make_pair(reference.timestamp, reference.T_cam_world);
    if (manhattan_) manhattan_->onInitialized(reference, frame, init.kf1, init.kf2, init.manhattanRotation);
    ctx_.referenceKeyFrame = init.kf2;
    lastKeyFrameFrame_ = frame.index;
    // No velocity yet (as ORB-SLAM after initialization): the next frame is tracked against the reference keyframe.
    haveVelocity_ = false;
    res.hasPose = true;
    res.T_cam_world = frame.T_cam_world;
    res.referenceKeyFrame = ctx_.referenceKeyFrame;
    last_ = frame;
  }
  return res;
}

bool Tracker::trackInMap(Frame& frame, FrameReport& rep, bool& relocalized, bool& manhattanTracked,
                         StageTimings& timings) {
  // The local map is searched 5x wider right after a relocalization (ORB-SLAM).
  const auto radiusFactor = [&] { return relocalizedEver_ && frame.index < lastRelocFrame_ + 2 ? 5.f : 1.f; };
  bool ok = false;
  if (manhattan_) {
    // §4.4.2: the Manhattan rotation and a translation-only estimate first; the 6-DoF path when there is no
    // usable Manhattan rotation or its pose does not validate.
    rep.manhattan.mode = "fallback";
    const MotionState state{last_, lost_, predictedPose(), radiusFactor()};
    if (const std::optional<Eigen::Matrix3d> R = manhattan_->rotation(frame, state, rep.manhattan)) {
      ScopedStage st(timings, "manhattan_tracking");
      Frame attempt = frame;
      if (manhattan_->track(attempt, *R, state, rep.manhattan)) {
        frame = std::move(attempt);
        ok = manhattanTracked = true;
        rep.method = "manhattan";
        rep.manhattan.mode = "manhattan";
        rep.inliers = rep.matches = frame.numMatchedInliers();
      } else {
        optimizer_.clearMeasurements();
      }
    }
    frame.rotationPrior.reset();
  }
  if (manhattanTracked) return true;
  {
    ScopedStage st(timings, "matching");
    if (!lost_) {
      if (haveVelocity_) {
        ok = motion_.trackWithMotionModel(frame, last_, velocity_ * last_.T_cam_world);
        rep.method = "motion";
      }
      if (!ok) {
        ok = motion_.trackReferenceKeyFrame(frame, last_);
        rep.method = "reference";
      }
    }
  }
  if (!ok) {
    ScopedStage st(timings, "relocalization");
    ok = places_.relocalize(frame);
    rep.method = "relocalization";
    if (ok) {
      relocalized = true;
      relocalizedEver_ = true;
      lastRelocFrame_ = frame.index;
    }
  }
  rep.matches = frame.numMatchedInliers();
  if (!ok) return false;
  ScopedStage st(timings, "local_map");
  int cands = 0;
  const int inliers = localMap_.track(frame, radiusFactor(), nullptr, &cands);
  rep.inliers = inliers;
  rep.localMapPoints = cands;
  const bool recentReloc =
      relocalizedEver_ && frame.index < lastRelocFrame_ + static_cast<std::size_t>(ctx_.params.keyFrames.maxFrames);
  return optimizer_.poseSupported(inliers, recentReloc ? ctx_.params.minInliersAfterReloc
                                                       : ctx_.params.minLocalMapInliers);
}

void Tracker::onLost(Result& res) {
  FrameReport& rep = res.report;
  rep.status = FrameStatus::Lost;
  haveVelocity_ = false;
  lost_ = true;
  if (unconfirmedRelocFrames_ > 0) {
    // Lost right after a relocalization: it put the camera at a place that only looked like this one.
    res.retractedFrames = unconfirmedRelocFrames_;
    unconfirmedRelocFrames_ = 0;
    rep.message = "lost " + std::to_string(res.retractedFrames) + " frame(s) after a relocalization: its poses are withdrawn";
  }
  if (ctx_.mapUpdates && ctx_.map.numKeyFrames() <= static_cast<std::size_t>(ctx_.params.resetKeyFrames)) {
    // ORB-SLAM: a map this young is not worth relocalizing into; start over.
    rep.message = (rep.message.empty() ? "" : rep.message + "; ") + "lost with " +
                  std::to_string(ctx_.map.numKeyFrames()) + " keyframes: map reset";
    reset();
    res.mapWasReset = true;
  }
}

std::vector<ModuleFrameReport> Tracker::afterTracking(const Frame& frame, FrameReport& rep, StageTimings& timings) {
  std::vector<ModuleFrameReport> reports;
  for (std::size_t m = 0; m < ctx_.modules.size(); ++m) {
    LandmarkModule& module = *ctx_.modules[m];
    // Localization: the module's store stays as it was loaded; the report still says what the pose used.
    std::optional<ScopedStage> st;
    if (ctx_.mapUpdates) st.emplace(timings, module.name() + "_update");
    reports.push_back(module.afterTracking(frame, ctx_.map, optimizer_.moduleOutliers(m), ctx_.mapUpdates));
    rep.modules.update(reports.back().counts);
  }
  return reports;
}

void Tracker::decideKeyFrame(const Frame& frame, bool manhattanTracked, const std::vector<ModuleFrameReport>& modules,
                             Result& res) {
  FrameReport& rep = res.report;
  KeyFrameDecisionInput kin;
  kin.frameIndex = frame.index;
  kin.lastKeyFrameFrame = lastKeyFrameFrame_;
  kin.lastRelocFrame = lastRelocFrame_;
  kin.relocalizedEver = relocalizedEver_;
  kin.numKeyFrames = ctx_.map.numKeyFrames();
  // ORB-SLAM's TrackedMapPoints over the points the policy lets us use (§3.4.3).
  if (ctx_.map.hasKeyFrame(ctx_.referenceKeyFrame))
    kin.referenceTrackedPoints =
        ctx_.map.trackedMapPoints(ctx_.referenceKeyFrame, kin.numKeyFrames <= 2 ? 2 : 3, ctx_.policy.get());
  // With a point model, the matches of the points active after this frame's update (§3.4.3: "we only consider
  // active points based on the current inlier estimate in the decision"); new points that this frame's
  // measurement activated count, as they do in the reference keyframe's count.
  kin.trackedInliers = ctx_.policy ? rep.activeMatches : rep.inliers;
  kin.localMappingIdle = localMappingIdle_;
  kin.weakInliers = weakTrackingInliers_;
  for (std::size_t m = 0; m < modules.size(); ++m)
    kin.modules.push_back({optimizer_.moduleCarriedPose(m), modules[m].referenceInView, modules[m].referenceActive});
  if (ctx_.mapUpdates && needNewKeyFrame(kin, ctx_.params.keyFrames)) {
    res.newKeyFrames.push_back(createKeyFrame(frame, manhattanTracked));
    unconfirmedRelocFrames_ = 0;  // the map now builds on this pose: too late to withdraw it
    places_.computeKeyFrameBow(res.newKeyFrames.back());
    rep.keyFrame = true;
  } else if (ctx_.mapUpdates && !kin.localMappingIdle) {
    kin.localMappingIdle = true;
    res.keyFrameWaitsForMapping = needNewKeyFrame(kin, ctx_.params.keyFrames);
    res.keyFrameUrgent = res.keyFrameWaitsForMapping && keyFrameUrgent(kin, ctx_.params.keyFrames);
  }
}

Tracker::Result Tracker::track(Frame frame, StageTimings& timings) {
  ctx_.timings = &timings;
  const std::size_t index = frame.index;
  const double timestamp = frame.timestamp;
  const int features = static_cast<int>(frame.size());
  frame.resetMatches();
  optimizer_.clearMeasurements();
  Result res;
  if (!initialized_) {
    res = initialize(frame, timings);
  } else {
    for (const auto& module : ctx_.modules) module->prepareFrame(frame, timings);
    bool relocalized = false, manhattanTracked = false;
    if (!trackInMap(frame, res.report, relocalized, manhattanTracked, timings)) {
      onLost(res);
    } else {
      FrameReport& rep = res.report;
      lost_ = false;
      rep.status = relocalized ? FrameStatus::Relocalized : FrameStatus::Tracking;
      // A relocalization counts once relocalizationCheckFrames more frames are tracked after it.
      if (relocalized)
        unconfirmedRelocFrames_ = ctx_.params.relocalizationCheckFrames > 0 ? 1 : 0;
      else if (unconfirmedRelocFrames_ > 0 &&
               ++unconfirmedRelocFrames_ > static_cast<std::size_t>(ctx_.params.relocalizationCheckFrames))
        unconfirmedRelocFrames_ = 0;
      if (manhattan_) manhattan_->onTracked(frame);
      // §3.4.2: "with each new frame we update the semantic class probabilities, the depth mean, depth variance
      // and the inlier model parameters" of every point the frame measured, before the keyframe decision reads
      // which points are active.
      if (optimizer_.hasMeasurements()) {
        ScopedStage st(timings, "point_model");
        rep.modelUpdates = optimizer_.updatePointModels(frame);
        res.measuredByTracking = true;
      }
      for (std::size_t i = 0; i < frame.size(); ++i) {
        const map::MapPointId id = frame.mapPointIds[i];
        if (id == map::kNoMapPoint || frame.outlier[i]) continue;
        (ctx_.usable(id) ? rep.activeMatches : rep.inactiveMatches)++;
      }
      const std::vector<ModuleFrameReport> modules = afterTracking(frame, rep, timings);
      if (last_.hasPose && !relocalized) {
        velocity_ = frame.T_cam_world * last_.T_cam_world.inverse();
        haveVelocity_ = true;
      }
      decideKeyFrame(frame, manhattanTracked, modules, res);
      res.hasPose = true;
      res.T_cam_world = frame.T_cam_world;
      res.referenceKeyFrame = ctx_.referenceKeyFrame;
      last_ = std::move(frame);
    }
  }
  FrameReport& rep = res.report;
  rep.index = index;
  rep.timestamp = timestamp;
  rep.features = features;
  rep.mapPoints = ctx_.map.numMapPoints();
  rep.keyFrames = ctx_.map.numKeyFrames();
  return res;
}

}  // namespace pslam::tracking
