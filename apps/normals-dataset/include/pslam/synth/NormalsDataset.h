#pragma once
// The normals-dataset tool: training and held-out data for the monocular normal network (doc/normals_network.md,
// thesis §4.2). Short randomized views of the indoor scenarios are rendered by libs/synth and written as
// image + normal + planar-mask triples (PNG), split by scene seed.
//
// Domain randomization, per view (all derived from scenario, seed and view index, so a dataset is reproducible
// bit for bit): time along the scenario's camera path, a small extra camera rotation and, for a share of the
// views, a downward look at floor and furniture (hand-held RGB-D sequences such as TUM fr3_cabinet), focal length, direction
// and strength of the key and fill lights and the ambient term, exposure gain and offset, Gaussian blur and
// image noise; per sequence (scenario + seed): textured or white surfaces.
//
// Outputs in <outDir>:
//   train/, test/                <scenario>_s<seed>_<view>_image.png   8-bit grey CAMERA image
//                                <scenario>_s<seed>_<view>_normal.png  8-bit, the NORMALS channel's encoding
//                                                                      (doc/architecture.md, "Data contracts"): OpenCV channels 0,1,2 =
//                                                                      camera x,y,z as round((n+1)/2*255)
//                                <scenario>_s<seed>_<view>_mask.png    8-bit, 255 = planar pixel with a normal
//                                manifest.csv                          one line per view: files, camera, draws
//   dataset.json                 effective options and counts
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/synth/Renderer.h"

namespace pslam::synth {

/// Why `list` is not a comma-separated list of known scenario names (nullopt: it is).
std::optional<std::string> scenarioListProblem(const std::string& list);
/// "a,b , c" -> {"a", "b", "c"}.
std::vector<std::string> splitScenarioList(const std::string& list);

struct NormalsDatasetOptions {
  std::string scenarios = "room,corridor,lowtexture";  ///< comma-separated scenario presets
  std::uint32_t firstTrainSeed = 1;
  int trainSeeds = 24;
  std::uint32_t firstTestSeed = 1001;  ///< held-out seeds: other scenes, textures and placements
  int testSeeds = 3;
  int views = 40;                      ///< views per sequence (scenario + seed)
  int width = 128, height = 96;
  double focalMin = 0.8, focalMax = 1.25;  ///< focal length factor on the scenario's default
  double untexturedShare = 0.25;           ///< share of sequences with white surfaces
  double maxTiltDeg = 10.0;                ///< extra camera rotation: roll, pitch and yaw uniform in +-this
  double lookDownShare = 0.35;             ///< share of views that also look down (floor and furniture from above)
  double lookDownMinDeg = 15.0, lookDownMaxDeg = 50.0;  ///< their extra downward pitch, uniform in [min, max]
  bool randomLighting = true;              ///< key/fill directions and strengths, ambient
  double maxExposureGain = 0.3;            ///< gain uniform in 1 +- this
  double maxExposureOffset = 20.0;         ///< offset uniform in +- this (grey levels)
  double maxNoise = 4.0;                   ///< noise std uniform in [0, this] grey levels
  double blurShare = 0.5;                  ///< share of views with Gaussian blur
  double maxBlurSigma = 1.0;               ///< blur sigma uniform in [0.3, this] pixels
  int supersampling = 2;
  int threads = 1;
  std::filesystem::path outDir;
  bool progress = true;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, scenarios, custom([](const std::string& s) { return scenarioListProblem(s); },
                                     "comma-separated scenario names"),
                "scenario presets, comma-separated");
    PSLAM_KEY(v, "first_train_seed", firstTrainSeed, anyValue, "first seed of the training sequences");
    PSLAM_KEY(v, "train_seeds", trainSeeds, inClosed(0, 100000), "number of training seeds per scenario");
    PSLAM_KEY(v, "first_test_seed", firstTestSeed, anyValue, "first seed of the held-out sequences");
    PSLAM_KEY(v, "test_seeds", testSeeds, inClosed(0, 100000), "number of held-out seeds per scenario");
    PSLAM_FIELD(v, views, inClosed(1, 100000), "views per sequence");
    PSLAM_FIELD(v, width, inClosed(8, 4096), "image width");
    PSLAM_FIELD(v, height, inClosed(8, 4096), "image height");
    PSLAM_KEY(v, "focal_min", focalMin, inClosed(0.1, 10), "smallest focal length factor");
    PSLAM_KEY(v, "focal_max", focalMax, inClosed(0.1, 10), "largest focal length factor (>= focal_min)");
    PSLAM_KEY(v, "untextured_share", untexturedShare, inClosed(0, 1), "share of sequences with white surfaces");
    PSLAM_KEY(v, "max_tilt_deg", maxTiltDeg, inClosed(0, 45), "extra camera roll/pitch/yaw, uniform in +-this");
    PSLAM_KEY(v, "look_down_share", lookDownShare, inClosed(0, 1), "share of views that also look down");
    PSLAM_KEY(v, "look_down_min_deg", lookDownMinDeg, inClosed(0, 80), "smallest extra downward pitch of those");
    PSLAM_KEY(v, "look_down_max_deg", lookDownMaxDeg, inClosed(0, 80), "largest extra downward pitch (>= min)");
    PSLAM_KEY(v, "random_lighting", randomLighting, anyValue, "randomize light directions and strengths");
    PSLAM_KEY(v, "max_exposure_gain", maxExposureGain, inClosed(0, 0.9), "exposure gain uniform in 1 +- this");
    PSLAM_KEY(v, "max_exposure_offset", maxExposureOffset, inClosed(0, 100), "exposure offset uniform in +- this");
    PSLAM_KEY(v, "max_noise", maxNoise, inClosed(0, 50), "noise std uniform in [0, this] grey levels");
    PSLAM_KEY(v, "blur_share", blurShare, inClosed(0, 1), "share of blurred views");
    PSLAM_KEY(v, "max_blur_sigma", maxBlurSigma, inClosed(0.3, 10), "blur sigma uniform in [0.3, this] pixels");
    PSLAM_FIELD(v, supersampling, inClosed(1, 8), "N x N samples per anti-aliased pixel");
    PSLAM_FIELD(v, threads, inClosed(1, 64), "renderer threads (the output is identical for any count)");
    PSLAM_KEY(v, "out_dir", outDir, anyValue, "output folder (required)");
  }
  /// check() also requires out_dir, focal_min <= focal_max and look_down_min_deg <= look_down_max_deg.
  PSLAM_PARAMS("normals_dataset")
  nlohmann::json toJson() const;
};

