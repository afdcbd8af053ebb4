#pragma once
// Swappable camera-pose solver used by tracking, chosen by name ([System] poseSolver) through a factory:
//   full6dof        ORB-SLAM's motion-only BA (optimize::optimizePose), every degree of freedom free;
//   translationOnly the rotation comes from a prior (thesis §4.4.2: the Manhattan-frame rotation), only the
//                   translation is optimized (3 DoF, eq. 4.2 with points); without a prior it solves all 6 DoF.
// Other solvers are added with registerPoseSolver() (tests, chapter-4 variants) without touching the tracker.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pslam/optimize/PhotometricPoseFactor.h"
#include "pslam/optimize/PoseFactor.h"
#include "pslam/optimize/PoseOptimizer.h"

namespace pslam::tracking {

/// Everything a pose solver gets for one frame.
struct PoseSolveRequest {
  Eigen::Isometry3d T_cam_world_initial = Eigen::Isometry3d::Identity();
  geometry::PinholeCamera camera;
  std::vector<optimize::PoseObservation> observations;  ///< ORB keypoint <-> map point reprojections
  std::vector<bool> initialOutliers;                     ///< empty = none
  /// Rotation prior R_cam_world for this frame (e.g. from the Manhattan frame), if any.
  std::optional<Eigen::Matrix3d> rotationPrior;
  /// Observations of other landmark kinds (direct patches, line segments) that join the same optimization.
  std::vector<std::shared_ptr<const optimize::PoseFactor>> factors;
};

class PoseSolver {
 public:
  virtual ~PoseSolver() = default;
  virtual std::string name() const = 0;
  /// Refines T_cam_world; outlier flags per observation (and per factor) in the result.
  virtual optimize::PoseOptimizationResult solve(const PoseSolveRequest& request) const = 0;
  /// The request joined by direct points, optimized coarse to fine (§3.4.2: DSO's pyramid levels from
  /// `coarsestLevel` down to 0, the keypoints at every level). factorOutlier lists `direct` first, then
  /// request.factors. The default runs solve() with the direct factors at level 0 only.
  virtual optimize::PoseOptimizationResult solveCoarseToFine(
      const PoseSolveRequest& request, const std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>>& direct,
      int coarsestLevel) const;
};

/// 6-DoF motion-only BA: Huber 2.448 on level-whitened residuals, chi2 5.991 re-classification rounds.
class FullPoseSolver : public PoseSolver {
 public:
  explicit FullPoseSolver(optimize::PoseOptimizationParams params = {}) : params_(params) {}
  std::string name() const override { return "full6dof"; }
  optimize::PoseOptimizationResult solve(const PoseSolveRequest& request) const override;
  optimize::PoseOptimizationResult solveCoarseToFine(
      const PoseSolveRequest& request, const std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>>& direct,
      int coarsestLevel) const override;
  const optimize::PoseOptimizationParams& params() const { return params_; }

 private:
  optimize::PoseOptimizationParams params_;
};

/// Rotation from the request's prior, translation optimized (same rounds, robust loss and outlier
/// classification as full6dof). Without a prior it behaves as full6dof.
class TranslationOnlyPoseSolver : public PoseSolver {
 public:
  explicit TranslationOnlyPoseSolver(optimize::PoseOptimizationParams params = {}) : params_(params) {}
  std::string name() const override { return "translationOnly"; }
  optimize::PoseOptimizationResult solve(const PoseSolveRequest& request) const override;

 private:
  optimize::PoseOptimizationParams params_;
};

using PoseSolverFactory = std::function<std::unique_ptr<PoseSolver>(const optimize::PoseOptimizationParams&)>;
/// Makes the solver registered under `name`. Throws pslam::Error("[System] poseSolver = <name>: unknown pose
/// solver (known: ...)") for an unknown name.
std::unique_ptr<PoseSolver> makePoseSolver(const std::string& name, const optimize::PoseOptimizationParams& params);
/// Adds (or replaces) a solver under `name`; thread-safe.
void registerPoseSolver(const std::string& name, PoseSolverFactory factory);
/// Throws the error of the factory (naming the key and the known names) when `name` is not registered.
void requirePoseSolver(const std::string& name);

}  // namespace pslam::tracking
