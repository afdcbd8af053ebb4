#pragma once
// Normals predicted from a single image by a network run through OpenCV DNN (thesis §4.2: the plane
// segmentation network of Yu et al. gives per-pixel normals plus a planar probability mask). Everything
// that differs between networks lives in the ini section: input size, normalization, which output holds
// the normals, the network's axis convention relative to our camera frame (x right, y down, z forward),
// and optionally which output channel is the planar mask.
#include <array>
#include <memory>
#include <string>

#include <mrpt/config/CConfigFileBase.h>
#include <opencv2/core.hpp>

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

  /// Relative model/config paths are resolved against `baseDir` (the ini's folder) when non-empty.
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                          const std::string& baseDir = "");
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  void check() const;

  /// Parsed axisMapping: for each camera axis the output channel and its sign.
  struct Axis {
    int channel;
    double sign;
  };
  std::array<Axis, 3> parsedAxes() const;
};

class NetworkNormalEstimator {
 public:
  /// Loads the network; throws pslam::Error naming the model file if it cannot be read.
  explicit NetworkNormalEstimator(NetworkNormalParams params);
  ~NetworkNormalEstimator();
  NetworkNormalEstimator(const NetworkNormalEstimator&) = delete;
  NetworkNormalEstimator& operator=(const NetworkNormalEstimator&) = delete;
  const NetworkNormalParams& params() const { return params_; }

  /// image: CV_8UC3 BGR or CV_8UC1. Returns a map of the image's size (output resized bilinearly and
  /// renormalized). K is needed only for orientTowardsCamera (ignored when null).
  NormalMap compute(const cv::Mat& image, const PinholeIntrinsics* K = nullptr);

 private:
  struct Impl;
  NetworkNormalParams params_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pslam::priors
