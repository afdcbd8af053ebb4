#pragma once
// One interface over the three ways a frame gets normals: the NORMALS channel already in the rawlog
// (ground truth of synthetic scenes), normals from the DEPTH channel (thesis "-w AHC"), or a network on
// the CAMERA image (thesis "-w Segmentation"/"-w GeoNet").
#include <filesystem>
#include <memory>
#include <string>

#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/priors/NormalsFromDepth.h"
#include "pslam/priors/NormalsFromNetwork.h"

namespace pslam::priors {

class NormalSource {
 public:
  virtual ~NormalSource() = default;
  /// Normals of one frame. Throws pslam::Error naming the frame if the needed channel is missing.
  virtual NormalMap compute(const datasets::Frame& frame) = 0;
  /// "rawlog", "depth" or "network".
  virtual std::string kind() const = 0;
};

inline constexpr const char* kDepthNormalsSection = "NormalsFromDepth";
inline constexpr const char* kNetworkNormalsSection = "NormalsFromNetwork";

/// The normal sources' sections of an ini file (config/manhattan/*.ini); a tool whose ini holds more sections
/// lists these with its own in a visitSections() (pslam/core/Params.h) and calls resolvePaths() after loading.
struct NormalSourceParams {
  DepthNormalParams depth;
  NetworkNormalParams network;  ///< model empty = no network configured
  template <class V>
  void visitSections(V& v) {
    v.section(kDepthNormalsSection, depth);
    v.section(kNetworkNormalsSection, network);
  }
  /// The network's relative model/config paths against the ini's folder.
  void resolvePaths(const std::filesystem::path& iniPath);
};

/// kind: "rawlog" | "depth" | "network". Throws pslam::Error on an unknown kind, or for "network" without a
/// [NormalsFromNetwork] model.
std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const NormalSourceParams& params);

/// The same from an ini file that holds only the normal sources' sections (empty path: defaults, which suffice
/// for "rawlog" and "depth"). Read strictly: errors name the file, section and key.
std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const std::filesystem::path& iniPath);

}  // namespace pslam::priors
