#pragma once
// Glue between pslam::map::Map and the bundle adjuster: extract a window as a BAProblem, write a BAResult
// back (poses, inverse depths, erasing outlier observations as ORB-SLAM does after local BA).
#include <cmath>
#include <functional>

#include "pslam/map/Map.h"
#include "pslam/optimize/BundleAdjustment.h"

namespace pslam::optimize {

/// Which map points take part in an optimization. Thesis §3.4.3: only points the probabilistic model
/// currently considers inliers (inlier ratio >= psi_min); empty = every non-bad point.
using PointFilter = std::function<bool(const map::MapPoint&)>;

/// Local window of `centre` (Map::localWindow with params.maxLocalKeyFrames): local keyframes free, the
/// others observing the selected local points fixed; the root keyframe is always fixed (gauge when no
/// other keyframe is). Bad points and points rejected by `usePoint` are left out.
BAProblem makeLocalProblem(const map::Map& map, map::KeyFrameId centre, const BundleAdjustmentParams& params = {},
                           const PointFilter& usePoint = {});

/// Every keyframe and every non-bad point accepted by `usePoint` (globalBundleAdjustment fixes the root).
BAProblem makeGlobalProblem(const map::Map& map, const PointFilter& usePoint = {});

struct MapUpdateSummary {
  int posesUpdated = 0;
  int pointsUpdated = 0;
  int observationsErased = 0;
  int pointsErased = 0;  ///< points that lost their last observation
  int pointsNotMoved = 0;  ///< points the BA put at or behind infinity (rho <= 0): their depth is left as it was
};

/// Can a point take this BA-refined inverse depth? Not when it is <= 0 or not finite: the BA put the point at or
/// behind its anchor's infinity, and there is no finite position to give it (written as 0, it became an infinitely
/// far point that the next pose optimization refused as non-finite input). Such a point keeps its depth.
inline bool isFiniteInverseDepth(double rho) { return rho > 0.0 && std::isfinite(rho); }

/// Writes poses and inverse depths into `map`, erases the outlier observations when eraseOutliers, and
/// refreshes the normal / scale distances of the touched points. A point whose refined inverse depth fails
/// isFiniteInverseDepth keeps its depth.
MapUpdateSummary applyResult(map::Map& map, const BAProblem& problem, const BAResult& result,
                             bool eraseOutliers = true);


/// Convenience for the initial map: makeGlobalProblem + globalBundleAdjustment + applyResult. Outlier
/// observations are reported in `resultOut` but not erased (ORB-SLAM leaves that to the initializer).
MapUpdateSummary globalBundleAdjustment(map::Map& map, const BundleAdjustmentParams& params = {},
                                        BAResult* resultOut = nullptr, const PointFilter& usePoint = {});

}  // namespace pslam::optimize
