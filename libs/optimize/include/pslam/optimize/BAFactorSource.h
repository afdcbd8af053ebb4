#pragma once
// Something besides the keypoints that takes part in local BA (doc/architecture.md, "The plug-in seam"): the
// landmark modules (direct points, line segments: tracking::LandmarkModule) and the Manhattan rotation priors of
// the keyframes (tracking::ManhattanPath). mapping::LocalMapper asks each registered source, in the order they
// were registered, for its factors of the window's problem, and gives each the outlier flags of its own factors
// after the solve.
#include <memory>
#include <vector>

#include "pslam/map/Map.h"
#include "pslam/optimize/BundleAdjustment.h"

namespace pslam::optimize {

class BAFactorSource {
 public:
  virtual ~BAFactorSource() = default;
  /// Factors of this source for the local-BA `problem` of `map` (BAProblem::factors); their keyframes must be
  /// keyframes of the window. Empty when it has none.
  virtual std::vector<std::shared_ptr<BAFactor>> bundleAdjustmentFactors(const map::Map& map,
                                                                        const BAProblem& problem) = 0;
  /// After the solve: the outlier flags of the factors bundleAdjustmentFactors() returned, in the same order.
  /// Default: nothing to update (a prior).
  virtual void afterBundleAdjustment(const std::vector<bool>& /*factorOutliers*/) {}
};

}  // namespace pslam::optimize
