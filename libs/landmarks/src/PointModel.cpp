#include "pslam/landmarks/PointModel.h"

PSLAM_DEFINE_PARAMS(pslam::landmarks::PointModelParams)
