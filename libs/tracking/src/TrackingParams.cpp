#include "pslam/tracking/TrackingParams.h"

namespace pslam::tracking {

PSLAM_DEFINE_PARAMS(TrackerParams)
PSLAM_DEFINE_PARAMS(ManhattanPathParams)

}  // namespace pslam::tracking
