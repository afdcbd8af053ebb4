#pragma once
// One interface over the three ways a frame gets normals: the NORMALS channel already in the rawlog
// (ground truth of synthetic scenes), normals from the DEPTH channel (thesis "-w AHC"), or a network on
// the CAMERA image (thesis "-w Segmentation"/"-w GeoNet").
#include <filesystem>
#include <memory>
#include <string>

#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalMap.h"

namespace pslam::priors {

class NormalSource {
 public:
  virtual ~NormalSource() = default;
  /// Normals of one frame. Throws pslam::Error naming the frame if the needed channel is missing.
  virtual NormalMap compute(const datasets::Frame& frame) = 0;
  /// "rawlog", "depth" or "network".
  virtual std::string kind() const = 0;
};

/// kind: "rawlog" | "depth" | "network". `iniPath` (may be empty for "rawlog" and "depth", which then use
/// defaults) supplies the [NormalsFromDepth] / [NormalsFromNetwork] section. Throws pslam::Error on an unknown
/// kind, a missing ini, or bad parameters.
std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const std::filesystem::path& iniPath);

inline constexpr const char* kDepthNormalsSection = "NormalsFromDepth";
inline constexpr const char* kNetworkNormalsSection = "NormalsFromNetwork";

}  // namespace pslam::priors
