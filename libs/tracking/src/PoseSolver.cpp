#include "pslam/tracking/PoseSolver.h"

#include <map>
#include <mutex>

#include "pslam/core/Error.h"

namespace pslam::tracking {

optimize::PoseOptimizationResult FullPoseSolver::solve(const PoseSolveRequest& r) const {
  return optimize::optimizePose(r.T_cam_world_initial, r.camera, r.observations, params_, r.initialOutliers,
                                r.factors);
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
struct Registry {
  std::mutex mutex;
  std::map<std::string, PoseSolverFactory> factories{
      {"full6dof", [](const optimize::PoseOptimizationParams& p) { return std::make_unique<FullPoseSolver>(p); }},
      {"translationOnly",
       [](const optimize::PoseOptimizationParams& p) { return std::make_unique<TranslationOnlyPoseSolver>(p); }}};
};
Registry& registry() {
  static Registry r;
  return r;
}
}  // namespace

std::unique_ptr<PoseSolver> makePoseSolver(const std::string& name, const optimize::PoseOptimizationParams& params) {
  PoseSolverFactory factory;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lk(r.mutex);
    auto it = r.factories.find(name);
    if (it != r.factories.end()) factory = it->second;
  }
  if (!factory) {
    std::string known;
    for (const std::string& n : poseSolverNames()) known += (known.empty() ? "" : ", ") + n;
    throw Error("[System] poseSolver = " + name + ": unknown pose solver (known: " + known + ")");
  }
  return factory(params);
}

void registerPoseSolver(const std::string& name, PoseSolverFactory factory) {
  require(!name.empty() && factory != nullptr, "registerPoseSolver", "needs a name and a factory");
  Registry& r = registry();
  std::lock_guard<std::mutex> lk(r.mutex);
  r.factories[name] = std::move(factory);
}

std::vector<std::string> poseSolverNames() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lk(r.mutex);
  std::vector<std::string> names;
  for (const auto& [n, f] : r.factories) names.push_back(n);
  return names;
}

}  // namespace pslam::tracking
