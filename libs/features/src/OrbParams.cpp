#include "pslam/features/OrbExtractor.h"

PSLAM_DEFINE_PARAMS(pslam::features::OrbParams)
