#pragma once
// Identifiers of keyframes and map points (the camera of a keyframe is geometry::PinholeCamera, without distortion).
// Objects refer to each other only by id (no pointers), so the map is plain, copyable and versionable.
#include <cstdint>
#include <limits>
#include <string>

#include <Eigen/Core>

#include "pslam/geometry/PinholeCamera.h"

namespace pslam::map {

using KeyFrameId = std::uint64_t;
using MapPointId = std::uint64_t;
inline constexpr KeyFrameId kNoKeyFrame = std::numeric_limits<KeyFrameId>::max();
inline constexpr MapPointId kNoMapPoint = std::numeric_limits<MapPointId>::max();

}  // namespace pslam::map
