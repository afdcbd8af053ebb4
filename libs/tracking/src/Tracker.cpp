#include "pslam/tracking/Tracker.h"

#include <algorithm>
#include <optional>
#include <set>

#include "pslam/core/Error.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/optimize/RotationPriorFactor.h"
#include "pslam/places/BowMatching.h"

namespace pslam::tracking {

// ---------------------------------------------------------------- parameters
PSLAM_DEFINE_PARAMS(TrackerParams)
PSLAM_DEFINE_PARAMS(ManhattanPathParams)

nlohmann::json ManhattanFrameReport::toJson() const {
  return {{"normals", normals},
          {"frame_valid", frameValid},
          {"observed_axes", observedAxes},
          {"mode", mode},
          {"prior_deviation_deg", priorDeviationDeg},
          {"refinement_deg", refinementDeg},
          {"validation_in_view", validationInView},
          {"validation_inliers", validationInliers},
          {"reason", reason}};
}

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::Initializing: return "initializing";
    case FrameStatus::Tracking: return "tracking";
    case FrameStatus::Lost: return "lost";
    case FrameStatus::Relocalized: return "relocalized";
  }
  return "?";
}

nlohmann::json FrameReport::toJson() const {
  return {{"index", index},       {"timestamp", timestamp}, {"status", toString(status)},
          {"method", method},     {"features", features},   {"matches", matches},
          {"inliers", inliers},   {"local_map_points", localMapPoints}, {"keyframe", keyFrame},
          {"active_matches", activeMatches}, {"inactive_matches", inactiveMatches}, {"model_updates", modelUpdates},
          {"direct_factors", direct.factors}, {"direct_inliers", direct.inliers}, {"direct_active", direct.active},
          {"direct_inactive", direct.inactive}, {"direct_measured", direct.measured},
          {"direct_reference_in_view", direct.referenceInView}, {"direct_reference_active", direct.referenceActive},
          {"manhattan", manhattan.toJson()},
          {"lines_detected", lines.detected}, {"lines_visible", lines.visible}, {"lines_factors", lines.factors},
          {"lines_inliers", lines.inliers},
          {"map_points", mapPoints}, {"keyframes", keyFrames}, {"message", message}};
}

// ---------------------------------------------------------------- tracker
Tracker::Tracker(map::Map& map, const geometry::PinholeCamera& camera, TrackerParams params,
                 std::unique_ptr<MapInitializer> initializer, std::unique_ptr<PoseSolver> solver, std::uint32_t seed)
    : map_(map),
      camera_(camera),
      params_(params),
      initializer_(initializer ? std::move(initializer)
                               : std::make_unique<MonocularInitializer>(camera, InitializerParams{},
                                                                        optimize::BundleAdjustmentParams{})),
      solver_(solver ? std::move(solver) : std::make_unique<FullPoseSolver>()),
      rng_(seed) {
  params_.check();
}

void Tracker::enableManhattanPath(ManhattanPathParams params, std::unique_ptr<PoseSolver> solver) {
  params.check();
  require(solver != nullptr, "Manhattan", "a translation-only pose solver is needed");
  manhattanParams_ = params;
  manhattanSolver_ = std::move(solver);
  manhattan_ = true;
}

bool Tracker::softRotationPrior(const Frame& frame) const {
  return frame.rotationPrior && manhattanParams_.trackingRotation != "fixed";
}

bool Tracker::fixedRotation(const Frame& frame) const {
  return frame.rotationPrior && !softRotationPrior(frame) && manhattanSolver_;
}

const PoseSolver& Tracker::solverFor(const Frame& frame) const {
  return fixedRotation(frame) ? *manhattanSolver_ : *solver_;
}

int Tracker::minPoseInliersFor(const Frame& frame) const {
  return fixedRotation(frame) ? manhattanParams_.minPoseInliers : params_.minPoseInliers;
}

void Tracker::setPointUsePolicy(std::shared_ptr<const map::PointUsePolicy> policy) {
  // ORB-SLAM*'s policy (every good point) is the same as none: skip the per-point call.
  policy_ = policy && !policy->usesEveryGoodPoint() ? std::move(policy) : nullptr;
}

bool Tracker::measurable(map::MapPointId id) const {
  return id != map::kNoMapPoint && map_.hasMapPoint(id) && !map_.mapPoint(id).bad;
}

bool Tracker::usable(map::MapPointId id) const {
  if (id == map::kNoMapPoint || !map_.hasMapPoint(id)) return false;
  const map::MapPoint& p = map_.mapPoint(id);
  return !p.bad && (!policy_ || policy_->mayUse(p));
}

void Tracker::onMapLoaded() {
  initializer_->reset();
  initialized_ = !map_.keyFrames().empty();
  lost_ = true;
  haveVelocity_ = false;
  referenceKeyFrame_ = map::kNoKeyFrame;
  relocalizedEver_ = false;
  unconfirmedRelocFrames_ = 0;
  localKeyFrames_.clear();
  last_ = Frame();
  R_world_mf_.reset();  // found again on the first tracked frame with a Manhattan frame
  keyFrameManhattan_.clear();
  keyFrameDatabase_.clear();
  for (const auto& [id, kf] : map_.keyFrames()) computeKeyFrameBow(id);
}

void Tracker::reset() {
  map_ = map::Map();
  initializer_->reset();
  initialized_ = false;
  lost_ = false;
  haveVelocity_ = false;
  referenceKeyFrame_ = map::kNoKeyFrame;
  relocalizedEver_ = false;
  unconfirmedRelocFrames_ = 0;
  localKeyFrames_.clear();
  last_ = Frame();
  R_world_mf_.reset();
  keyFrameManhattan_.clear();
  keyFrameDatabase_.clear();  // keyframe ids start again at 0
}

void Tracker::setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary, const places::PlacesParams& params) {
  params.check();
  vocabulary_ = std::move(vocabulary);
  placesParams_ = params;
  keyFrameDatabase_.clear();
  for (const auto& [id, kf] : map_.keyFrames()) computeKeyFrameBow(id);
}

void Tracker::onKeyFramesMoved(map::KeyFrameId ref, const Eigen::Isometry3d& T_ref_world_before, double scale) {
  if (!last_.hasPose || !map_.hasKeyFrame(ref) || !(scale > 0.0)) return;
  Eigen::Isometry3d T_last_ref = last_.T_cam_world * T_ref_world_before.inverse();
  T_last_ref.translation() /= scale;
  last_.T_cam_world = T_last_ref * map_.keyFrame(ref).T_cam_world;
  velocity_.translation() /= scale;
}

