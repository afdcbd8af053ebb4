#include "pslam/optimize/BundleAdjustment.h"

#include <algorithm>
#include <atomic>
#include <set>
#include <chrono>
#include <cmath>
#include <memory>

#include <ceres/loss_function.h>
#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/AnalyticJacobians.h"

namespace pslam::optimize {

namespace {

using map::KeyFrameId;
using map::MapPointId;

void validate(const BAProblem& problem) {
  const std::string ctx = "bundle adjustment";
  for (const auto& [id, kf] : problem.keyframes) {
    require(kf.T_cam_world.matrix().allFinite(), ctx, "keyframe " + std::to_string(id) + " pose has NaN/Inf");
    kf.camera.check(ctx + ": keyframe " + std::to_string(id) + " camera");
  }
  for (const auto& [id, p] : problem.points) {
    require(problem.keyframes.count(p.anchor) != 0, ctx,
            "point " + std::to_string(id) + " anchor keyframe " + std::to_string(p.anchor) + " is not in the problem");
    require(p.bearing.allFinite() && std::abs(p.bearing.norm() - 1.0) < 1e-6, ctx,
            "point " + std::to_string(id) + " bearing is not a finite unit vector");
    require(std::isfinite(p.inverseDepth), ctx, "point " + std::to_string(id) + " inverse depth is NaN/Inf");
  }
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    const BAObservation& o = problem.observations[i];
    const std::string obs = "observation " + std::to_string(i);
    require(problem.keyframes.count(o.keyframe) != 0, ctx, obs + " refers to unknown keyframe " + std::to_string(o.keyframe));
    require(problem.points.count(o.point) != 0, ctx, obs + " refers to unknown point " + std::to_string(o.point));
    require(o.pixel.allFinite() && std::isfinite(o.invSigma2) && o.invSigma2 > 0.0, ctx,
            obs + " has a NaN/Inf pixel or a non-positive weight");
  }
  for (std::size_t i = 0; i < problem.factors.size(); ++i) {
    const std::string f = "factor " + std::to_string(i);
    require(problem.factors[i] != nullptr, ctx, f + " is null");
    require(!problem.factors[i]->keyframes().empty(), ctx, f + " involves no keyframe");
    for (KeyFrameId kf : problem.factors[i]->keyframes())
      require(problem.keyframes.count(kf) != 0, ctx, f + " refers to unknown keyframe " + std::to_string(kf));
    for (const double* block : problem.factors[i]->landmarkBlocks())
      require(block != nullptr, ctx, f + " has a null landmark block");
    for (const double* block : problem.factors[i]->sharedBlocks())
      require(block != nullptr, ctx, f + " has a null shared block");
  }
}

/// Parameter blocks of a factor at the current state: its keyframes' poses, its landmark blocks, its shared blocks.
std::vector<double*> factorBlocks(const BAFactor& f, const std::map<KeyFrameId, double*>& poses) {
  std::vector<double*> blocks;
  for (KeyFrameId kf : f.keyframes()) blocks.push_back(poses.at(kf));
  for (double* b : f.landmarkBlocks()) blocks.push_back(b);
  for (double* b : f.sharedBlocks()) blocks.push_back(b);
  return blocks;
}

// Mutable copy of the problem's values, in the layout Ceres optimizes. The blocks live in contiguous
// vectors in id order: Ceres orders blocks inside a Schur group by address, so this makes the elimination
// order (and with it every floating-point result) identical from run to run.
struct State {
  std::vector<PoseParameters> poseStorage;
  std::vector<double> rhoStorage;
  std::map<KeyFrameId, double*> poses;
  std::map<MapPointId, double*> rhos;

