#include "pslam/mapping/LocalMapper.h"

PSLAM_DEFINE_PARAMS(pslam::mapping::LocalMappingParams)