void Tracker::computeKeyFrameBow(map::KeyFrameId id) {
  if (!vocabulary_ || !map_.hasKeyFrame(id)) return;
  map::KeyFrame& kf = map_.mutableKeyFrame(id);
  if (!kf.bow.empty() || kf.descriptors.empty()) return;
  vocabulary_->transform(kf.descriptors, kf.bow, &kf.bowFeatures, placesParams_.directIndexLevelsUp);
}

void Tracker::computeFrameBow(Frame& frame) const {
  if (!vocabulary_ || !frame.bow.empty() || frame.descriptors.empty()) return;
  vocabulary_->transform(frame.descriptors, frame.bow, &frame.bowFeatures, placesParams_.directIndexLevelsUp);
}

void Tracker::syncKeyFrameDatabase() {
  for (const places::KeyFrameKey id : keyFrameDatabase_.keyFrames())
    if (!map_.hasKeyFrame(id)) keyFrameDatabase_.erase(id);
  for (const auto& [id, kf] : map_.keyFrames())
    if (!keyFrameDatabase_.contains(id)) {
      computeKeyFrameBow(id);
      keyFrameDatabase_.add(id, map_.keyFrame(id).bow);
    }
}

void Tracker::recordMeasurements(const Frame& frame) {
  if (!policy_ || !policy_->learnsFromMeasurements() || !mapUpdates_) return;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (frame.mapPointIds[i] != map::kNoMapPoint) measured_[frame.mapPointIds[i]] = i;
}

int Tracker::updatePointModels(const Frame& frame) {
  int updates = 0;
  for (const auto& [id, i] : measured_) {
    if (!measurable(id)) continue;
    map::PointMeasurement m;
    m.T_cam_world = frame.T_cam_world;
    m.camera = frame.camera;
    m.pixel = frame.pixel(i);
    m.descriptor = frame.descriptors.row(static_cast<int>(i));
    m.classProbabilities = frame.semanticProbabilities.empty() ? nullptr : &frame.semanticProbabilities[i];
    if (policy_->observe(map_, map_.mutableMapPoint(id), m)) ++updates;
  }
  return updates;
}

bool Tracker::poseSupported(int keypointInliers, int minKeypointInliers) const {
  if (keypointInliers >= minKeypointInliers) return true;
  if (directFactors_ == 0 && lineFactors_ == 0) return false;
  // Keypoint, direct and line inliers each count as their share of what would carry the pose alone: 28 of 30
  // keypoints and a handful of direct points together are as good a pose as 30 keypoints.
  double share = static_cast<double>(keypointInliers) / minKeypointInliers;
  if (directFactors_ > 0) share += static_cast<double>(directInliers_) / direct_->minInliers();
  if (lineFactors_ > 0) share += static_cast<double>(lineInliers_) / lines_->minInliers();
  return share >= 1.0;
}

int Tracker::optimizeFramePose(Frame& frame) {
  recordMeasurements(frame);
  directFactors_ = directInliers_ = 0;
  directOutliers_.clear();
  lineFactors_ = lineInliers_ = 0;
  lineOutliers_.clear();
  std::vector<optimize::PoseObservation> obs;
  std::vector<std::size_t> keypointOf;
  std::vector<std::size_t> evidence;  ///< matches of points the policy does not let us use (§3.4.2: measured only)
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    if (!usable(id)) {
      if (measurable(id))
        evidence.push_back(i);
      else
        frame.mapPointIds[i] = map::kNoMapPoint;
      continue;
    }
    optimize::PoseObservation o;
    o.p_world = map_.worldPosition(id);
    o.pixel = frame.pixel(i);
    o.invSigma2 = 1.0 / frame.levelSigma2[frame.keypoints[i].octave];
    obs.push_back(o);
    keypointOf.push_back(i);
  }
  std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> direct;
  // Direct points join the final (local-map) optimization of every frame; the earlier ones (motion model,
  // reference keyframe) only when the keypoints alone are too few to carry them, which saves most of their cost.
  const bool wantDirect = direct_ && useDirect_ && (finalOptimization_ || static_cast<int>(obs.size()) < 2 * params_.minPoseInliers);
  if (wantDirect) {
    std::optional<ScopedStage> stage;
    if (timings_) stage.emplace(*timings_, "direct_factors");
    direct = direct_->poseFactors(frame, map_, referenceKeyFrame_);
  }
  // ---- line segments (eq. 2.59): every attempt that starts from a pose guess (as the direct points' useDirect_)
  std::vector<std::shared_ptr<const optimize::PoseFactor>> lineFactors;
  if (lines_ && useDirect_) {
    std::optional<ScopedStage> stage;
    if (timings_) stage.emplace(*timings_, "line_factors");
    lineFactors = lines_->poseFactors(frame, map_, referenceKeyFrame_);
  }
  // ---- end line segments
  // Lines count only when the rotation is fixed or held by a prior (a 3-DoF problem they can carry with a few
  // points, §4.4.2).
  const std::size_t lineConstraints = frame.rotationPrior ? lineFactors.size() : 0;
  if (obs.size() + lineConstraints < 3 && direct.empty()) {
    for (std::size_t i : evidence) frame.mapPointIds[i] = map::kNoMapPoint;
    return 0;
  }
  std::optional<ScopedStage> stage;
  if (timings_) stage.emplace(*timings_, "pose_optimization");
  PoseSolveRequest request;
  request.T_cam_world_initial = frame.T_cam_world;
  request.camera = frame.camera;
  request.observations = std::move(obs);
  request.factors.insert(request.factors.end(), lineFactors.begin(), lineFactors.end());  // lines (after direct)
  if (softRotationPrior(frame))  // the Manhattan rotation as a measurement of the 6-DoF pose (after the lines)
    request.factors.push_back(std::make_shared<optimize::RotationPosePriorFactor>(
        *frame.rotationPrior, manhattanParams_.trackingRotationSigmaDeg * M_PI / 180.0));
  else
    request.rotationPrior = frame.rotationPrior;
  const optimize::PoseOptimizationResult r =
      direct.empty() ? solverFor(frame).solve(request)
                     : solverFor(frame).solveCoarseToFine(request, direct, direct_->coarsestLevel());
  frame.T_cam_world = r.T_cam_world;
  frame.hasPose = true;
  directFactors_ = static_cast<int>(direct.size());
  directOutliers_.assign(r.factorOutlier.begin(), r.factorOutlier.begin() + static_cast<long>(direct.size()));
  for (bool o : directOutliers_) directInliers_ += o ? 0 : 1;
  // The lines' flags follow the direct ones in factorOutlier (PoseSolver::solveCoarseToFine).
  lineFactors_ = static_cast<int>(lineFactors.size());
  const auto firstLine = r.factorOutlier.begin() + static_cast<long>(direct.size());
  lineOutliers_.assign(firstLine, firstLine + static_cast<long>(lineFactors.size()));
  for (bool o : lineOutliers_) lineInliers_ += o ? 0 : 1;
  int inliers = 0;
  for (std::size_t k = 0; k < keypointOf.size(); ++k) {
    const std::size_t i = keypointOf[k];
    if (r.outlier[k]) {
      // ORB-SLAM discards outlier matches after pose optimization.
      frame.mapPointIds[i] = map::kNoMapPoint;
      frame.outlier[i] = false;
    } else {
      frame.outlier[i] = false;
      ++inliers;
    }
  }
  // Inactive points take no part in the estimate, but a match that agrees with it is a measurement of the
  // point (§3.4.2: "we use each measurement to update our probabilistic measurement model"): it stays matched
  // (and reaches the point's model through the keyframe observations) when its reprojection error at the
  // estimated pose passes the same chi-square test (Table 3.2, chi_R = 5.991); otherwise it is dropped.
  for (std::size_t i : evidence) {
    optimize::PoseObservation o;
    o.p_world = map_.worldPosition(frame.mapPointIds[i]);
    o.pixel = frame.pixel(i);
    o.invSigma2 = 1.0 / frame.levelSigma2[frame.keypoints[i].octave];
    Eigen::Vector2d residual;
    const bool inFront = optimize::poseOnlyResidual(frame.T_cam_world, frame.camera, o, residual, nullptr);
    if (!inFront || !(residual.squaredNorm() <= kEvidenceChi2)) frame.mapPointIds[i] = map::kNoMapPoint;
    frame.outlier[i] = false;
  }
  return inliers;
}

