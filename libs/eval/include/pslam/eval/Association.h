#pragma once
// Pairing the poses of a ground-truth and an estimated trajectory before any metric is computed.
//
// Two timestamp rules are offered because the reference tools of the field differ, and the rule changes
// the numbers when the estimate is denser than the ground truth or has stamps close to two GT stamps:
//  - Rule::Nearest (evo, evo/core/sync.py `associate_trajectories` / `matching_time_indices`; the
//    DEFAULT): the SHORTER trajectory is searched (the estimate when both have the same length); each of its
//    stamps is paired with the nearest stamp of the longer one (first one on a tie) if |dt| <= maxDiff.
//    No one-to-one constraint: one stamp of the longer trajectory may be used several times.
//  - Rule::OneToOneGreedy (TUM RGB-D benchmark associate.py): all candidate pairs with |dt| < maxDiff
//    (strict) are sorted by (|dt|, gt stamp, est stamp) and accepted greedily when neither stamp is used
//    yet: a one-to-one matching. Pairs are returned in gt stamp order.
//  - Rule::ByIndex: pose k with pose k (KITTI files have no stamps); both must have the same length.
// `offset` is added to the estimate's stamps before matching (evo `--t_offset`, TUM `--offset`).
#include <cstddef>
#include <string>
#include <vector>

#include "pslam/core/Trajectory.h"

namespace pslam::eval {

enum class AssociationRule { Nearest, OneToOneGreedy, ByIndex };

/// "nearest" | "tum" | "index"; throws pslam::Error naming the value otherwise.
AssociationRule parseAssociationRule(const std::string& name);
std::string toString(AssociationRule rule);

struct AssociationOptions {
  AssociationRule rule = AssociationRule::Nearest;
  double maxTimeDifference = 0.01;  ///< seconds; evo's max_diff default (TUM associate.py uses 0.02)
  double offset = 0.0;              ///< seconds, added to the estimate's stamps
};

/// Index pairs (gt[k], est[k]) in the order of the searched trajectory (Nearest), gt stamps (TUM) or index.
struct Association {
  std::vector<std::size_t> gtIndex;
  std::vector<std::size_t> estIndex;
  std::size_t size() const { return gtIndex.size(); }
};

/// Pairs the poses. Throws pslam::Error if either trajectory is empty, if ByIndex lengths differ, or if
/// no pair is found (message gives maxDiff and offset). Does not sort or deduplicate the inputs.
Association associate(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options);

/// The associated sub-trajectories, pose k of each forming pair k.
void selectAssociated(const Trajectory& gt, const Trajectory& est, const Association& association,
                      Trajectory& gtOut, Trajectory& estOut);

}  // namespace pslam::eval
