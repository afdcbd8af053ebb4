#include "pslam/tracking/ManhattanPath.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "pslam/core/Error.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/optimize/RotationPriorFactor.h"

namespace pslam::tracking {

ManhattanPath::ManhattanPath(TrackingContext& context, FramePoseOptimizer& optimizer, MotionTracking& motion,
                             LocalMapTracker& localMap, const ManhattanPathParams& params)
    : ctx_(context), optimizer_(optimizer), motion_(motion), localMap_(localMap), params_(params) {
  params_.check();
}

void ManhattanPath::reset() {
  R_world_mf_.reset();  // found again on the first tracked frame with a Manhattan frame
  keyFrameManhattan_.clear();
}

void ManhattanPath::onInitialized(const Frame& reference, const Frame& frame, map::KeyFrameId kf1,
                                  map::KeyFrameId kf2, bool manhattanInitialization) {
  // §4.4.1: "we use the MW orientation found in the first image as our global MW frame".
  if (reference.R_cam_mf)
    R_world_mf_ = reference.T_cam_world.linear().transpose() * *reference.R_cam_mf;
  else if (frame.R_cam_mf)
    R_world_mf_ = frame.T_cam_world.linear().transpose() * *frame.R_cam_mf;
  // Rotation priors only for keyframes whose Manhattan frame the system trusted (bundleAdjustmentFactors).
  if (manhattanInitialization && reference.R_cam_mf && frame.R_cam_mf) {
    keyFrameManhattan_[kf1] = *reference.R_cam_mf;
    keyFrameManhattan_[kf2] = *frame.R_cam_mf;
  }
}

void ManhattanPath::onTracked(const Frame& frame) {
  // A map initialized (or loaded) without a Manhattan frame takes the first tracked frame's as the global one.
  if (!R_world_mf_ && frame.R_cam_mf) R_world_mf_ = frame.T_cam_world.linear().transpose() * *frame.R_cam_mf;
}

void ManhattanPath::onKeyFrame(map::KeyFrameId id, const Frame& frame, bool manhattanTracked) {
  if (manhattanTracked && frame.R_cam_mf) keyFrameManhattan_[id] = *frame.R_cam_mf;
  for (auto it = keyFrameManhattan_.begin(); it != keyFrameManhattan_.end();)
    it = ctx_.map.hasKeyFrame(it->first) ? std::next(it) : keyFrameManhattan_.erase(it);  // culled keyframes
}

std::optional<Eigen::Matrix3d> ManhattanPath::rotation(const Frame& frame, const MotionState& state,
                                                       ManhattanFrameReport& report) const {
  if (!frame.R_cam_mf) {
    report.reason = "no Manhattan frame";
    return std::nullopt;
  }
  if (!R_world_mf_) {
    report.reason = "global Manhattan frame not known yet";
    return std::nullopt;
  }
  // Lost: the last tracked pose is the prediction for up to recoveryFrames frames.
  const Frame& last = state.last;
  const bool recovering = state.lost && last.hasPose && frame.index <= last.index + params_.recoveryFrames;
  if ((state.lost && !recovering) || !last.hasPose) {
    report.reason = "no pose prediction";
    return std::nullopt;
  }
  double deviation = 0.0;
  const Eigen::Matrix3d R_cam_world = rotationFromManhattanFrame(*frame.R_cam_mf, state.predicted.linear(), deviation);
  report.priorDeviationDeg = deviation;
  if (deviation > params_.maxPriorDeviationDeg) {
    report.reason = "Manhattan rotation " + std::to_string(deviation) + " deg from the prediction";
    return std::nullopt;
  }
  // "relative": the increment between two Manhattan frames applied to the last frame's rotation (the first
  // frame after a gap in Manhattan frames takes the absolute one).
  if (params_.trackingRotation == "relative" && last.R_cam_mf) {
    double lastDeviation = 0.0;
    const Eigen::Matrix3d R_last = rotationFromManhattanFrame(*last.R_cam_mf, last.T_cam_world.linear(), lastDeviation);
    return Eigen::Matrix3d(R_cam_world * R_last.transpose() * last.T_cam_world.linear());
  }
  return R_cam_world;
}

Eigen::Matrix3d ManhattanPath::rotationFromManhattanFrame(const Eigen::Matrix3d& R_cam_mf,
                                                          const Eigen::Matrix3d& R_guess, double& deviationDeg) const {
  // The axes re-labelled to the guess's (the mean-shift tracker keeps labels from frame to frame, but
  // re-initializations may permute them), then R_cam_world = R_cam_mf R_world_mf^T (§4.4.2).
  const Eigen::Matrix3d labelled = manhattan::alignToReference(R_cam_mf, R_guess * *R_world_mf_, &deviationDeg);
  return labelled * R_world_mf_->transpose();
}

std::vector<std::shared_ptr<optimize::BAFactor>> ManhattanPath::bundleAdjustmentFactors(
    const map::Map& /*map*/, const optimize::BAProblem& problem) {
  std::vector<std::shared_ptr<optimize::BAFactor>> factors;
  if (!R_world_mf_ || !(params_.baRotationSigmaDeg > 0.0)) return factors;
  const double sigma = params_.baRotationSigmaDeg * M_PI / 180.0;
  for (const auto& [id, kf] : problem.keyframes) {
    if (kf.fixed) continue;
    const auto mf = keyFrameManhattan_.find(id);
    if (mf == keyFrameManhattan_.end()) continue;
    double deviation = 0.0;
    const Eigen::Matrix3d R_kf_world = rotationFromManhattanFrame(mf->second, kf.T_cam_world.linear(), deviation);
    if (deviation > params_.maxPriorDeviationDeg) continue;
    factors.push_back(std::make_shared<optimize::RotationPriorFactor>(id, R_kf_world, sigma));
  }
  return factors;
}

bool ManhattanPath::track(Frame& frame, const Eigen::Matrix3d& R_cam_world, const MotionState& state,
                          ManhattanFrameReport& report) {
  frame.resetMatches();
  optimizer_.clearMeasurements();
  frame.rotationPrior = R_cam_world;
  // The motion model's camera centre with the Manhattan rotation.
  const Eigen::Isometry3d& predicted = state.predicted;
  const Eigen::Vector3d centre = -(predicted.linear().transpose() * predicted.translation());
  if (optimizer_.softRotationPrior(frame)) {
    // A soft prior may be degrees off: the search starts from the motion model's pose, the prior only enters
    // the optimization.
    frame.T_cam_world = predicted;
  } else {
    frame.T_cam_world.linear() = R_cam_world;
    frame.T_cam_world.translation() = -(R_cam_world * centre);
  }
  // Motion-model search first; when the frame moved too far for it, the reference keyframe's descriptor matches
  // (with the rotation fixed, a few of them fix the translation).
  const int n = motion_.searchLastFrame(frame, state.last, static_cast<float>(params_.searchRadiusFactor));
  // With the rotation fixed, the 3-DoF translation needs fewer matches than 6-DoF tracking's minMotionMatches, and
  // any landmark module may make up for the rest.
  const int enough = std::min(ctx_.params.minMotionMatches, params_.minInliers);
  bool found = (n >= enough || !ctx_.modules.empty()) &&
               optimizer_.poseSupported(optimizer_.optimize(frame, {/*withModules=*/true}),
                                        optimizer_.minPoseInliersFor(frame));
  if (!found) found = motion_.trackReferenceKeyFrame(frame, state.last);
  if (!found) {
    report.reason = "too few matches with the Manhattan rotation (motion model " + std::to_string(n) + ")";
    return false;
  }
  // §4.4.2 "Pose Refinement": the local map refines the Manhattan estimate in all 6 DoF ("not limited to MW
  // conform solutions"), or keeps the rotation when refinePose = false. A soft prior stays: the refinement is
  // 6-DoF either way, and the prior holds the rotation where the local map has too few points to fix it.
  if (params_.refinePose && !optimizer_.softRotationPrior(frame)) frame.rotationPrior.reset();
  // The visibility counters count only once the pose is accepted.
  LocalMapTracker::Counters deferred;
  const int inliers = localMap_.track(frame, state.localMapRadiusFactor, &deferred);
  report.refinementDeg = manhattan::rotationAngleDeg(R_cam_world, frame.T_cam_world.linear());
  if (!optimizer_.poseSupported(inliers, params_.minInliers)) {
    report.reason = "too few local-map inliers with the Manhattan rotation (" + std::to_string(inliers) + ")";
    return false;
  }
  // Pose validation (§4.4.2): the points of the last n keyframes in view at the estimated pose, and how many of
  // them the frame holds as inliers (matched and kept by the chi-square test of the optimization).
  std::set<map::MapPointId> recent;
  int taken = 0;
  for (auto it = ctx_.map.keyFrames().rbegin(); it != ctx_.map.keyFrames().rend() && taken < params_.validationKeyFrames;
       ++it, ++taken)
    for (map::MapPointId p : ctx_.map.pointsOf(it->first))
      if (ctx_.usable(p)) recent.insert(p);
  std::set<map::MapPointId> held;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (frame.mapPointIds[i] != map::kNoMapPoint && !frame.outlier[i]) held.insert(frame.mapPointIds[i]);
  for (map::MapPointId p : recent) {
    const Eigen::Vector3d pc = frame.T_cam_world * ctx_.map.worldPosition(p);
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d uv = frame.camera.project(pc);
    if (!frame.bounds.contains(uv.x(), uv.y())) continue;
    ++report.validationInView;
    if (held.count(p)) ++report.validationInliers;
  }
  if (report.validationInliers < params_.validationMinInliers ||
      report.validationInliers < params_.validationMinRatio * report.validationInView) {
    report.reason = "validation: " + std::to_string(report.validationInliers) + " of " +
                    std::to_string(report.validationInView) + " recent points in view are inliers";
    return false;
  }
  localMap_.applyCounters(deferred);
  return true;
}

}  // namespace pslam::tracking
