#pragma once
// The `semantic-priors` tool: reads a rawlog, adds the SEMANTIC channel to every frame from ground-truth
// labels or a segmentation network, and writes a new rawlog (images re-written, atomically), optionally with
// colour overlays for inspection.
#include <array>
#include <cstddef>
#include <filesystem>
#include <string>

#include "pslam/core/StageTimer.h"
#include "pslam/priors/SemanticClassMap.h"

namespace pslam::priors {

struct SemanticPriorsOptions {
  std::filesystem::path input;              ///< existing rawlog
  std::filesystem::path output;             ///< new rawlog (must differ from input)
  std::filesystem::path labelsDir;          ///< source (a): folder of label images ("auto" = labelsDirFor(input)) ...
  std::string labelPattern = "LABEL_%06d.png";
  std::filesystem::path classMapFile;       ///< ... mapped through this ini (empty = Cityscapes, Table 3.1)
  std::filesystem::path networkConfig;      ///< source (b): [SemanticNetwork] ini
  std::filesystem::path overlayDir;         ///< optional: write overlay PNGs here
  std::size_t overlayEvery = 1;             ///< every n-th frame gets an overlay
  std::size_t maxFrames = 0;                ///< 0 = all
  bool progress = true;

  /// Exactly one source, distinct input/output, overlayEvery >= 1; throws pslam::Error naming the option.
  void check() const;
};

struct SemanticPriorsReport {
  std::size_t frames = 0;
  std::size_t overlays = 0;
  std::array<double, kNumSemanticGroups> meanProbability{};  ///< soft class histogram over all frames
  StageTimings timings;  ///< "read", "semantic", "write" per frame (ms)
  std::string source;
};

/// `<dir>/<stem>_Labels` beside a rawlog, where the synthetic generator writes its label images.
std::filesystem::path labelsDirFor(const std::filesystem::path& rawlogPath);

class SemanticPriorsApp {
 public:
  explicit SemanticPriorsApp(SemanticPriorsOptions options);
  SemanticPriorsReport run();

 private:
  SemanticPriorsOptions options_;
};

}  // namespace pslam::priors
