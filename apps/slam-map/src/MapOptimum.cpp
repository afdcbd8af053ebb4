// slam-map optimum: keyframe ATE of a map after a global BA from it and from the ground-truth poses (doc/maps.md).
#include "pslam/apps/SlamMapApp.h"

#include "MapAppSupport.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/Plot.h"
#include "pslam/eval/TrajectoryIO.h"
#include "pslam/landmarks/KeypointModel.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/lines/LineFrontEnd.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/map/MapIO.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/optimize/MapAdapter.h"

namespace fs = std::filesystem;

namespace pslam::apps {



namespace {

/// The keyframe trajectory (timestamp order) and the ground-truth pose of each keyframe.
struct KeyFramePairs {
  Trajectory estimate, groundTruth;
};

KeyFramePairs keyFramePairs(const map::Map& map, const Trajectory& groundTruthSorted, const OptimumOptions& options) {
  KeyFramePairs pairs;
  for (const map::KeyFrame* kf : keyFramesByTime(map)) {
    const StampedPose* gt = nearestPose(groundTruthSorted, kf->timestamp, options.maxTimeDifference);
    require(gt != nullptr, "slam-map optimum",
            "keyframe " + std::to_string(kf->id) + " (stamp " + fmt(kf->timestamp, 6) + " s) has no pose within " +
                fmt(options.maxTimeDifference, 3) + " s in " + options.groundTruth.string());
    pairs.estimate.emplace_back(kf->timestamp, kf->T_world_cam());
    pairs.groundTruth.push_back(*gt);
  }
  return pairs;
}

OptimumStage measureStage(const std::string& name, const map::Map& map, const Trajectory& groundTruthSorted,
                          const OptimumOptions& options) {
  const KeyFramePairs pairs = keyFramePairs(map, groundTruthSorted, options);
  OptimumStage stage;
  stage.name = name;
  const eval::Alignment a = eval::alignTrajectories(pairs.groundTruth, pairs.estimate, eval::AlignmentMode::Sim3);
  stage.ate = eval::computeAte(pairs.groundTruth, eval::applyAlignment(pairs.estimate, a)).stats.rmse;
  if (options.segments > 0)
    stage.scaleSpread = eval::segmentScaleRange(eval::alignSegments(pairs.groundTruth, pairs.estimate,
                                                                    eval::AlignmentMode::Sim3, options.segments))
                            .spread();
  return stage;
}

/// Two stages: `m` as it is, then after a global BA of it (which `m` receives).
void addGlobalBundleAdjustmentStages(map::Map& m, const std::string& before, const std::string& after,
                                     const optimize::BundleAdjustmentParams& ba, const Trajectory& groundTruthSorted,
                                     const OptimumOptions& options, std::vector<OptimumStage>& stages) {
  OptimumStage start = measureStage(before, m, groundTruthSorted, options);
  optimize::BAResult r;
  optimize::globalBundleAdjustment(m, ba, &r);
  start.cost = r.initialCost;
  start.rmsPixels = r.initialRmsPixels;
  OptimumStage end = measureStage(after, m, groundTruthSorted, options);
  end.cost = r.finalCost;
  end.rmsPixels = r.finalRmsPixels;
  end.iterations = r.iterations;
  end.outliers = r.outliers.size();
  stages.push_back(start);
  stages.push_back(end);
}

}  // namespace

void OptimumOptions::check() const {
  require(iterations >= 1, "slam-map optimum",
          "--iterations must be at least 1 (got " + std::to_string(iterations) + ")");
  require(std::isfinite(maxTimeDifference) && maxTimeDifference > 0.0, "slam-map optimum",
          "--max-diff must be a positive number of seconds");
}

nlohmann::json OptimumStage::toJson() const {
  return {{"name", name},   {"keyframe_ate_m", ate}, {"scale_spread", scaleSpread}, {"cost", cost},
          {"rms_px", rmsPixels}, {"iterations", iterations}, {"outliers", outliers}};
}

nlohmann::json MapOptimum::toJson() const {
  nlohmann::json s = nlohmann::json::array();
  for (const OptimumStage& st : stages) s.push_back(st.toJson());
  return {{"map", file.string()},
          {"groundtruth", groundTruth.string()},
          {"keyframes", keyFrames},
          {"observations", observations},
          {"stages", s}};
}

std::string MapOptimum::toText() const {
  std::ostringstream os;
  os << "map: " << file.string() << " (" << keyFrames << " keyframes, " << observations << " observations)\n";
  os << "ground truth: " << groundTruth.string() << "\n";
  os << "state                 keyframe ATE   scale spread   BA cost       RMS px   BA its   outliers\n";
  for (const OptimumStage& st : stages) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%-20s  %10.4f m   %10.2f %%   %10.1f   %6.3f   %6d   %8zu\n", st.name.c_str(),
                  st.ate, 100.0 * st.scaleSpread, st.cost, st.rmsPixels, st.iterations, st.outliers);
    os << buf;
  }
  return os.str();
}