/// The random draws of one view.
struct ViewDraws {
  double time = 0;                     ///< seconds along the scenario's camera path
  double rollDeg = 0, pitchDeg = 0, yawDeg = 0;  ///< about camera x; the look-down pitch is included (negative = down)
  double focalFactor = 1;
  bool textured = true;
  double keyAzimuthDeg = 0, keyElevationDeg = 0, fillAzimuthDeg = 0, fillElevationDeg = 0;
  double ambient = 0, key = 0, fill = 0;
  double gain = 1, offset = 0, noise = 0, blurSigma = 0;
};

/// One rendered training view.
struct NormalsSample {
  std::string scenario;
  std::uint32_t seed = 0;
  int view = 0;
  PinholeCamera camera;
  ViewDraws draws;
  cv::Mat image;    ///< CV_8UC1
  cv::Mat normals;  ///< CV_32FC3 camera-frame unit normals, (0,0,0) = none
  cv::Mat mask;     ///< CV_8UC1, 255 = planar pixel with a ground-truth normal
};

struct NormalsDatasetSummary {
  std::size_t trainViews = 0, testViews = 0;
  double seconds = 0;
  double meanMaskShare = 0;
  nlohmann::json toJson() const;
};

class NormalsDataset {
 public:
  /// Throws params::ParamError naming the key of a bad option.
  explicit NormalsDataset(NormalsDatasetOptions options);
  const NormalsDatasetOptions& options() const { return options_; }
  /// Renders views [firstView, firstView + count) of one sequence (the same as run() writes).
  std::vector<NormalsSample> renderSequence(const std::string& scenario, std::uint32_t seed, int firstView,
                                            int count) const;
  /// Renders every sequence and writes the outputs; all appear together at the end or none.
  NormalsDatasetSummary run() const;

 private:
  NormalsDatasetOptions options_;
};

}  // namespace pslam::synth
