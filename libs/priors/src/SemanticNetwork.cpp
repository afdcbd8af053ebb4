#include "pslam/priors/SemanticNetwork.h"

#include <cmath>
#include <mutex>
#include <sstream>

#include <mrpt/config/CConfigFileBase.h>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/dnn/layer.details.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/priors/SemanticImage.h"

namespace pslam::priors {
namespace {

std::filesystem::path resolve(const std::string& text, const std::filesystem::path& baseDir) {
  if (text.empty()) return {};
  std::filesystem::path p(text);
  return (p.is_relative() && !baseDir.empty()) ? (baseDir / p).lexically_normal() : p;
}

// caffe-enet's Upsample: max-unpooling by the index mask of the matching MAX pooling (scale 2). OpenCV's
// pooling writes, per channel, the flat index (y * W + x) of the maximum in its input plane; the unpooled
// output has twice the pooled size, so it must equal the pooling input (even sizes: input a multiple of 8).
class EnetUpsampleLayer final : public cv::dnn::Layer {
 public:
  explicit EnetUpsampleLayer(const cv::dnn::LayerParams& params) : cv::dnn::Layer(params) {}
  static cv::Ptr<cv::dnn::Layer> create(cv::dnn::LayerParams& params) {
    return cv::makePtr<EnetUpsampleLayer>(params);
  }
  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, const int, std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>&) const override {
    if (inputs.size() != 2 || inputs[0].size() != 4 || inputs[0] != inputs[1])
      throw Error("ENet Upsample layer '" + name + "': expects a 4-D feature map and a mask of the same shape");
    cv::dnn::MatShape out = inputs[0];
    out[2] *= 2;
    out[3] *= 2;
    outputs.assign(1, out);
    return false;
  }
  void forward(cv::InputArrayOfArrays inputsArr, cv::OutputArrayOfArrays outputsArr, cv::OutputArrayOfArrays) override {
    std::vector<cv::Mat> inputs, outputs;
    inputsArr.getMatVector(inputs);
    outputsArr.getMatVector(outputs);
    const cv::Mat& in = inputs[0];
    const cv::Mat& mask = inputs[1];
    cv::Mat& out = outputs[0];
    out.setTo(0);
    const int planes = in.size[0] * in.size[1];
    const std::size_t inPlane = std::size_t(in.size[2]) * in.size[3];
    const std::size_t outPlane = std::size_t(out.size[2]) * out.size[3];
    const float* src = in.ptr<float>();
    const float* idx = mask.ptr<float>();
    float* dst = out.ptr<float>();
    for (int p = 0; p < planes; ++p) {
      for (std::size_t i = 0; i < inPlane; ++i) {
        const auto target = static_cast<std::size_t>(idx[p * inPlane + i]);
        if (target < outPlane) dst[p * outPlane + target] = src[p * inPlane + i];
      }
    }
  }
};

}  // namespace

void SemanticNetworkParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                                               const std::filesystem::path& baseDir) {
  params::load(*this, cfg, section);
  model = resolve(model.string(), baseDir);
  config = resolve(config.string(), baseDir);
  if (classMap != "cityscapes") classMap = resolve(classMap, baseDir).string();
  check();
}

void SemanticNetworkParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  params::save(*this, cfg, section);
}

void SemanticNetworkParams::check() const {
  params::check(*this, kSection);
  if (model.empty()) throw params::ParamError(kSection, "model", "", "missing (the network's weights file)");
  if (!std::filesystem::is_regular_file(model))
    throw params::ParamError(kSection, "model", model.string(), "file not found");
  if (!config.empty() && !std::filesystem::is_regular_file(config))
    throw params::ParamError(kSection, "config", config.string(), "file not found");
}

SemanticNetworkParams SemanticNetworkParams::loadFromFile(const std::filesystem::path& iniPath) {
  SemanticNetworkParams p;
  params::loadConfigFile(iniPath.string(), {kSection}, [&](const mrpt::config::CConfigFileBase& cfg) {
    p.loadFromConfigFile(cfg, kSection, std::filesystem::absolute(iniPath).parent_path());
  });
  return p;
}

