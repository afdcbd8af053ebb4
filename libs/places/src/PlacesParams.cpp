#include "pslam/places/PlacesParams.h"

namespace pslam::places {

PSLAM_DEFINE_PARAMS(PlacesParams)

}  // namespace pslam::places
