#include "pslam/tracking/FramePoseOptimizer.h"

#include <algorithm>
#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/optimize/RotationPriorFactor.h"

namespace pslam::tracking {

FramePoseOptimizer::FramePoseOptimizer(TrackingContext& context, std::unique_ptr<PoseSolver> solver)
    : ctx_(context), solver_(solver ? std::move(solver) : std::make_unique<FullPoseSolver>()) {}

void FramePoseOptimizer::setRotationPriors(const ManhattanPathParams& params,
                                           std::unique_ptr<PoseSolver> translationOnly) {
  require(translationOnly != nullptr, "Manhattan", "a translation-only pose solver is needed");
  translationOnly_ = std::move(translationOnly);
  trackingRotation_ = params.trackingRotation;
  trackingRotationSigmaDeg_ = params.trackingRotationSigmaDeg;
  fixedRotationMinPoseInliers_ = params.minPoseInliers;
}

bool FramePoseOptimizer::softRotationPrior(const Frame& frame) const {
  return frame.rotationPrior && trackingRotation_ != "fixed";
}

bool FramePoseOptimizer::fixedRotation(const Frame& frame) const {
  return frame.rotationPrior && !softRotationPrior(frame) && translationOnly_;
}

const PoseSolver& FramePoseOptimizer::solverFor(const Frame& frame) const {
  return fixedRotation(frame) ? *translationOnly_ : *solver_;
}

int FramePoseOptimizer::minPoseInliersFor(const Frame& frame) const {
  return fixedRotation(frame) ? fixedRotationMinPoseInliers_ : ctx_.params.minPoseInliers;
}

const std::vector<bool>& FramePoseOptimizer::moduleOutliers(std::size_t m) const {
  static const std::vector<bool> none;
  return records_.size() > m ? records_[m].outliers : none;
}

bool FramePoseOptimizer::moduleCarriedPose(std::size_t m) const {
  return moduleFactors(m) > 0 && moduleInliers(m) >= ctx_.modules[m]->minInliers();
}

void FramePoseOptimizer::recordMeasurements(const Frame& frame) {
  if (!ctx_.policy || !ctx_.policy->learnsFromMeasurements() || !ctx_.mapUpdates) return;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (frame.mapPointIds[i] != map::kNoMapPoint) measured_[frame.mapPointIds[i]] = i;
}

int FramePoseOptimizer::updatePointModels(const Frame& frame) {
  int updates = 0;
  for (const auto& [id, i] : measured_) {
    if (!ctx_.measurable(id)) continue;
    map::PointMeasurement m;
    m.T_cam_world = frame.T_cam_world;
    m.camera = frame.camera;
    m.pixel = frame.pixel(i);
    m.descriptor = frame.descriptors.row(static_cast<int>(i));
    m.classProbabilities = frame.semanticProbabilities.empty() ? nullptr : &frame.semanticProbabilities[i];
    if (ctx_.policy->observe(ctx_.map, ctx_.map.mutableMapPoint(id), m)) ++updates;
  }
  return updates;
}

bool FramePoseOptimizer::poseSupported(int keypointInliers, int minKeypointInliers) const {
  if (keypointInliers >= minKeypointInliers) return true;
  // Keypoint and module inliers each count as their share of what would carry the pose alone: 28 of 30 keypoints
  // and a handful of direct points together are as good a pose as 30 keypoints.
  double share = static_cast<double>(keypointInliers) / minKeypointInliers;
  bool anyModule = false;
  for (std::size_t m = 0; m < records_.size(); ++m) {
    if (records_[m].factors == 0) continue;
    anyModule = true;
    share += static_cast<double>(records_[m].inliers) / ctx_.modules[m]->minInliers();
  }
  return anyModule && share >= 1.0;
}

int FramePoseOptimizer::optimize(Frame& frame, OptimizationMode mode) {
  recordMeasurements(frame);
  records_.assign(ctx_.modules.size(), ModuleRecord{});
  std::vector<optimize::PoseObservation> obs;
  std::vector<std::size_t> keypointOf;
  std::vector<std::size_t> evidence;  ///< matches of points the policy does not let us use (§3.4.2: measured only)
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const map::MapPointId id = frame.mapPointIds[i];
    if (id == map::kNoMapPoint) continue;
    if (!ctx_.usable(id)) {
      if (ctx_.measurable(id))
        evidence.push_back(i);
      else
        frame.mapPointIds[i] = map::kNoMapPoint;
      continue;
    }
    optimize::PoseObservation o;
    o.p_world = ctx_.map.worldPosition(id);
    o.pixel = frame.pixel(i);
    o.invSigma2 = 1.0 / frame.levelSigma2[frame.keypoints[i].octave];
    obs.push_back(o);
    keypointOf.push_back(i);
  }
  // The modules that join, in their order: photometric factors first (all modules), then the others.
  std::vector<ModulePoseFactors> contributed(ctx_.modules.size());
  std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> pyramid;
  std::vector<std::shared_ptr<const optimize::PoseFactor>> factors;
  int coarsestLevel = 0;
  if (mode.withModules) {
    const PoseAttempt attempt{mode.final, static_cast<int>(obs.size()), ctx_.params.minPoseInliers};
    for (std::size_t m = 0; m < ctx_.modules.size(); ++m) {
      LandmarkModule& module = *ctx_.modules[m];
      if (!module.joins(attempt)) continue;
      {
        std::optional<ScopedStage> stage;
        ctx_.time(stage, module.name() + "_factors");
        contributed[m] = module.poseFactors(frame, ctx_.map, ctx_.referenceKeyFrame);
      }
      pyramid.insert(pyramid.end(), contributed[m].pyramid.begin(), contributed[m].pyramid.end());
      factors.insert(factors.end(), contributed[m].factors.begin(), contributed[m].factors.end());
      if (!contributed[m].pyramid.empty()) coarsestLevel = std::max(coarsestLevel, module.coarsestLevel());
    }
  }
  // Full-resolution factors (lines) count only when the rotation is fixed or held by a prior (a 3-DoF problem they
  // can carry with a few points, §4.4.2); photometric ones always let the optimization run.
  const std::size_t constraints = frame.rotationPrior ? factors.size() : 0;
  if (obs.size() + constraints < 3 && pyramid.empty()) {
    for (std::size_t i : evidence) frame.mapPointIds[i] = map::kNoMapPoint;
    return 0;
  }
  std::optional<ScopedStage> stage;
  ctx_.time(stage, "pose_optimization");
  PoseSolveRequest request;
  request.T_cam_world_initial = frame.T_cam_world;
  request.camera = frame.camera;
  request.observations = std::move(obs);
  request.factors = factors;
  if (softRotationPrior(frame))  // the Manhattan rotation as a measurement of the 6-DoF pose (after the modules')
    request.factors.push_back(std::make_shared<optimize::RotationPosePriorFactor>(
        *frame.rotationPrior, trackingRotationSigmaDeg_ * M_PI / 180.0));
  else
    request.rotationPrior = frame.rotationPrior;
  const optimize::PoseOptimizationResult r =
      pyramid.empty() ? solverFor(frame).solve(request)
                      : solverFor(frame).solveCoarseToFine(request, pyramid, coarsestLevel);
  frame.T_cam_world = r.T_cam_world;
  frame.hasPose = true;
  // Each module's flags: its photometric factors' within the first block of factorOutlier, then its others' after
  // every photometric one (PoseSolver::solveCoarseToFine puts them first).
  std::size_t pyramidAt = 0, factorAt = pyramid.size();
  for (std::size_t m = 0; m < contributed.size(); ++m) {
    ModuleRecord& rec = records_[m];
    const std::size_t np = contributed[m].pyramid.size(), nf = contributed[m].factors.size();
    rec.outliers.assign(r.factorOutlier.begin() + static_cast<long>(pyramidAt),
                        r.factorOutlier.begin() + static_cast<long>(pyramidAt + np));
    rec.outliers.insert(rec.outliers.end(), r.factorOutlier.begin() + static_cast<long>(factorAt),
                        r.factorOutlier.begin() + static_cast<long>(factorAt + nf));
    pyramidAt += np;
    factorAt += nf;
    rec.factors = static_cast<int>(np + nf);
    for (bool o : rec.outliers) rec.inliers += o ? 0 : 1;
  }
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
    o.p_world = ctx_.map.worldPosition(frame.mapPointIds[i]);
    o.pixel = frame.pixel(i);
    o.invSigma2 = 1.0 / frame.levelSigma2[frame.keypoints[i].octave];
    Eigen::Vector2d residual;
    const bool inFront = optimize::poseOnlyResidual(frame.T_cam_world, frame.camera, o, residual, nullptr);
    if (!inFront || !(residual.squaredNorm() <= kEvidenceChi2)) frame.mapPointIds[i] = map::kNoMapPoint;
    frame.outlier[i] = false;
  }
  return inliers;
}

}  // namespace pslam::tracking