  explicit State(const BAProblem& problem) {
    poseStorage.reserve(problem.keyframes.size());
    for (const auto& [id, kf] : problem.keyframes) poseStorage.push_back(toPoseParameters(kf.T_cam_world));
    rhoStorage.reserve(problem.points.size());
    for (const auto& [id, p] : problem.points) rhoStorage.push_back(p.inverseDepth);
    std::size_t i = 0;
    for (const auto& [id, kf] : problem.keyframes) poses[id] = poseStorage[i++].data();
    i = 0;
    for (const auto& [id, p] : problem.points) rhos[id] = &rhoStorage[i++];
  }
  State(const State&) = delete;
  State& operator=(const State&) = delete;
};

struct ObservationCheck {
  Eigen::Vector2d whitened;
  Eigen::Vector2d pixels;  ///< unweighted residual
  bool inFront = true;
  bool isAnchor = false;
};

ObservationCheck evaluate(const BAProblem& problem, const State& state, const BAObservation& o) {
  const BAPoint& p = problem.points.at(o.point);
  const double rho = *state.rhos.at(o.point);
  ObservationCheck c;
  c.isAnchor = o.keyframe == p.anchor;
  Eigen::Vector3d ph;
  if (c.isAnchor) {
    ph = p.bearing;
  } else {
    ph = anchoredPointInTarget<double>(state.poses.at(p.anchor), state.poses.at(o.keyframe), rho, p.bearing);
  }
  // Depth in the observing camera is ph.z / rho: positive iff the point is in front of its anchor (rho > 0;
  // rho = 0 is a direction at infinity) and ph.z > 0.
  c.inFront = rho >= 0.0 && ph.z() > 0.0;
  whitenedReprojection<double>(ph, problem.keyframes.at(o.keyframe).camera, o.pixel, 1.0, c.pixels.data());
  c.whitened = c.pixels * std::sqrt(o.invSigma2);
  return c;
}

// Unweighted RMS over the non-anchor observations not flagged in `skip`.
double rmsPixels(const BAProblem& problem, const State& state, const std::vector<bool>& skip) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (skip[i]) continue;
    const ObservationCheck c = evaluate(problem, state, problem.observations[i]);
    if (c.isAnchor) continue;
    sum += c.pixels.squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

/// Ends a Ceres solve after the current iteration once `stop` is set (the best point so far is kept).
class StopCallback : public ceres::IterationCallback {
 public:
  explicit StopCallback(const std::atomic<bool>* stop) : stop_(stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stop_ && stop_->load() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* stop_;
};

// One Levenberg-Marquardt pass over the observations not excluded. Returns the Ceres summary.
//
// Ceres orders the blocks of a Schur group by address. The keypoints' poses and inverse depths live in the
// State's id-ordered vectors, but the factors' landmark and shared blocks are owned by the factors, each its own
// heap object, so their addresses -- relative to each other and to the State's vectors -- change with the heap's
// history. The pass therefore optimizes one contiguous copy laid out as [poses | shared blocks | inverse depths |
// factor landmarks] (ids in order, factor blocks in first-use order) and writes it back afterwards: the
// elimination order, and with it every floating-point result, is the same from run to run and process to process.
ceres::Solver::Summary solvePass(const BAProblem& problem, State& state, const std::vector<bool>& excluded,
                                 const std::vector<bool>& factorExcluded,
                                 const std::map<KeyFrameId, bool>& keyframeFixed, bool robust, int iterations,
                                 const BundleAdjustmentParams& params, int& residualBlocks,
                                 const std::atomic<bool>* stop) {
  ceres::HuberLoss huber(params.huberDelta);
  ceres::Problem::Options problemOptions;
  problemOptions.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;

  struct FactorResidual {
    std::size_t factor;
    ceres::CostFunction* cost;
  };
  struct OwnBlock {
    double* block;        ///< owned by the factor
    int size;
    std::size_t factor;   ///< first factor using it (its manifold and fixedness)
    std::size_t index;    ///< landmark block index within that factor
  };
  std::vector<FactorResidual> factorResiduals;
  std::vector<OwnBlock> shared, landmarks;  ///< distinct factor-owned blocks, in first-use order
  std::set<double*> seenShared, seenLandmark;
  for (std::size_t i = 0; i < problem.factors.size(); ++i) {
    if (factorExcluded[i]) continue;
    const BAFactor& f = *problem.factors[i];
    FactorResidual r{i, f.newCostFunction()};
    const std::vector<int>& sizes = r.cost->parameter_block_sizes();
    const std::size_t nPoses = f.keyframes().size();
    const std::vector<double*> landmark = f.landmarkBlocks();
    for (std::size_t b = 0; b < landmark.size(); ++b)
      if (seenLandmark.insert(landmark[b]).second) landmarks.push_back({landmark[b], sizes.at(nPoses + b), i, b});
    const std::vector<double*> sharedBlocks = f.sharedBlocks();
    for (std::size_t b = 0; b < sharedBlocks.size(); ++b)
      if (seenShared.insert(sharedBlocks[b]).second)
        shared.push_back({sharedBlocks[b], sizes.at(nPoses + landmark.size() + b), i, b});
    factorResiduals.push_back(r);
  }

  // The contiguous copy and where each block lives in it.
  std::vector<std::pair<double*, int>> layout;  ///< (original block, size), in storage order
  for (auto& [id, pose] : state.poses) layout.emplace_back(pose, kPoseSize);
  for (const OwnBlock& b : shared) layout.emplace_back(b.block, b.size);
  for (auto& [id, rho] : state.rhos) layout.emplace_back(rho, 1);
  for (const OwnBlock& b : landmarks) layout.emplace_back(b.block, b.size);
  std::vector<std::size_t> offsets(layout.size());
  std::size_t total = 0;
  for (std::size_t k = 0; k < layout.size(); ++k) {
    offsets[k] = total;
    total += static_cast<std::size_t>(layout[k].second);
  }
  std::vector<double> storage(total);
  for (std::size_t k = 0; k < layout.size(); ++k)
    std::copy(layout[k].first, layout[k].first + layout[k].second, storage.data() + offsets[k]);
  // Written back on every exit (the values are unchanged when nothing is solved).
  struct WriteBack {
    const std::vector<std::pair<double*, int>>& layout;
    const std::vector<std::size_t>& offsets;
    const std::vector<double>& storage;
    ~WriteBack() {
      for (std::size_t k = 0; k < layout.size(); ++k)
        std::copy(storage.data() + offsets[k], storage.data() + offsets[k] + layout[k].second, layout[k].first);
    }
  } writeBack{layout, offsets, storage};
  std::size_t k = 0;
  std::map<KeyFrameId, double*> poses;  ///< id -> local block (the same lookups as the State's maps)
  for (auto& [id, pose] : state.poses) poses[id] = storage.data() + offsets[k++];
  std::map<const double*, double*> ownLocal;  ///< factor-owned block -> local block
  for (const OwnBlock& b : shared) ownLocal[b.block] = storage.data() + offsets[k++];
  std::map<MapPointId, double*> rhos;
  for (auto& [id, rho] : state.rhos) rhos[id] = storage.data() + offsets[k++];
  for (const OwnBlock& b : landmarks) ownLocal[b.block] = storage.data() + offsets[k++];

  ceres::Problem ceresProblem(problemOptions);
  residualBlocks = 0;
  for (std::size_t i = 0; i < problem.observations.size(); ++i) {
    if (excluded[i]) continue;
    const BAObservation& o = problem.observations[i];
    const BAPoint& p = problem.points.at(o.point);
    if (o.keyframe == p.anchor) continue;  // constant residual (see InverseDepthReprojectionError.h)
    ceresProblem.AddResidualBlock(
        new InverseDepthReprojectionCost(p.bearing, o.pixel, o.invSigma2, problem.keyframes.at(o.keyframe).camera),
        robust ? &huber : nullptr, poses.at(p.anchor), poses.at(o.keyframe), rhos.at(o.point));
    ++residualBlocks;
  }
  std::vector<std::unique_ptr<ceres::HuberLoss>> factorLosses;
  for (const FactorResidual& r : factorResiduals) {
    const BAFactor& f = *problem.factors[r.factor];
    ceres::LossFunction* loss = nullptr;
    if (robust && f.huberDelta() > 0.0) {
      factorLosses.push_back(std::make_unique<ceres::HuberLoss>(f.huberDelta()));
      loss = factorLosses.back().get();
    }
    std::vector<double*> blocks;
    for (KeyFrameId kf : f.keyframes()) blocks.push_back(poses.at(kf));
    for (double* b : f.landmarkBlocks()) blocks.push_back(ownLocal.at(b));
    for (double* b : f.sharedBlocks()) blocks.push_back(ownLocal.at(b));
    ceresProblem.AddResidualBlock(r.cost, loss, blocks);
    ++residualBlocks;
  }
  for (const OwnBlock& b : landmarks) {
    const BAFactor& f = *problem.factors[b.factor];
    double* block = ownLocal.at(b.block);
    if (ceres::Manifold* m = f.newLandmarkManifold(b.index)) ceresProblem.SetManifold(block, m);
    if (f.landmarkFixed()) ceresProblem.SetParameterBlockConstant(block);
  }
  ceres::Solver::Summary summary;
  if (residualBlocks == 0) return summary;

  // Schur ordering: every inverse depth in the first (eliminated) group, poses in the second.
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (auto& [id, pose] : poses) {
    if (!ceresProblem.HasParameterBlock(pose)) continue;
    ceresProblem.SetManifold(pose, new PoseManifold);
    if (keyframeFixed.at(id)) ceresProblem.SetParameterBlockConstant(pose);
    ordering->AddElementToGroup(pose, 1);
  }
  for (auto& [id, rho] : rhos) {
    if (!ceresProblem.HasParameterBlock(rho)) continue;
    if (problem.points.at(id).fixed) ceresProblem.SetParameterBlockConstant(rho);
    ordering->AddElementToGroup(rho, 0);
  }
  for (const OwnBlock& b : landmarks) ordering->AddElementToGroup(ownLocal.at(b.block), 0);
  for (const OwnBlock& b : shared) ordering->AddElementToGroup(ownLocal.at(b.block), 1);  // with the poses

  ceres::Solver::Options options;
  options.linear_solver_type = params.linearSolver == "dense_schur" ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.linear_solver_ordering = ordering;
  options.max_num_iterations = iterations;
  options.function_tolerance = params.functionTolerance;
  options.num_threads = params.numThreads;
  options.logging_type = ceres::SILENT;
  // ORB-SLAM's abort flag: a stop request ends the pass after the current iteration, keeping its best point.
  StopCallback stopCallback(stop);
  if (stop) options.callbacks.push_back(&stopCallback);
  ceres::Solve(options, &ceresProblem, &summary);
  return summary;
}

BAResult run(const BAProblem& problem, const BundleAdjustmentParams& params, const std::map<KeyFrameId, bool>& fixed,
             int firstIterations, int secondIterations, const std::atomic<bool>* stop = nullptr) {
  const auto start = std::chrono::steady_clock::now();
  State state(problem);
  const State initialState(problem);
  BAResult result;

  std::vector<bool> excluded(problem.observations.size(), false);
  std::vector<bool> factorExcluded(problem.factors.size(), false);
  int blocks = 0;
  const ceres::Solver::Summary first =
      solvePass(problem, state, excluded, factorExcluded, fixed, true, firstIterations, params, blocks, stop);
  result.residualBlocks = blocks;
  result.initialCost = first.initial_cost;
  result.finalCost = first.final_cost;
  result.iterations = static_cast<int>(first.iterations.size());
  auto addTimes = [&](const ceres::Solver::Summary& summary) {
    result.jacobianSeconds += std::max(0.0, summary.jacobian_evaluation_time_in_seconds) +
                              std::max(0.0, summary.residual_evaluation_time_in_seconds);
    result.linearSolverSeconds += std::max(0.0, summary.linear_solver_time_in_seconds);
  };
  addTimes(first);

  auto isOutlier = [&](std::size_t i) {
    const ObservationCheck c = evaluate(problem, state, problem.observations[i]);
    return !(c.whitened.squaredNorm() <= params.chi2Threshold) || !c.inFront;
  };
  auto isFactorOutlier = [&](std::size_t i) {
    const BAFactor& f = *problem.factors[i];
    std::unique_ptr<ceres::CostFunction> cost(f.newCostFunction());
    std::vector<double> r(static_cast<std::size_t>(cost->num_residuals()));
    const std::vector<double*> blocks = factorBlocks(f, state.poses);
    if (!cost->Evaluate(blocks.data(), r.data(), nullptr)) return true;
    double chi2 = 0.0;
    for (double v : r) chi2 += v * v;
    return !(chi2 <= f.chi2Threshold());
  };
  result.stopped = stop && stop->load();
  // Stopped: no second pass (ORB-SLAM's bDoMore = false); the outliers are still found and reported below.
  if (secondIterations > 0 && !result.stopped) {
    for (std::size_t i = 0; i < excluded.size(); ++i) excluded[i] = isOutlier(i);
    for (std::size_t i = 0; i < factorExcluded.size(); ++i) factorExcluded[i] = isFactorOutlier(i);
    const ceres::Solver::Summary second =
        solvePass(problem, state, excluded, factorExcluded, fixed, false, secondIterations, params, blocks, stop);
    result.stopped = stop && stop->load();
    if (blocks > 0) {
      result.finalCost = second.final_cost;
      result.iterations += static_cast<int>(second.iterations.size());
      addTimes(second);
    }
  }
  for (std::size_t i = 0; i < problem.observations.size(); ++i)
    if (isOutlier(i)) result.outliers.push_back(i);
  for (std::size_t i = 0; i < problem.factors.size(); ++i)
    if (isFactorOutlier(i)) result.factorOutliers.push_back(i);

  // Report every free block that took part in the optimization.
  std::map<KeyFrameId, bool> used;
  std::map<MapPointId, bool> usedPoint;
  for (const BAObservation& o : problem.observations) {
    const BAPoint& p = problem.points.at(o.point);
    if (o.keyframe == p.anchor) continue;
    used[o.keyframe] = used[p.anchor] = true;
    usedPoint[o.point] = true;
  }
  for (const auto& f : problem.factors)
    for (KeyFrameId kf : f->keyframes()) used[kf] = true;
  for (const auto& [id, u] : used)
    if (!fixed.at(id)) result.poses[id] = fromPoseParameters(state.poses.at(id));
  for (const auto& [id, u] : usedPoint)
    if (!problem.points.at(id).fixed) result.inverseDepths[id] = *state.rhos.at(id);

  // Error statistics over the final inliers, so that a few gross outliers do not hide the improvement.
  std::vector<bool> skip(problem.observations.size(), false);
  for (std::size_t i : result.outliers) skip[i] = true;
  result.initialRmsPixels = rmsPixels(problem, initialState, skip);
  result.finalRmsPixels = rmsPixels(problem, state, skip);
  result.solveSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace

BAResult localBundleAdjustment(const BAProblem& problem, const BundleAdjustmentParams& params,
                               const std::atomic<bool>* stop) {
  params.check();
  validate(problem);
  std::map<KeyFrameId, bool> fixed;
  bool anyFixed = false;
  for (const auto& [id, kf] : problem.keyframes) {
    fixed[id] = kf.fixed;
    anyFixed = anyFixed || kf.fixed;
  }
  require(anyFixed || problem.keyframes.empty(), "local bundle adjustment",
          "no fixed keyframe: the gauge (world frame) would be free");
  return run(problem, params, fixed, params.firstPassIterations, params.secondPassIterations, stop);
}

BAResult globalBundleAdjustment(const BAProblem& problem, const BundleAdjustmentParams& params,
                                const std::atomic<bool>* stop) {
  params.check();
  validate(problem);
  std::map<KeyFrameId, bool> fixed;
  for (const auto& [id, kf] : problem.keyframes) fixed[id] = kf.fixed;
  if (!fixed.empty()) fixed.begin()->second = true;  // the first keyframe defines the world frame
  return run(problem, params, fixed, params.globalIterations, 0, stop);
}

}  // namespace pslam::optimize
