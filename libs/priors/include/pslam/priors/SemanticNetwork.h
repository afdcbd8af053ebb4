#pragma once
// A semantic segmentation network run through OpenCV DNN (Caffe, ONNX, TensorFlow, Torch: cv::dnn::readNet),
// with its pre-processing in an ini file, producing the SEMANTIC channel: softmax over the network's classes,
// then the class probabilities summed into the Table 3.1 groups of its class map.
//
//   [SemanticNetwork]
//   model       = ../../../shared/data/models/enet_cityscapes_caffe/cityscapes_weights.caffemodel
//   config      = ../../../shared/data/models/enet_cityscapes_caffe/enet_opencv46_DERIVED.prototxt
//   framework   =                ; optional (caffe, onnx, tensorflow, torch); empty = from the file extensions
//   inputWidth  = 1024
//   inputHeight = 512
//   scale       = 1.0            ; blob = scale * (image - mean)
//   mean        = 0 0 0          ; per channel, in the channel order after swapRB
//   swapRB      = false          ; images are BGR; true feeds RGB
//   softmax     = true           ; false when the network already outputs probabilities
//   outputLayer =                ; optional; empty = the network's default output
//   classMap    = cityscapes     ; "cityscapes" (built in) or a class-map ini path
// Relative paths are relative to the folder of the ini file.
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/priors/DnnFramework.h"
#include "pslam/priors/SemanticClassMap.h"

namespace pslam::priors {

struct SemanticNetworkParams {
  std::filesystem::path model;   ///< weights file
  std::filesystem::path config;  ///< architecture file (may be empty for ONNX)
  std::string framework;
  int inputWidth = 1024;
  int inputHeight = 512;
  double scale = 1.0;
  std::array<double, 3> mean{0, 0, 0};
  bool swapRB = false;
  bool softmax = true;
  std::string outputLayer;
  std::string classMap = "cityscapes";

  /// The keys of the section above (pslam/core/Params.h: strict, unknown keys are errors).
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, model, anyValue, "weights file (required; relative = to the ini's folder)");
    PSLAM_FIELD(v, config, anyValue, "architecture file (optional for ONNX)");
    PSLAM_FIELD(v, framework, dnnFrameworkRule(), "cv::dnn::readNet framework; empty = from the file extensions");
    PSLAM_FIELD(v, inputWidth, inClosed(1, 16384), "network input width");
    PSLAM_FIELD(v, inputHeight, inClosed(1, 16384), "network input height");
    PSLAM_FIELD(v, scale, greaterThan(0), "blob = scale * (image - mean)");
    PSLAM_FIELD(v, mean, custom([](const std::array<double, 3>& m) -> std::optional<std::string> {
                  for (double x : m)
                    if (!std::isfinite(x)) return "must be finite";
                  return std::nullopt;
                }, "three finite numbers"),
                "per channel, in the channel order after swapRB");
    PSLAM_FIELD(v, swapRB, anyValue, "images are BGR; true feeds RGB");
    PSLAM_FIELD(v, softmax, anyValue, "false when the network already outputs probabilities");
    PSLAM_FIELD(v, outputLayer, anyValue, "empty = the network's default output");
    PSLAM_FIELD(v, classMap, nonEmpty, "\"cityscapes\" (built in) or a class-map ini path");
  }
  static constexpr const char* kSection = "SemanticNetwork";

  /// Strict (unknown keys, values of the wrong type or range are errors naming section and key); relative
  /// paths are resolved against `baseDir`; then check().
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section = kSection,
                          const std::filesystem::path& baseDir = {});
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section = kSection) const;
  /// Throws params::ParamError naming the key (rules above; model set and found, config found when set).
  void check() const;
  /// Reads section [SemanticNetwork] of an ini file that holds only this section; throws pslam::Error naming
  /// the file, section and key.
  static SemanticNetworkParams loadFromFile(const std::filesystem::path& iniPath);
};

/// Registers the "Upsample" layer of caffe-enet (max-unpooling by the MAX-pool index mask) with OpenCV DNN,
/// which OpenCV 4.6 lacks (see models/enet_cityscapes_caffe/SOURCE.txt). Idempotent and thread-safe.
void registerEnetUpsampleLayer();

class SemanticNetwork {
 public:
  /// Loads the network and its class map. Throws pslam::Error naming the file that failed.
  explicit SemanticNetwork(SemanticNetworkParams params);
  ~SemanticNetwork();
  SemanticNetwork(const SemanticNetwork&) = delete;
  SemanticNetwork& operator=(const SemanticNetwork&) = delete;

  /// Raw network output for an 8-bit grey (replicated to 3 channels) or BGR image: 1 x C x h x w scores.
  cv::Mat scores(const cv::Mat& image);
  /// SEMANTIC channel (CV_8UC3) at the size of `image`.
  cv::Mat segment(const cv::Mat& image);
  /// SEMANTIC channel from scores already computed, at `size`.
  cv::Mat semanticFromScores(const cv::Mat& scores, cv::Size size) const;

  const SemanticClassMap& classMap() const { return classMap_; }
  const SemanticNetworkParams& params() const { return params_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  SemanticNetworkParams params_;
  SemanticClassMap classMap_;
};

}  // namespace pslam::priors