MapOptimum mapOptimum(const map::Map& savedMap, const Trajectory& groundTruth, const OptimumOptions& options) {
  options.check();
  const std::string ctx = "slam-map optimum";
  require(savedMap.numKeyFrames() >= 3, ctx, "the map has fewer than 3 keyframes");
  require(options.segments == 0 || savedMap.numKeyFrames() >= 3 * options.segments, ctx,
          "--segments " + std::to_string(options.segments) + " needs at least 3 keyframes per stretch; the map has " +
              std::to_string(savedMap.numKeyFrames()));
  Trajectory gt = groundTruth;
  std::stable_sort(gt.begin(), gt.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  MapOptimum out;
  out.keyFrames = savedMap.numKeyFrames();
  optimize::BundleAdjustmentParams ba;
  ba.globalIterations = options.iterations;

  // 1-2. The saved map, and a global BA from it.
  map::Map fromSaved = savedMap;
  addGlobalBundleAdjustmentStages(fromSaved, "saved", "ba_from_saved", ba, gt, options, out.stages);
  forGoodPoints(savedMap, [&](map::MapPointId, const map::MapPoint& p) { out.observations += p.observations.size(); });

  // 3. Every keyframe at its ground-truth pose, brought into the map's frame by the saved map's Sim(3) alignment
  // (p_gt = s R p_map + t), the points' depths refit along their anchor rays with the poses held.
  const KeyFramePairs pairs = keyFramePairs(savedMap, gt, options);
  const eval::Alignment a = eval::alignTrajectories(pairs.groundTruth, pairs.estimate, eval::AlignmentMode::Sim3);
  map::Map atTruth = savedMap;
  for (const map::KeyFrame* kf : keyFramesByTime(savedMap)) {
    const Eigen::Isometry3d T_gt = nearestPose(gt, kf->timestamp, options.maxTimeDifference)->T_world_cam();
    Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
    T_world_cam.linear() = a.rotation.transpose() * T_gt.linear();
    T_world_cam.translation() = a.rotation.transpose() * (T_gt.translation() - a.translation) / a.scale;
    atTruth.setKeyFramePose(kf->id, T_world_cam.inverse());
  }
  {
    optimize::BAProblem depthsOnly = optimize::makeGlobalProblem(atTruth);
    for (auto& [id, kf] : depthsOnly.keyframes) kf.fixed = true;
    optimize::BundleAdjustmentParams refit = ba;
    refit.firstPassIterations = refit.secondPassIterations = options.iterations;
    optimize::applyResult(atTruth, depthsOnly, optimize::localBundleAdjustment(depthsOnly, refit), false);
  }
  // 4. A global BA from there.
  addGlobalBundleAdjustmentStages(atTruth, "groundtruth_poses", "ba_from_groundtruth", ba, gt, options, out.stages);
  return out;
}

MapOptimum mapOptimum(const OptimumOptions& options) {
  options.check();
  const map::Map m = map::loadMap(options.map);
  const Trajectory gt = eval::readTrajectory(options.groundTruth);
  require(!gt.empty(), "slam-map optimum", options.groundTruth.string() + " holds no pose");
  // A static ground truth cannot be aligned to: refused before any bundle adjustment runs (and prints).
  const bool moves = std::any_of(gt.begin(), gt.end(), [&](const StampedPose& p) {
    return (p.position - gt.front().position).norm() > 1e-9 * std::max(1.0, gt.front().position.norm());
  });
  require(gt.size() < 2 || moves, options.groundTruth.string(),
          "all " + std::to_string(gt.size()) + " poses are at one position: a static ground truth cannot be aligned");
  MapOptimum out = mapOptimum(m, gt, options);
  out.file = options.map;
  out.groundTruth = options.groundTruth;
  return out;
}

}  // namespace pslam::apps