int Tracker::searchLastFrame(Frame& frame, float widestFactor) {
  std::vector<ProjectionCandidate> cands;
  for (std::size_t i = 0; i < last_.size(); ++i) {
    const map::MapPointId id = last_.mapPointIds[i];
    if (last_.outlier[i] || !measurable(id)) continue;
    const map::MapPoint& p = map_.mapPoint(id);
    ProjectionCandidate c;
    c.id = id;
    c.p_world = map_.worldPosition(id);
    c.descriptor = p.descriptor;
    const int oct = last_.keypoints[i].octave;
    c.predictedLevel = oct;
    c.minLevel = std::max(0, oct - 1);
    c.maxLevel = oct + 1;
    c.referenceAngle = last_.keypoints[i].angle;
    cands.push_back(c);
  }
  ProjectionSearchParams sp;
  auto search = [&](float th) {
    for (auto& c : cands) c.radius = th * static_cast<float>(frame.scaleFactors[std::min<int>(c.predictedLevel, frame.numLevels() - 1)]);
    return searchByProjection(frame, frame.T_cam_world, cands, sp);
  };
  int n = search(params_.motionModelRadius);
  // ORB-SLAM widens the window once (2x); the Manhattan path, whose rotation is known, further.
  for (float factor = 2.f; n < params_.minMotionMatches && factor <= widestFactor; factor *= 2.f) {
    frame.resetMatches();
    n = search(factor * params_.motionModelRadius);
  }
  return n;
}

bool Tracker::trackWithMotionModel(Frame& frame) {
  frame.resetMatches();
  measured_.clear();  // only the matches of the attempt that succeeds are measurements
  frame.T_cam_world = velocity_ * last_.T_cam_world;
  const int n = searchLastFrame(frame);
  // With direct points the photometric alignment can carry a frame whose keypoint matches are too few (§3.4.2).
  if (n < params_.minMotionMatches && !direct_) return false;
  return poseSupported(optimizeFramePose(frame), minPoseInliersFor(frame));
}

std::optional<Eigen::Matrix3d> Tracker::manhattanRotation(const Frame& frame, ManhattanFrameReport& report) const {
  if (!frame.R_cam_mf) {
    report.reason = "no Manhattan frame";
    return std::nullopt;
  }
  if (!R_world_mf_) {
    report.reason = "global Manhattan frame not known yet";
    return std::nullopt;
  }
  // Lost: the last tracked pose is the prediction for up to recoveryFrames frames (ManhattanPathParams).
  const bool recovering = lost_ && last_.hasPose && frame.index <= last_.index + manhattanParams_.recoveryFrames;
  if ((lost_ && !recovering) || !last_.hasPose) {
    report.reason = "no pose prediction";
    return std::nullopt;
  }
  double deviation = 0.0;
  const Eigen::Matrix3d R_cam_world = rotationFromManhattanFrame(*frame.R_cam_mf, predictedPose().linear(), deviation);
  report.priorDeviationDeg = deviation;
  if (deviation > manhattanParams_.maxPriorDeviationDeg) {
    report.reason = "Manhattan rotation " + std::to_string(deviation) + " deg from the prediction";
    return std::nullopt;
  }
  // "relative": the increment between two Manhattan frames applied to the last frame's rotation (the first
  // frame after a gap in Manhattan frames takes the absolute one).
  if (manhattanParams_.trackingRotation == "relative" && last_.R_cam_mf) {
    double lastDeviation = 0.0;
    const Eigen::Matrix3d R_last =
        rotationFromManhattanFrame(*last_.R_cam_mf, last_.T_cam_world.linear(), lastDeviation);
    return Eigen::Matrix3d(R_cam_world * R_last.transpose() * last_.T_cam_world.linear());
  }
  return R_cam_world;
}

