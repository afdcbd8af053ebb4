#pragma once
// The slam-synth application: renders a scenario and writes it as a rawlog following the contract
// (doc/architecture.md, "Data contracts") with ground truth beside it.
//
// Outputs in <outDir>:
//   <name>.rawlog + <name>_Images/     CAMERA (grey), DEPTH (u16, scenario depth unit), SEMANTIC (one-hot,
//                                      Table 3.1), NORMALS (camera frame, encodeNormal)
//   <name>_groundtruth.txt             TUM, camera-to-world, stamps equal to the CAMERA stamps
//   <name>_Labels/LABEL_%06d.png       8-bit Cityscapes trainIds per frame (255 = unlabeled)
//   <name>_synth.json                  effective options, intrinsics, depth unit, summary
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/core/StageTimer.h"
#include "pslam/synth/Renderer.h"
#include "pslam/synth/Scenarios.h"

namespace pslam::synth {

/// Why `pathVariant` is not a path variant of `scenario` (nullopt: it is, or the scenario is unknown, which the
/// scenario key reports).
std::optional<std::string> pathVariantProblem(const std::string& scenario, int pathVariant);

struct SynthOptions {
  std::string scenario = "room";
  int frames = 0;          ///< 0 = the scenario's default length
  int width = 640, height = 480;
  double fx = 0, fy = 0;   ///< 0 = scenario default focal length scaled to the width
  double cx = -1, cy = -1; ///< negative = image centre ((w-1)/2, (h-1)/2)
  std::uint32_t seed = 1;
  int pathVariant = 0;     ///< another camera path through the same scene (Scenarios.h); 0 = the preset's
  bool textured = true;
  double noiseSigma = 0.0; ///< std of additive Gaussian image noise in grey levels
  bool exposure = false;   ///< per-frame affine brightness change a*I+b (smooth in time, from the seed)
  int supersampling = 2;
  std::string antiAliasing = "adaptive";  ///< silhouettes | adaptive | full (see RenderOptions)
  double aaContrast = 20.0;               ///< adaptive mode: grey-level contrast that triggers supersampling
  std::filesystem::path outDir;
  std::string name;        ///< empty = scenario name
  std::filesystem::path preview;  ///< optional PNG: image | depth | normals | labels of one frame
  int previewFrame = -1;          ///< frame shown in the preview (-1 = the middle frame)
  int threads = 1;                ///< renderer threads (output identical for any count)
  bool progress = true;

