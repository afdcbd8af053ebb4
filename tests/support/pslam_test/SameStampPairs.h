#pragma once
// The poses of an estimate and of its ground truth that share a timestamp (within 0.1 ms), in the estimate's order:
// the pairs the end-to-end tests align and evaluate (SLAM frames carry the rawlog's CAMERA stamps, which the
// ground truth repeats).
#include <cmath>
#include <utility>

#include "pslam/core/Trajectory.h"

namespace pslam::test_support {

/// {ground-truth poses, estimate poses}, pair by pair; estimate poses without a ground-truth stamp are left out.
inline std::pair<Trajectory, Trajectory> sameStampPairs(const Trajectory& gt, const Trajectory& est) {
  Trajectory g, e;
  for (const auto& p : est)
    for (const auto& q : gt)
      if (std::abs(q.timestamp - p.timestamp) < 1e-4) {
        g.push_back(q);
        e.push_back(p);
        break;
      }
  return {g, e};
}

}  // namespace pslam::test_support