Eigen::Matrix3d Tracker::rotationFromManhattanFrame(const Eigen::Matrix3d& R_cam_mf, const Eigen::Matrix3d& R_guess,
                                                    double& deviationDeg) const {
  // The axes re-labelled to the guess's (the mean-shift tracker keeps labels from frame to frame, but
  // re-initializations may permute them), then R_cam_world = R_cam_mf R_world_mf^T (§4.4.2).
  const Eigen::Matrix3d labelled = manhattan::alignToReference(R_cam_mf, R_guess * *R_world_mf_, &deviationDeg);
  return labelled * R_world_mf_->transpose();
}

std::vector<std::shared_ptr<optimize::BAFactor>> Tracker::manhattanRotationPriors(
    const optimize::BAProblem& problem) const {
  std::vector<std::shared_ptr<optimize::BAFactor>> factors;
  if (!manhattan_ || !R_world_mf_ || !(manhattanParams_.baRotationSigmaDeg > 0.0)) return factors;
  const double sigma = manhattanParams_.baRotationSigmaDeg * M_PI / 180.0;
  for (const auto& [id, kf] : problem.keyframes) {
    if (kf.fixed) continue;
    const auto mf = keyFrameManhattan_.find(id);
    if (mf == keyFrameManhattan_.end()) continue;
    double deviation = 0.0;
    const Eigen::Matrix3d R_kf_world = rotationFromManhattanFrame(mf->second, kf.T_cam_world.linear(), deviation);
    if (deviation > manhattanParams_.maxPriorDeviationDeg) continue;
    factors.push_back(std::make_shared<optimize::RotationPriorFactor>(id, R_kf_world, sigma));
  }
  return factors;
}

bool Tracker::trackWithManhattanRotation(Frame& frame, const Eigen::Matrix3d& R_cam_world,
                                         ManhattanFrameReport& report) {
  frame.resetMatches();
  measured_.clear();
  frame.rotationPrior = R_cam_world;
  // The motion model's camera centre with the Manhattan rotation.
  const Eigen::Isometry3d predicted = predictedPose();
  const Eigen::Vector3d centre = -(predicted.linear().transpose() * predicted.translation());
  if (softRotationPrior(frame)) {
    // A soft prior may be degrees off: the search starts from the motion model's pose, the prior only enters
    // the optimization.
    frame.T_cam_world = predicted;
  } else {
    frame.T_cam_world.linear() = R_cam_world;
    frame.T_cam_world.translation() = -(R_cam_world * centre);
  }
  // Motion-model search first; when the frame moved too far for it, the reference keyframe's descriptor matches
  // (with the rotation fixed, a few of them fix the translation).
  const int n = searchLastFrame(frame, static_cast<float>(manhattanParams_.searchRadiusFactor));
  // With the rotation fixed, the 3-DoF translation needs fewer matches than 6-DoF tracking's minMotionMatches.
  const int enough = std::min(params_.minMotionMatches, manhattanParams_.minInliers);
  bool found = (n >= enough || direct_ || lines_) && poseSupported(optimizeFramePose(frame), minPoseInliersFor(frame));
  if (!found) found = trackReferenceKeyFrame(frame);
  if (!found) {
    report.reason = "too few matches with the Manhattan rotation (motion model " + std::to_string(n) + ")";
    return false;
  }
  // §4.4.2 "Pose Refinement": the local map refines the Manhattan estimate in all 6 DoF ("not limited to MW
  // conform solutions"), or keeps the rotation when refinePose = false.
  // A soft prior stays: the refinement is 6-DoF either way, and the prior holds the rotation where the local
  // map has too few points to fix it.
  if (manhattanParams_.refinePose && !softRotationPrior(frame)) frame.rotationPrior.reset();
  deferCounters_ = true;
  const int inliers = trackLocalMap(frame);
  deferCounters_ = false;
  report.refinementDeg = manhattan::rotationAngleDeg(R_cam_world, frame.T_cam_world.linear());
  if (!poseSupported(inliers, manhattanParams_.minInliers)) {
    report.reason = "too few local-map inliers with the Manhattan rotation (" + std::to_string(inliers) + ")";
    return false;
  }
  // Pose validation (§4.4.2): the points of the last n keyframes in view at the estimated pose, and how many of
  // them the frame holds as inliers (matched and kept by the chi-square test of the optimization).
  std::set<map::MapPointId> recent;
  int taken = 0;
  for (auto it = map_.keyFrames().rbegin(); it != map_.keyFrames().rend() && taken < manhattanParams_.validationKeyFrames;
       ++it, ++taken)
    for (map::MapPointId p : map_.pointsOf(it->first))
      if (usable(p)) recent.insert(p);
  std::set<map::MapPointId> held;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (frame.mapPointIds[i] != map::kNoMapPoint && !frame.outlier[i]) held.insert(frame.mapPointIds[i]);
  for (map::MapPointId p : recent) {
    const Eigen::Vector3d pc = frame.T_cam_world * map_.worldPosition(p);
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d uv = frame.camera.project(pc);
    if (!frame.bounds.contains(uv.x(), uv.y())) continue;
    ++report.validationInView;
    if (held.count(p)) ++report.validationInliers;
  }
  if (report.validationInliers < manhattanParams_.validationMinInliers ||
      report.validationInliers < manhattanParams_.validationMinRatio * report.validationInView) {
    report.reason = "validation: " + std::to_string(report.validationInliers) + " of " +
                    std::to_string(report.validationInView) + " recent points in view are inliers";
    return false;
  }
  // Accepted: the visibility counters of the local-map search count now.
  if (mapUpdates_) {
    for (map::MapPointId id : deferredVisible_)
      if (map_.hasMapPoint(id)) ++map_.mutableMapPoint(id).visibleCount;
    for (map::MapPointId id : deferredFound_)
      if (map_.hasMapPoint(id)) ++map_.mutableMapPoint(id).foundCount;
  }
  return true;
}

