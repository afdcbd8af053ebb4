#include "pslam/tracking/PoseSolver.h"

#include "pslam/core/NamedRegistry.h"

namespace pslam::tracking {

optimize::PoseOptimizationResult FullPoseSolver::solve(const PoseSolveRequest& r) const {
  return optimize::optimizePose(r.T_cam_world_initial, r.camera, r.observations, params_, r.initialOutliers,
                                r.factors);
}

optimize::PoseOptimizationResult PoseSolver::solveCoarseToFine(
    const PoseSolveRequest& request, const std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>>& direct,
    int /*coarsestLevel*/) const {
  PoseSolveRequest r = request;
  r.factors.clear();
  for (const auto& f : direct) r.factors.push_back(f->level() == 0 ? f : f->atLevel(0));
  r.factors.insert(r.factors.end(), request.factors.begin(), request.factors.end());
  return solve(r);
}

optimize::PoseOptimizationResult FullPoseSolver::solveCoarseToFine(
    const PoseSolveRequest& r, const std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>>& direct,
    int coarsestLevel) const {
  return optimize::optimizePoseCoarseToFine(r.T_cam_world_initial, r.camera, r.observations, direct, coarsestLevel,
                                            params_, r.factors);
}

optimize::PoseOptimizationResult TranslationOnlyPoseSolver::solve(const PoseSolveRequest& r) const {
  if (!r.rotationPrior)
    return optimize::optimizePose(r.T_cam_world_initial, r.camera, r.observations, params_, r.initialOutliers,
                                  r.factors);
  Eigen::Isometry3d start = r.T_cam_world_initial;
  // Keep the camera centre of the initial estimate while the rotation takes the prior's value.
  const Eigen::Vector3d centre = -(start.linear().transpose() * start.translation());
  start.linear() = *r.rotationPrior;
  start.translation() = -(*r.rotationPrior * centre);
  return optimize::optimizePose(start, r.camera, r.observations, params_, r.initialOutliers, r.factors,
                                optimize::PoseFreedom::TranslationOnly);
}

namespace {
NamedRegistry<PoseSolverFactory>& poseSolverRegistry() {
  static NamedRegistry<PoseSolverFactory> r({
      {"full6dof", [](const optimize::PoseOptimizationParams& p) { return std::make_unique<FullPoseSolver>(p); }},
      {"translationOnly",
       [](const optimize::PoseOptimizationParams& p) { return std::make_unique<TranslationOnlyPoseSolver>(p); }}});
  return r;
}
}  // namespace

std::unique_ptr<PoseSolver> makePoseSolver(const std::string& name, const optimize::PoseOptimizationParams& params) {
  return poseSolverRegistry().get(name, "[System] poseSolver", "pose solver")(params);
}

void registerPoseSolver(const std::string& name, PoseSolverFactory factory) {
  poseSolverRegistry().add(name, std::move(factory));
}

void requirePoseSolver(const std::string& name) {
  poseSolverRegistry().get(name, "[System] poseSolver", "pose solver");
}

}  // namespace pslam::tracking
