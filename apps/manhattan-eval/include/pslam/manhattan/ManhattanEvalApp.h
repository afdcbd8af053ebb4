#pragma once
// The `manhattan-eval` tool: runs the Manhattan-frame tracker over a rawlog and
// reports, against ground truth, the per-frame rotation error relative to the first frame, the share of
// frames the tracker accepts, per-stage timings, and optionally the normal-accuracy metrics of §4.5.3
// between two normal sources.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/priors/NormalSource.h"

namespace pslam::manhattan {

struct ManhattanEvalOptions {
  std::filesystem::path rawlog;       ///< input rawlog (doc/architecture.md, "Data contracts")
  std::filesystem::path groundTruth;  ///< TUM file; default `<stem>_groundtruth.txt` beside the rawlog
  std::string normals = "rawlog";     ///< normals for the tracker: rawlog | depth | network
  std::string referenceNormals;       ///< optional second source; metrics of `normals` against it
  std::filesystem::path config;       ///< ini: [ManhattanTracker], [NormalsFromDepth], [NormalsFromNetwork]
  std::filesystem::path referenceConfig;  ///< ini of the reference source; empty = `config`
  /// Pixels of the normal accuracy: "all" where both sources have a normal, or "reference-planar" where both
  /// have one and the reference's planar mask is set (depth normals: only the segmented planes).
  std::string accuracyPixels = "all";
  std::size_t referenceFrame = 0;     ///< errors relative to the first evaluated frame with index >= this
  int normalStride = 2;               ///< pixel stride when collecting normals for the tracker
  double maxGroundTruthDt = 0.02;     ///< [s] ground-truth association window
  std::filesystem::path outputJson;   ///< optional, written atomically
  std::filesystem::path outputText;   ///< optional, written atomically (the text is also returned)
  std::filesystem::path outputPlot;   ///< optional PNG: rotation error and GT rotation per frame
  bool progress = true;
};

inline constexpr const char* kTrackerSection = "ManhattanTracker";

/// The sections of a manhattan-eval ini (config/manhattan/*.ini): the tracker's and the normal sources'.
struct ManhattanEvalConfig {
  ManhattanParams tracker;
  priors::NormalSourceParams normals;
  template <class V>
  void visitSections(V& v) {
    v.section(kTrackerSection, tracker);
    normals.visitSections(v);
  }
  /// Strict (pslam/core/Params.h): unknown sections and keys, values of the wrong type or range are errors
  /// naming the file, section and key. Empty path: the defaults.
  static ManhattanEvalConfig loadFromFile(const std::filesystem::path& path);
};

struct ManhattanEvalResult {
  nlohmann::json report;  ///< configuration, per-frame records, summary
  std::string text;       ///< human-readable summary table
};

/// Throws pslam::Error naming the file/frame on bad input (and the option: --normal-stride, --max-gt-dt). The
/// outputs (JSON, text, plot) are checked before the run (none may be an input or replace a folder) and either
/// all are written or none.
ManhattanEvalResult runManhattanEval(const ManhattanEvalOptions& options);


}  // namespace pslam::manhattan
