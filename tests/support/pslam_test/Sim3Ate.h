#pragma once
// The ATE the end-to-end tests assert on: the estimate's poses paired with the ground truth by timestamp
// (sameStampPairs), Sim(3)-aligned (monocular scale), RMSE of the position error.
#include "pslam/core/Trajectory.h"
#include "pslam/eval/Metrics.h"
#include "pslam_test/SameStampPairs.h"

namespace pslam::test_support {

/// Sim(3) ATE RMSE of `est` against `gt` over their common timestamps.
inline double ateSim3(const Trajectory& gt, const Trajectory& est) {
  const auto [g, e] = sameStampPairs(gt, est);
  const auto alignment = eval::alignTrajectories(g, e, eval::AlignmentMode::Sim3);
  return eval::computeAte(g, eval::applyAlignment(e, alignment)).stats.rmse;
}

}  // namespace pslam::test_support