bool Tracker::trackReferenceKeyFrame(Frame& frame) {
  frame.resetMatches();
  measured_.clear();
  if (!map_.hasKeyFrame(referenceKeyFrame_)) return false;
  const map::KeyFrame& kf = map_.keyFrame(referenceKeyFrame_);
  if (vocabulary_ && placesParams_.referenceTracking) {
    // ORB-SLAM's SearchByBoW: the keyframe's points against the frame keypoints of the same vocabulary node.
    computeKeyFrameBow(referenceKeyFrame_);
    computeFrameBow(frame);
    places::NodeMatchParams np;
    np.ratio = params_.referenceRatio;
    np.maxDistance = params_.referenceMaxDistance;
    const auto matches = places::matchByVocabularyNode(
        kf.bowFeatures, kf.descriptors, kf.keypoints, frame.bowFeatures, frame.descriptors, frame.keypoints, np,
        [&](std::size_t i) { return measurable(kf.mapPointIds[i]); });
    for (const auto& m : matches)
      frame.mapPointIds[static_cast<std::size_t>(m.i2)] = kf.mapPointIds[static_cast<std::size_t>(m.i1)];
    if (static_cast<int>(matches.size()) < params_.minReferenceMatches && !direct_) return false;
    frame.T_cam_world = last_.hasPose ? last_.T_cam_world : kf.T_cam_world;
    return poseSupported(optimizeFramePose(frame), minPoseInliersFor(frame));
  }
  // Without a vocabulary: descriptor matching of the keyframe's map points against all frame keypoints (same
  // TH_LOW and ratio as SearchByBoW, exhaustive instead of vocabulary-node restricted).
  std::vector<int> rows;
  for (std::size_t i = 0; i < kf.mapPointIds.size(); ++i)
    if (measurable(kf.mapPointIds[i])) rows.push_back(static_cast<int>(i));
  if (static_cast<int>(rows.size()) < params_.minReferenceMatches && !direct_) return false;
  cv::Mat query(static_cast<int>(rows.size()), 32, CV_8U);
  for (std::size_t r = 0; r < rows.size(); ++r) kf.descriptors.row(rows[r]).copyTo(query.row(static_cast<int>(r)));
  features::BruteForceParams bp;
  bp.ratio = params_.referenceRatio;
  bp.maxDistance = params_.referenceMaxDistance;
  bp.crossCheck = true;
  const auto matches = rows.empty() || frame.descriptors.empty()
                           ? std::vector<features::IndexMatch>{}
                           : features::matchBruteForce(query, frame.descriptors, bp);
  for (const auto& m : matches) frame.mapPointIds[m.i2] = kf.mapPointIds[rows[m.i1]];
  if (static_cast<int>(matches.size()) < params_.minReferenceMatches && !direct_) return false;
  frame.T_cam_world = last_.hasPose ? last_.T_cam_world : kf.T_cam_world;
  return poseSupported(optimizeFramePose(frame), minPoseInliersFor(frame));
}

void Tracker::updateLocalKeyFrames(const Frame& frame) {
  std::map<map::KeyFrameId, int> counter;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint || !map_.hasMapPoint(id)) continue;
    for (const auto& [kf, k] : map_.mapPoint(id).observations) ++counter[kf];
  }
  localKeyFrames_.clear();
  // A frame tracked by direct points alone has no keypoint matches: its local map is then the reference
  // keyframe's neighbourhood, so that keypoint matches can come back (never the case without direct points:
  // local-map tracking needs keypoint inliers then).
  if (counter.empty() && direct_ && map_.hasKeyFrame(referenceKeyFrame_)) counter[referenceKeyFrame_] = 1;
  if (counter.empty()) return;
  std::set<map::KeyFrameId> inLocal;
  int best = -1;
  for (const auto& [kf, n] : counter) {
    localKeyFrames_.push_back(kf);
    inLocal.insert(kf);
    if (n > best) {
      best = n;
      referenceKeyFrame_ = kf;
    }
  }
  // Neighbours of the local keyframes (ORB-SLAM: 10 best covisible, children and parent).
  const std::vector<map::KeyFrameId> first = localKeyFrames_;
  for (map::KeyFrameId kf : first) {
    if (static_cast<int>(localKeyFrames_.size()) >= params_.maxLocalKeyFrames) break;
    for (map::KeyFrameId n : map_.bestCovisibleKeyFrames(kf, 10))
      if (inLocal.insert(n).second) localKeyFrames_.push_back(n);
    const map::KeyFrame& k = map_.keyFrame(kf);
    for (map::KeyFrameId c : k.children)
      if (inLocal.insert(c).second) localKeyFrames_.push_back(c);
    if (k.parent != map::kNoKeyFrame && inLocal.insert(k.parent).second) localKeyFrames_.push_back(k.parent);
  }
}

int Tracker::trackLocalMap(Frame& frame, int* localCandidates) {
  updateLocalKeyFrames(frame);
  deferredVisible_.clear();
  deferredFound_.clear();
  // ORB-SLAM's visible / found counters (culling's found ratio); held back while deferCounters_.
  auto countVisible = [&](map::MapPointId id) {
    if (deferCounters_)
      deferredVisible_.push_back(id);
    else if (mapUpdates_ && map_.hasMapPoint(id))
      ++map_.mutableMapPoint(id).visibleCount;
  };
  std::set<map::MapPointId> matched;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    matched.insert(id);
    countVisible(id);
  }
  std::set<map::MapPointId> localPoints;
  for (map::KeyFrameId kf : localKeyFrames_)
    for (map::MapPointId p : map_.pointsOf(kf))
      if (!matched.count(p)) localPoints.insert(p);
  const Eigen::Vector3d centre = frame.cameraCenter();
  const float th = (relocalizedEver_ && frame.index < lastRelocFrame_ + 2) ? 5.f * params_.localMapRadius
                                                                            : params_.localMapRadius;
  std::vector<ProjectionCandidate> cands;
  for (map::MapPointId id : localPoints) {
    if (!measurable(id)) continue;
    const map::MapPoint& p = map_.mapPoint(id);
    // ORB-SLAM Frame::isInFrustum: in front, inside the image, within the scale-invariance distances, and
    // seen at less than 60 degrees from its mean viewing direction.
    const Eigen::Vector3d pw = map_.worldPosition(id);
    const Eigen::Vector3d pc = frame.T_cam_world * pw;
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d uv = frame.camera.project(pc);
    if (!frame.bounds.contains(uv.x(), uv.y())) continue;
    const Eigen::Vector3d po = pw - centre;
    const double dist = po.norm();
    if (dist < 0.8 * p.minDistance || dist > 1.2 * p.maxDistance) continue;
    const double viewCos = p.normal.norm() > 0 ? po.dot(p.normal) / dist : 1.0;
    if (viewCos < 0.5) continue;
    countVisible(id);
    ProjectionCandidate c;
    c.id = id;
    c.p_world = pw;
    c.descriptor = p.descriptor;
    c.predictedLevel = predictLevel(dist, p.maxDistance, frame.numLevels() > 1 ? frame.scaleFactors[1] : 1.2,
                                    frame.numLevels());
    c.minLevel = std::max(0, c.predictedLevel - 1);
    c.maxLevel = c.predictedLevel;
    c.radius = th * radiusByViewingCos(viewCos) * static_cast<float>(frame.scaleFactors[c.predictedLevel]);
    cands.push_back(c);
  }
  if (localCandidates) *localCandidates = static_cast<int>(cands.size());
  ProjectionSearchParams sp;
  sp.ratio = params_.localMapRatio;
  sp.checkOrientation = false;  // ORB-SLAM's local-map search has no rotation check
  searchByProjection(frame, frame.T_cam_world, cands, sp);
  finalOptimization_ = true;
  const int inliers = optimizeFramePose(frame);
  finalOptimization_ = false;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    if (deferCounters_)
      deferredFound_.push_back(id);
    else if (mapUpdates_ && map_.hasMapPoint(id))
      ++map_.mutableMapPoint(id).foundCount;
  }
  return inliers;
}

