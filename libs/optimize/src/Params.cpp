#include "pslam/optimize/Params.h"

PSLAM_DEFINE_PARAMS(pslam::optimize::PoseOptimizationParams)
PSLAM_DEFINE_PARAMS(pslam::optimize::BundleAdjustmentParams)