  /// The ini keys of [synth] (pslam/core/Params.h: strict, unknown keys are errors); the command-line options
  /// of slam-synth set the same fields and are checked by the same rules (params::cliCheckKey).
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, scenario, oneOf(scenarioNames()), "scenario preset");
    PSLAM_FIELD(v, frames, inClosed(0, 1000000), "number of frames (0 = the scenario's default)");
    PSLAM_FIELD(v, width, inClosed(8, 8192), "image width");
    PSLAM_FIELD(v, height, inClosed(8, 8192), "image height");
    PSLAM_FIELD(v, fx, atLeast(0), "focal length x in pixels (0 = scenario default scaled to the width)");
    PSLAM_FIELD(v, fy, atLeast(0), "focal length y in pixels (0 = fx)");
    PSLAM_FIELD(v, cx, finite(), "principal point x (negative = (width-1)/2)");
    PSLAM_FIELD(v, cy, finite(), "principal point y (negative = (height-1)/2)");
    PSLAM_FIELD(v, seed, anyValue, "seed of textures, placements, traffic, jitter, noise");
    PSLAM_KEY(v, "path_variant", pathVariant,
              custom([this](int n) -> std::optional<std::string> { return pathVariantProblem(scenario, n); },
                     "a path variant of the scenario (room, corridor: 0, 1, 2; the others: 0)"),
              "camera path through the same scene (0 = the preset's; which others exist depends on the scenario)");
    PSLAM_KEY(v, "texture", textured, anyValue, "procedural textures (false: white surfaces, shading only)");
    PSLAM_KEY(v, "noise_sigma", noiseSigma, inClosed(0, 100), "Gaussian image noise std in grey levels");
    PSLAM_FIELD(v, exposure, anyValue, "per-frame affine brightness change");
    PSLAM_FIELD(v, supersampling, inClosed(1, 8), "N x N samples per pixel for anti-aliasing");
    PSLAM_KEY(v, "anti_aliasing", antiAliasing, oneOf({"silhouettes", "adaptive", "full"}), "anti-aliasing mode");
    PSLAM_KEY(v, "aa_contrast", aaContrast, greaterThan(0), "adaptive anti-aliasing: contrast (grey levels)");
    PSLAM_KEY(v, "out_dir", outDir, anyValue, "output folder (required, here or on the command line)");
    PSLAM_FIELD(v, name,
                satisfies([](const std::string& n) { return n.find_first_of("/\\") == std::string::npos && n != "." && n != ".."; },
                          "must be a plain file stem"),
                "file stem of the outputs (empty = the scenario name)");
    PSLAM_KEY(v, "preview_frame", previewFrame, atLeast(-1), "frame of --preview (-1 = the middle frame)");
    PSLAM_FIELD(v, threads, inClosed(1, 64), "renderer threads (the output is identical for any count)");
  }
  /// loadFromConfigFile / saveToConfigFile (section default synth); check() throws params::ParamError naming
  /// the key at fault (out_dir must be set).
  PSLAM_PARAMS("synth")
  std::string effectiveName() const { return name.empty() ? scenario : name; }
  PinholeCamera camera() const;
  AntiAliasing antiAliasingMode() const;
  nlohmann::json toJson() const;
};

/// Affine exposure change of frame time t (seconds): gain a in about [0.75, 1.25] and offset b in about
/// [-15, 15] grey levels, drifting smoothly (auto-exposure-like) from the seed.
struct Exposure {
  double gain = 1.0, offset = 0.0;
  static Exposure at(double t, std::uint32_t seed);
};

/// Grey CAMERA image from rendered radiance: a*I+b, plus Gaussian noise (sigma grey levels, seeded), rounded
/// and saturated to 8 bits.
cv::Mat applySensor(const cv::Mat& radiance, const Exposure& exposure, double noiseSigma, std::uint64_t noiseSeed);

/// Colour panel image | depth | normals | labels (each scaled to `panelWidth`) for documentation.
cv::Mat makePreviewPanel(const cv::Mat& grey, const cv::Mat& depthMetres, const cv::Mat& normals,
                         const cv::Mat& trainIds, int panelWidth = 320);
/// Cityscapes colour (BGR) of a trainId.
cv::Vec3b cityscapesColour(std::uint8_t trainId);

struct SynthSummary {
  std::size_t frames = 0;
  double renderSeconds = 0, totalSeconds = 0;        ///< wall clock
  double renderCpuSeconds = 0, totalCpuSeconds = 0;  ///< process CPU time (the machine may be shared)
  double meanDynamicFraction = 0, meanSkyFraction = 0, meanValidDepthFraction = 0, meanFastCorners = 0;
  std::filesystem::path rawlog, groundTruth, labelsDir, info;
  StageTimings timings;
  nlohmann::json toJson() const;
  std::string toText() const;
};

class SynthApp {
 public:
  /// `inputs`: files the run reads (the config file), which no output may replace.
  explicit SynthApp(SynthOptions options, std::vector<std::filesystem::path> inputs = {});
  /// Renders and writes the outputs. They are all prepared before rendering (none may be an input or replace a
  /// folder; an impossible path fails at once) and committed together at the end: all are written or none.
  SynthSummary run();

 private:
  SynthOptions options_;
  std::vector<std::filesystem::path> inputs_;
};

}  // namespace pslam::synth