std::vector<Tracker::RelocCandidate> Tracker::relocalizationCandidates(Frame& frame) {
  std::vector<RelocCandidate> cands;
  if (vocabulary_ && placesParams_.relocalization) {
    // ORB-SLAM: the keyframe database proposes the keyframes (and covisible groups) most similar to the frame;
    // each is matched by vocabulary node (SearchByBoW: TH_LOW, ratio 0.75, rotation consistency).
    computeFrameBow(frame);
    syncKeyFrameDatabase();
    const auto places = keyFrameDatabase_.relocalizationCandidates(
        frame.bow, [&](places::KeyFrameKey k) { return map_.bestCovisibleKeyFrames(k, 10); });
    places::NodeMatchParams np;
    np.ratio = 0.75f;
    for (const places::PlaceCandidate& pc : places) {
      const map::KeyFrame& kf = map_.keyFrame(pc.keyFrame);
      RelocCandidate c{pc.keyFrame, {}};
      for (const auto& m : places::matchByVocabularyNode(
               kf.bowFeatures, kf.descriptors, kf.keypoints, frame.bowFeatures, frame.descriptors, frame.keypoints, np,
               [&](std::size_t i) { return usable(kf.mapPointIds[i]); }))
        c.matches.emplace_back(static_cast<std::size_t>(m.i2), kf.mapPointIds[static_cast<std::size_t>(m.i1)]);
      if (static_cast<int>(c.matches.size()) >= params_.minReferenceMatches) cands.push_back(std::move(c));
    }
  } else {
    // Without a vocabulary: exhaustive descriptor matching against every keyframe's points (the match count
    // stands in for the BoW similarity).
    features::BruteForceParams bp;
    bp.ratio = 0.75f;
    bp.maxDistance = features::kOrbThHigh;
    for (const auto& [kfId, kf] : map_.keyFrames()) {
      std::vector<int> rows;
      for (std::size_t i = 0; i < kf.mapPointIds.size(); ++i)
        if (usable(kf.mapPointIds[i])) rows.push_back(static_cast<int>(i));
      if (static_cast<int>(rows.size()) < params_.minReferenceMatches) continue;
      cv::Mat query(static_cast<int>(rows.size()), 32, CV_8U);
      for (std::size_t r = 0; r < rows.size(); ++r) kf.descriptors.row(rows[r]).copyTo(query.row(static_cast<int>(r)));
      RelocCandidate c{kfId, {}};
      for (const auto& m : features::matchBruteForce(query, frame.descriptors, bp))
        c.matches.emplace_back(static_cast<std::size_t>(m.i2), kf.mapPointIds[rows[m.i1]]);
      if (static_cast<int>(c.matches.size()) >= params_.minReferenceMatches) cands.push_back(std::move(c));
    }
  }
  std::stable_sort(cands.begin(), cands.end(), [](const RelocCandidate& a, const RelocCandidate& b) {
    return a.matches.size() > b.matches.size();
  });
  if (static_cast<int>(cands.size()) > params_.relocalizationCandidates) cands.resize(params_.relocalizationCandidates);
  return cands;
}

bool Tracker::relocalize(Frame& frame) {
  // Candidate keyframes with their matches, most matches first; each is tried by PnP. The query (BoW vector,
  // database, node matching) is timed on its own: it grows with the map differently from the PnP attempts.
  std::vector<RelocCandidate> cands;
  {
    std::optional<ScopedStage> stage;
    if (timings_) stage.emplace(*timings_, "relocalization_query");
    cands = relocalizationCandidates(frame);
  }
  for (const RelocCandidate& c : cands) {
    std::vector<Eigen::Vector3d> pts;
    std::vector<Eigen::Vector2d> pixels;
    for (const auto& [k, p] : c.matches) {
      pts.push_back(map_.worldPosition(p));
      pixels.push_back(frame.pixel(k));
    }
    const geometry::PnpResult pnp = geometry::solvePnpRansac(camera_, pts, pixels, params_.pnp);
    if (!pnp.success) continue;
    frame.resetMatches();
    measured_.clear();
    for (std::size_t m = 0; m < c.matches.size(); ++m)
      if (pnp.inliers[m]) frame.mapPointIds[c.matches[m].first] = c.matches[m].second;
    frame.T_cam_world = Eigen::Isometry3d::Identity();
    frame.T_cam_world.linear() = pnp.R_cam_world;
    frame.T_cam_world.translation() = pnp.t_cam_world;
    int inliers = optimizeFramePose(frame);
    if (inliers < params_.minPoseInliers) continue;
    if (inliers < params_.minInliersAfterReloc) {
      // Project the candidate keyframe's other points with a wide window and optimize again.
      std::set<map::MapPointId> have(frame.mapPointIds.begin(), frame.mapPointIds.end());
      std::vector<ProjectionCandidate> pc;
      for (map::MapPointId id : map_.pointsOf(c.kf)) {
        if (have.count(id) || !usable(id)) continue;
        const map::MapPoint& p = map_.mapPoint(id);
        const Eigen::Vector3d pw = map_.worldPosition(id);
        const double dist = (pw - frame.cameraCenter()).norm();
        ProjectionCandidate cand;
        cand.id = id;
        cand.p_world = pw;
        cand.descriptor = p.descriptor;
        cand.predictedLevel = predictLevel(dist, p.maxDistance, frame.numLevels() > 1 ? frame.scaleFactors[1] : 1.2,
                                           frame.numLevels());
        cand.minLevel = std::max(0, cand.predictedLevel - 1);
        cand.maxLevel = cand.predictedLevel + 1;
        cand.radius = 10.f * static_cast<float>(frame.scaleFactors[cand.predictedLevel]);
        pc.push_back(cand);
      }
      ProjectionSearchParams sp;
      sp.checkOrientation = false;
      searchByProjection(frame, frame.T_cam_world, pc, sp);
      inliers = optimizeFramePose(frame);
    }
    if (inliers >= params_.minInliersAfterReloc) {
      referenceKeyFrame_ = c.kf;
      return true;
    }
  }
  frame.resetMatches();
  return false;
}

