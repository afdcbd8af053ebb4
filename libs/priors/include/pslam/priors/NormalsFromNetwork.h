#pragma once
// Normals predicted from a single image by a network run through OpenCV DNN (thesis §4.2: the plane
// segmentation network of Yu et al. gives per-pixel normals plus a planar probability mask). Everything
// that differs between networks lives in the ini section: input size, normalization, which output holds
// the normals, the network's axis convention relative to our camera frame (x right, y down, z forward),
// and optionally which output channel is the planar mask.
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include <mrpt/config/CConfigFileBase.h>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/priors/DnnFramework.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/priors/NormalsFromDepth.h"

namespace pslam::priors {

struct NetworkNormalParams {
  std::string model;      ///< weights file (.onnx, .caffemodel, .weights, .pb, ...); relative = to the ini
  std::string config;     ///< optional network description (.prototxt, .cfg, ...); relative = to the ini
  std::string framework;  ///< optional, as for cv::dnn::readNet
  int inputWidth = 320;
  int inputHeight = 256;
  double scale = 1.0 / 255.0;                   ///< blob = (pixel - mean) * scale
  std::array<double, 3> mean{0.0, 0.0, 0.0};    ///< per channel, in the order after swapRB
  bool swapRB = true;                           ///< feed RGB (our images are BGR)
  std::string normalsOutput;                    ///< output layer name; empty = the network's default output
  /// n_camera[k] = sign_k * (outputScale * out[channel_k] + outputOffset); written as e.g. "x,-y,-z" meaning
  /// camera x = +out0, camera y = -out1, camera z = -out2 (a network with y up and z towards the viewer).
  std::string axisMapping = "x,y,z";
  double outputScale = 1.0;
  double outputOffset = 0.0;
  int planarChannel = -1;        ///< channel of the normals output with the planar probability; -1 = none
  double planarThreshold = 0.5;  ///< pixels with probability >= threshold are planar
  bool orientTowardsCamera = true;  ///< flip normals that face away from the viewing ray

  /// The keys of [NormalsFromNetwork] (pslam/core/Params.h: strict, unknown keys are errors). An absent
  /// section leaves model empty: the network source then says that it needs one.
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, model, anyValue, "weights file (required by the network source; relative = to the ini)");
    PSLAM_FIELD(v, config, anyValue, "optional network description; relative = to the ini");
    PSLAM_FIELD(v, framework, dnnFrameworkRule(), "cv::dnn::readNet framework; empty = from the file extensions");
    PSLAM_FIELD(v, inputWidth, inClosed(1, 16384), "network input width");
    PSLAM_FIELD(v, inputHeight, inClosed(1, 16384), "network input height");
    PSLAM_FIELD(v, scale, satisfies([](double x) { return std::isfinite(x) && x != 0; }, "must be finite and non-zero"),
                "blob = (pixel - mean) * scale");
    PSLAM_KEY(v, "mean0", mean[0], finite(), "mean of channel 0 (after swapRB)");
    PSLAM_KEY(v, "mean1", mean[1], finite(), "mean of channel 1");
    PSLAM_KEY(v, "mean2", mean[2], finite(), "mean of channel 2");
    PSLAM_FIELD(v, swapRB, anyValue, "feed RGB (our images are BGR)");
    PSLAM_FIELD(v, normalsOutput, anyValue, "output layer name; empty = the network's default output");
    PSLAM_FIELD(v, axisMapping, custom([](const std::string& m) { return axisMappingProblem(m); },
                                       "three of [+|-]x, y, z, each axis once"),
                "camera axis k = sign_k * output channel_k");
    PSLAM_FIELD(v, outputScale,
                satisfies([](double x) { return std::isfinite(x) && x != 0; }, "must be finite and non-zero"),
                "n = sign * (outputScale * out + outputOffset)");
    PSLAM_FIELD(v, outputOffset, finite(), "see outputScale");
    PSLAM_FIELD(v, planarChannel, satisfies([](int c) { return c == -1 || c >= 3; }, "must be -1 or >= 3"),
                "channel with the planar probability (-1 = every pixel is planar)");
    PSLAM_FIELD(v, planarThreshold, finite(), "pixels with probability >= this are planar");
    PSLAM_FIELD(v, orientTowardsCamera, anyValue, "flip normals that face away from the viewing ray");
  }
  static constexpr const char* kSection = "NormalsFromNetwork";

  /// Strict; relative model/config paths are resolved against `baseDir` (the ini's folder) when non-empty.
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section = kSection,
                          const std::string& baseDir = "");
  /// Throws params::ParamError naming the key.
  void check() const;
  /// Relative model/config paths against `baseDir` (nothing when empty).
  void resolvePaths(const std::string& baseDir);

  /// Parsed axisMapping: for each camera axis the output channel and its sign.
  struct Axis {
    int channel;
    double sign;
  };
  std::array<Axis, 3> parsedAxes() const;
  /// Why `mapping` is not a valid axisMapping (nullopt = valid).
  static std::optional<std::string> axisMappingProblem(const std::string& mapping);
};

class NetworkNormalEstimator {
 public:
  /// Loads the network and runs it once on a blank input of the configured size; throws pslam::Error naming
  /// the model file if it cannot be read, does not run at that size, or its output is not 1xCxHxW with C >= 3
  /// (and C > planarChannel).
  explicit NetworkNormalEstimator(NetworkNormalParams params);
  ~NetworkNormalEstimator();
  NetworkNormalEstimator(const NetworkNormalEstimator&) = delete;
  NetworkNormalEstimator& operator=(const NetworkNormalEstimator&) = delete;
  const NetworkNormalParams& params() const { return params_; }

  /// image: CV_8UC3 BGR or CV_8UC1. A larger image is shrunk to the input size by area averaging. Returns a map
  /// of the image's size (output resized bilinearly and renormalized). K is needed only for
  /// orientTowardsCamera (ignored when null).
  NormalMap compute(const cv::Mat& image, const PinholeIntrinsics* K = nullptr);

 private:
  void checkOutputLayout(const cv::Mat& out) const;
  struct Impl;
  NetworkNormalParams params_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pslam::priors