void registerEnetUpsampleLayer() {
  static std::once_flag once;
  std::call_once(once, [] { cv::dnn::LayerFactory::registerLayer("Upsample", EnetUpsampleLayer::create); });
}

struct SemanticNetwork::Impl {
  cv::dnn::Net net;
};

SemanticNetwork::SemanticNetwork(SemanticNetworkParams params) : impl_(std::make_unique<Impl>()), params_(std::move(params)) {
  params_.check();
  classMap_ = params_.classMap == "cityscapes" ? SemanticClassMap::cityscapes()
                                               : SemanticClassMap::loadFromFile(params_.classMap);
  registerEnetUpsampleLayer();
  // Each file is checked on its own, so the message names the one at fault: an empty file (OpenCV would load an
  // empty caffemodel and fail only at the first frame, and say `model_proto.has_graph()` for an empty ONNX file),
  // then the description alone (a cut prototxt was blamed on the weights). OpenCV's own log lines are kept quiet
  // meanwhile: the exception carries the reason.
  for (const auto& [file, what] : {std::pair{params_.model, "network model"}, std::pair{params_.config, "network description"}}) {
    std::error_code ec;
    if (!file.empty() && std::filesystem::file_size(file, ec) == 0 && !ec)
      throw Error(file.string() + ": empty file (0 bytes): not a " + what + " (framework " +
                  (params_.framework.empty() ? std::string("from the file extensions") : params_.framework) + ")");
  }
  const auto logLevel = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  struct RestoreLogLevel {
    cv::utils::logging::LogLevel level;
    ~RestoreLogLevel() { cv::utils::logging::setLogLevel(level); }
  } restore{logLevel};
  const bool caffe = params_.framework == "caffe" || (params_.framework.empty() && params_.config.extension() == ".prototxt");
  if (caffe && !params_.config.empty()) {
    try {
      cv::dnn::readNetFromCaffe(params_.config.string());
    } catch (const cv::Exception& e) {
      throw Error(params_.config.string() + ": OpenCV DNN cannot read the network description: " +
                  oneLineMessage(e.msg));
    }
  }
  try {
    impl_->net = cv::dnn::readNet(params_.model.string(), params_.config.string(), params_.framework);
  } catch (const cv::Exception& e) {
    throw Error(params_.model.string() + ": OpenCV DNN cannot load the network: " + oneLineMessage(e.msg));
  }
  if (impl_->net.empty()) throw Error(params_.model.string() + ": OpenCV DNN loaded an empty network");
  impl_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  impl_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
}

SemanticNetwork::~SemanticNetwork() = default;

cv::Mat SemanticNetwork::scores(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw Error("SemanticNetwork: image must be a non-empty 8-bit grey or BGR image");
  cv::Mat bgr;
  if (image.channels() == 1)
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);  // grey cameras (KITTI): replicate to 3 channels
  else
    bgr = image;
  const cv::Mat blob = cv::dnn::blobFromImage(bgr, params_.scale, cv::Size(params_.inputWidth, params_.inputHeight),
                                              cv::Scalar(params_.mean[0], params_.mean[1], params_.mean[2]),
                                              params_.swapRB, /*crop=*/false, CV_32F);
  cv::Mat out;
  try {
    impl_->net.setInput(blob);
    out = params_.outputLayer.empty() ? impl_->net.forward() : impl_->net.forward(params_.outputLayer);
  } catch (const cv::Exception& e) {
    throw Error(params_.model.string() + ": forward pass failed: " + e.msg);
  }
  return out.clone();  // the network reuses its output buffers
}

cv::Mat SemanticNetwork::semanticFromScores(const cv::Mat& s, cv::Size size) const {
  return encodeSemantic(groupProbabilitiesFromScores(s, classMap_, params_.softmax), size);
}

cv::Mat SemanticNetwork::segment(const cv::Mat& image) { return semanticFromScores(scores(image), image.size()); }

}  // namespace pslam::priors
