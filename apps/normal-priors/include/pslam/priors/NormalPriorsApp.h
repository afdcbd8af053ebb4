#pragma once
// The `normal-priors` tool: copies a rawlog, adding (or replacing) the NORMALS channel of every frame from
// depth or from a network. The ground-truth file `<stem>_groundtruth.txt` is copied along when present.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/priors/NormalSource.h"

namespace pslam::priors {

struct NormalPriorsOptions {
  std::filesystem::path input;   ///< existing rawlog
  std::filesystem::path output;  ///< new rawlog (its `<stem>_Images/` is written beside it)
  std::string source = "depth";  ///< "depth" or "network" ("rawlog" would copy the channel unchanged)
  std::filesystem::path config;  ///< ini with [NormalsFromDepth] / [NormalsFromNetwork]; empty = defaults
  bool planarOnly = true;        ///< store normals only inside the planar mask (thesis §4.2)
  bool progress = true;
};

/// The sections normal-priors accepts in its --config: the normal sources' and, because the same files
/// configure manhattan-eval (config/manhattan/*.ini), [ManhattanTracker], which is checked too (a bad value is
/// reported by whichever tool reads the file) but not used.
struct NormalPriorsConfig {
  NormalSourceParams normals;
  manhattan::ManhattanParams tracker;
  template <class V>
  void visitSections(V& v) {
    normals.visitSections(v);
    v.section("ManhattanTracker", tracker);
  }
  /// Strict (pslam/core/Params.h): errors name the file, section and key. Empty path: the defaults.
  static NormalPriorsConfig loadFromFile(const std::filesystem::path& path);
};

struct NormalPriorsResult {
  std::size_t frames = 0;
  double meanNormalsMs = 0.0;     ///< time per frame of the normal source
  double meanPlanarShare = 0.0;   ///< mean share of pixels that received a normal
};

/// Runs the conversion. Throws pslam::Error naming the file/frame on bad input; the output appears only
/// when complete (RawlogWriter commits atomically).
NormalPriorsResult runNormalPriors(const NormalPriorsOptions& options);

}  // namespace pslam::priors