map::KeyFrameId Tracker::createKeyFrame(const Frame& frame, bool manhattanTracked) {
  const map::KeyFrameId id = map_.addKeyFrame(toKeyFrame(frame));
  std::vector<map::MapPointId> touched;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId p = frame.mapPointIds[i];
    if (frame.outlier[i] || !measurable(p)) continue;
    if (map_.addObservation(p, id, i)) touched.push_back(p);
  }
  for (map::MapPointId p : touched) {
    map_.computeDistinctiveDescriptor(p);
    map_.updateNormalAndDepth(p);
  }
  map_.connectToSpanningTree(id);
  if (manhattan_ && manhattanTracked && frame.R_cam_mf) keyFrameManhattan_[id] = *frame.R_cam_mf;
  for (auto it = keyFrameManhattan_.begin(); it != keyFrameManhattan_.end();)
    it = map_.hasKeyFrame(it->first) ? std::next(it) : keyFrameManhattan_.erase(it);  // culled keyframes
  referenceKeyFrame_ = id;
  lastKeyFrameFrame_ = frame.index;
  return id;
}

Tracker::Result Tracker::track(Frame frame, StageTimings& timings) {
  Result res;
  timings_ = &timings;
  FrameReport& rep = res.report;
  rep.index = frame.index;
  rep.timestamp = frame.timestamp;
  rep.features = static_cast<int>(frame.size());
  frame.resetMatches();
  measured_.clear();

  if (!initialized_) {
    rep.status = FrameStatus::Initializing;
    rep.method = "initializer";
    if (!mapUpdates_) {
      rep.message = "localization only and no map: nothing to track against";
      return res;
    }
    InitializationOutcome init;
    Frame reference;
    {
      ScopedStage st(timings, "initialization");
      init = initializer_->process(frame, map_, rng_, &reference);
    }
    if (init.initialized) {
      res.initialReferenceGrey = reference.grey;
      res.initialReferenceSemantic = reference.semantic;
    }
    rep.matches = init.matches;
    rep.message = init.message;
    if (init.initialized) {
      initialized_ = true;
      lost_ = false;
      rep.status = FrameStatus::Tracking;
      rep.inliers = frame.numMatchedInliers();
      rep.keyFrame = true;
      res.newKeyFrames = {init.kf1, init.kf2};
      for (map::KeyFrameId id : res.newKeyFrames) computeKeyFrameBow(id);
      res.initialReferencePose = std::make_pair(reference.timestamp, reference.T_cam_world);
      // §4.4.1: "we use the MW orientation found in the first image as our global MW frame".
      if (reference.R_cam_mf)
        R_world_mf_ = reference.T_cam_world.linear().transpose() * *reference.R_cam_mf;
      else if (frame.R_cam_mf)
        R_world_mf_ = frame.T_cam_world.linear().transpose() * *frame.R_cam_mf;
      // Rotation priors only for keyframes whose Manhattan frame the system trusted (manhattanRotationPriors).
      if (manhattan_ && init.manhattanRotation && reference.R_cam_mf && frame.R_cam_mf) {
        keyFrameManhattan_[init.kf1] = *reference.R_cam_mf;
        keyFrameManhattan_[init.kf2] = *frame.R_cam_mf;
      }
      referenceKeyFrame_ = init.kf2;
      lastKeyFrameFrame_ = frame.index;
      // No velocity yet (as ORB-SLAM after initialization): the next frame is tracked against the reference keyframe.
      haveVelocity_ = false;
      res.hasPose = true;
      res.T_cam_world = frame.T_cam_world;
      res.referenceKeyFrame = referenceKeyFrame_;
      last_ = frame;
    }
    rep.mapPoints = map_.numMapPoints();
    rep.keyFrames = map_.numKeyFrames();
    return res;
  }

  bool ok = false;
  bool relocalized = false;
  bool manhattanTracked = false;
  if (manhattan_) {
    // §4.4.2: the Manhattan rotation and a translation-only estimate first; the 6-DoF path when there is no
    // usable Manhattan rotation or its pose does not validate.
    rep.manhattan.mode = "fallback";
    if (const std::optional<Eigen::Matrix3d> R = manhattanRotation(frame, rep.manhattan)) {
      ScopedStage st(timings, "manhattan_tracking");
      Frame attempt = frame;
      useDirect_ = true;
      if (trackWithManhattanRotation(attempt, *R, rep.manhattan)) {
        frame = std::move(attempt);
        ok = manhattanTracked = true;
        rep.method = "manhattan";
        rep.manhattan.mode = "manhattan";
        rep.inliers = rep.matches = frame.numMatchedInliers();
      } else {
        measured_.clear();
      }
      useDirect_ = false;
    }
    frame.rotationPrior.reset();
  }
  if (!manhattanTracked) {
    {
      ScopedStage st(timings, "matching");
      useDirect_ = true;  // the motion-model, reference and local-map attempts; relocalization has no pose guess
      if (!lost_) {
        if (haveVelocity_) {
          ok = trackWithMotionModel(frame);
          rep.method = "motion";
        }
        if (!ok) {
          ok = trackReferenceKeyFrame(frame);
          rep.method = "reference";
        }
      }
    }
    if (!ok) {
      ScopedStage st(timings, "relocalization");
      useDirect_ = false;
      ok = relocalize(frame);
      useDirect_ = true;
      rep.method = "relocalization";
      if (ok) {
        relocalized = true;
        relocalizedEver_ = true;
        lastRelocFrame_ = frame.index;
      }
    }
    rep.matches = frame.numMatchedInliers();

    if (ok) {
      ScopedStage st(timings, "local_map");
      int cands = 0;
      const int inliers = trackLocalMap(frame, &cands);
      rep.inliers = inliers;
      rep.localMapPoints = cands;
      const bool recentReloc = relocalizedEver_ && frame.index < lastRelocFrame_ + static_cast<std::size_t>(params_.keyFrames.maxFrames);
      ok = poseSupported(inliers, recentReloc ? params_.minInliersAfterReloc : params_.minLocalMapInliers);
    }
  }
  useDirect_ = false;

  if (!ok) {
    rep.status = FrameStatus::Lost;
    haveVelocity_ = false;
    lost_ = true;
    if (unconfirmedRelocFrames_ > 0) {
      // Lost right after a relocalization: it put the camera at a place that only looked like this one.
      res.retractedFrames = unconfirmedRelocFrames_;
      unconfirmedRelocFrames_ = 0;
      rep.message = "lost " + std::to_string(res.retractedFrames) +
                    " frame(s) after a relocalization: its poses are withdrawn";
    }
    if (mapUpdates_ && map_.numKeyFrames() <= static_cast<std::size_t>(params_.resetKeyFrames)) {
      // ORB-SLAM: a map this young is not worth relocalizing into; start over.
      rep.message = (rep.message.empty() ? "" : rep.message + "; ") + "lost with " +
                    std::to_string(map_.numKeyFrames()) + " keyframes: map reset";
      reset();
      res.mapWasReset = true;
    }
    rep.mapPoints = map_.numMapPoints();
    rep.keyFrames = map_.numKeyFrames();
    return res;
  }

  lost_ = false;
  rep.status = relocalized ? FrameStatus::Relocalized : FrameStatus::Tracking;
  // A relocalization counts once relocalizationCheckFrames more frames are tracked after it.
  if (relocalized)
    unconfirmedRelocFrames_ = params_.relocalizationCheckFrames > 0 ? 1 : 0;
  else if (unconfirmedRelocFrames_ > 0 &&
           ++unconfirmedRelocFrames_ > static_cast<std::size_t>(params_.relocalizationCheckFrames))
    unconfirmedRelocFrames_ = 0;
  // A map initialized (or loaded) without a Manhattan frame takes the first tracked frame's as the global one.
  if (manhattan_ && !R_world_mf_ && frame.R_cam_mf) R_world_mf_ = frame.T_cam_world.linear().transpose() * *frame.R_cam_mf;
  // §3.4.2: "with each new frame we update the semantic class probabilities, the depth mean, depth variance
  // and the inlier model parameters" of every point the frame measured, before the keyframe decision reads
  // which points are active.
  if (!measured_.empty()) {
    ScopedStage st(timings, "point_model");
    rep.modelUpdates = updatePointModels(frame);
    res.measuredByTracking = true;
  }
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint || frame.outlier[i]) continue;
    (usable(id) ? rep.activeMatches : rep.inactiveMatches)++;
  }
  if (direct_ && mapUpdates_) {
    ScopedStage st(timings, "direct_update");
    rep.direct = direct_->afterTracking(frame, map_, directOutliers_);
  } else if (direct_) {
    // Localization: the direct points stay as they were loaded (no measurements, counters or culling); the report
    // still says what the pose used and which points it saw.
    rep.direct = direct_->viewCounts();
    rep.direct.factors = directFactors_;
    rep.direct.inliers = directInliers_;
  }
  if (lines_ && mapUpdates_) {
    ScopedStage st(timings, "line_update");
    rep.lines = lines_->afterTracking(frame, map_, lineOutliers_);
  } else if (lines_) {
    // Localization: the line store stays as it was loaded (no counters, no culling); the report still says what
    // the pose used.
    rep.lines.factors = lineFactors_;
    rep.lines.inliers = lineInliers_;
  }
  if (last_.hasPose && !relocalized) {
    velocity_ = frame.T_cam_world * last_.T_cam_world.inverse();
    haveVelocity_ = true;
  }

  KeyFrameDecisionInput kin;
  kin.frameIndex = frame.index;
  kin.lastKeyFrameFrame = lastKeyFrameFrame_;
  kin.lastRelocFrame = lastRelocFrame_;
  kin.relocalizedEver = relocalizedEver_;
  kin.numKeyFrames = map_.numKeyFrames();
  // ORB-SLAM's TrackedMapPoints over the points the policy lets us use (§3.4.3).
  if (map_.hasKeyFrame(referenceKeyFrame_))
    kin.referenceTrackedPoints = map_.trackedMapPoints(referenceKeyFrame_, kin.numKeyFrames <= 2 ? 2 : 3, policy_.get());
  // With a point model, the matches of the points active after this frame's update (§3.4.3: "we only consider
  // active points based on the current inlier estimate in the decision"); new points that this frame's
  // measurement activated count, as they do in the reference keyframe's count.
  kin.trackedInliers = policy_ ? rep.activeMatches : rep.inliers;
  kin.localMappingIdle = localMappingIdle_;
  kin.weakInliers = weakTrackingInliers_;
  kin.directSupported = directFactors_ > 0 && directInliers_ >= direct_->minInliers();
  kin.directReferenceInView = rep.direct.referenceInView;
  kin.directReferenceActive = rep.direct.referenceActive;
  if (mapUpdates_ && needNewKeyFrame(kin, params_.keyFrames)) {
    res.newKeyFrames.push_back(createKeyFrame(frame, manhattanTracked));
    unconfirmedRelocFrames_ = 0;  // the map now builds on this pose: too late to withdraw it
    computeKeyFrameBow(res.newKeyFrames.back());
    rep.keyFrame = true;
  } else if (mapUpdates_ && !kin.localMappingIdle) {
    kin.localMappingIdle = true;
    res.keyFrameWaitsForMapping = needNewKeyFrame(kin, params_.keyFrames);
    res.keyFrameUrgent = res.keyFrameWaitsForMapping && keyFrameUrgent(kin, params_.keyFrames);
  }
  res.hasPose = true;
  res.T_cam_world = frame.T_cam_world;
  res.referenceKeyFrame = referenceKeyFrame_;
  rep.mapPoints = map_.numMapPoints();
  rep.keyFrames = map_.numKeyFrames();
  last_ = std::move(frame);
  return res;
}

}  // namespace pslam::tracking
