#include "pslam/priors/NormalsFromNetwork.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam::priors {

namespace {
constexpr const char* kCtx = "NormalsFromNetwork";

std::string resolve(const std::string& p, const std::string& baseDir) {
  if (p.empty() || baseDir.empty() || fs::path(p).is_absolute()) return p;
  return (fs::path(baseDir) / p).string();
}
}  // namespace

void NetworkNormalParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& c, const std::string& s,
                                             const std::string& baseDir) {
  model = resolve(c.read_string(s, "model", model), baseDir);
  config = resolve(c.read_string(s, "config", config), baseDir);
  framework = c.read_string(s, "framework", framework);
  inputWidth = c.read_int(s, "inputWidth", inputWidth);
  inputHeight = c.read_int(s, "inputHeight", inputHeight);
  scale = c.read_double(s, "scale", scale);
  mean[0] = c.read_double(s, "mean0", mean[0]);
  mean[1] = c.read_double(s, "mean1", mean[1]);
  mean[2] = c.read_double(s, "mean2", mean[2]);
  swapRB = c.read_bool(s, "swapRB", swapRB);
  normalsOutput = c.read_string(s, "normalsOutput", normalsOutput);
  axisMapping = c.read_string(s, "axisMapping", axisMapping);
  outputScale = c.read_double(s, "outputScale", outputScale);
  outputOffset = c.read_double(s, "outputOffset", outputOffset);
  planarChannel = c.read_int(s, "planarChannel", planarChannel);
  planarThreshold = c.read_double(s, "planarThreshold", planarThreshold);
  orientTowardsCamera = c.read_bool(s, "orientTowardsCamera", orientTowardsCamera);
  check();
}

void NetworkNormalParams::saveToConfigFile(mrpt::config::CConfigFileBase& c, const std::string& s) const {
  c.write(s, "model", model);
  c.write(s, "config", config);
  c.write(s, "framework", framework);
  c.write(s, "inputWidth", inputWidth);
  c.write(s, "inputHeight", inputHeight);
  c.write(s, "scale", scale);
  c.write(s, "mean0", mean[0]);
  c.write(s, "mean1", mean[1]);
  c.write(s, "mean2", mean[2]);
  c.write(s, "swapRB", swapRB);
  c.write(s, "normalsOutput", normalsOutput);
  c.write(s, "axisMapping", axisMapping);
  c.write(s, "outputScale", outputScale);
  c.write(s, "outputOffset", outputOffset);
  c.write(s, "planarChannel", planarChannel);
  c.write(s, "planarThreshold", planarThreshold);
  c.write(s, "orientTowardsCamera", orientTowardsCamera);
}

std::array<NetworkNormalParams::Axis, 3> NetworkNormalParams::parsedAxes() const {
  std::array<Axis, 3> axes{};
  std::stringstream ss(axisMapping);
  std::string tok;
  int k = 0;
  while (std::getline(ss, tok, ',')) {
    tok.erase(0, tok.find_first_not_of(" \t"));
    tok.erase(tok.find_last_not_of(" \t") + 1);
    require(k < 3, kCtx, "axisMapping '" + axisMapping + "' must have exactly three entries");
    double sign = 1.0;
    if (!tok.empty() && (tok[0] == '-' || tok[0] == '+')) {
      sign = tok[0] == '-' ? -1.0 : 1.0;
      tok = tok.substr(1);
    }
    require(tok == "x" || tok == "y" || tok == "z", kCtx,
            "axisMapping entry '" + tok + "' must be [+|-]x, y or z");
    axes[static_cast<std::size_t>(k++)] = {tok[0] - 'x', sign};
  }
  require(k == 3, kCtx, "axisMapping '" + axisMapping + "' must have exactly three entries");
  require(axes[0].channel != axes[1].channel && axes[0].channel != axes[2].channel &&
              axes[1].channel != axes[2].channel,
          kCtx, "axisMapping '" + axisMapping + "' must use each of x, y, z once");
  return axes;
}

void NetworkNormalParams::check() const {
  require(!model.empty(), kCtx, "model must be set");
  require(inputWidth > 0 && inputHeight > 0, kCtx, "inputWidth and inputHeight must be > 0");
  require(std::isfinite(scale) && scale != 0, kCtx, "scale must be finite and non-zero");
  for (double m : mean) require(std::isfinite(m), kCtx, "mean0..mean2 must be finite");
  require(std::isfinite(outputScale) && outputScale != 0, kCtx, "outputScale must be finite and non-zero");
  require(std::isfinite(outputOffset), kCtx, "outputOffset must be finite");
  require(planarChannel == -1 || planarChannel >= 3, kCtx, "planarChannel must be -1 or >= 3");
  require(std::isfinite(planarThreshold), kCtx, "planarThreshold must be finite");
  parsedAxes();
}

struct NetworkNormalEstimator::Impl {
  cv::dnn::Net net;
};

NetworkNormalEstimator::NetworkNormalEstimator(NetworkNormalParams params)
    : params_(std::move(params)), impl_(std::make_unique<Impl>()) {
  params_.check();
  require(fs::exists(params_.model), params_.model, "network model file not found");
  require(params_.config.empty() || fs::exists(params_.config), params_.config, "network config file not found");
  try {
    impl_->net = cv::dnn::readNet(params_.model, params_.config, params_.framework);
  } catch (const cv::Exception& e) {
    throw Error(params_.model + ": cannot load network: " + e.what());
  }
  require(!impl_->net.empty(), params_.model, "cannot load network (empty net)");
  impl_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  impl_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
}

NetworkNormalEstimator::~NetworkNormalEstimator() = default;

NormalMap NetworkNormalEstimator::compute(const cv::Mat& image, const PinholeIntrinsics* K) {
  require(!image.empty(), kCtx, "empty input image");
  require(image.type() == CV_8UC3 || image.type() == CV_8UC1, kCtx, "input image must be 8-bit grey or BGR");
  cv::Mat bgr = image;
  if (image.channels() == 1) cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  const NetworkNormalParams& P = params_;
  const cv::Mat blob = cv::dnn::blobFromImage(bgr, P.scale, cv::Size(P.inputWidth, P.inputHeight),
                                              cv::Scalar(P.mean[0], P.mean[1], P.mean[2]), P.swapRB, false);
  impl_->net.setInput(blob);
  cv::Mat out;
  try {
    out = P.normalsOutput.empty() ? impl_->net.forward() : impl_->net.forward(P.normalsOutput);
  } catch (const cv::Exception& e) {
    throw Error(P.model + ": forward pass failed: " + e.what());
  }
  require(out.dims == 4 && out.size[0] == 1, P.model, "normals output must be a 1xCxHxW blob");
  const int C = out.size[1], H = out.size[2], W = out.size[3];
  require(C >= 3, P.model, "normals output has " + std::to_string(C) + " channels, needs >= 3");
  require(P.planarChannel < C, P.model, "planarChannel " + std::to_string(P.planarChannel) + " but the output has " +
                                            std::to_string(C) + " channels");
  auto plane = [&](int c) { return cv::Mat(H, W, CV_32F, out.ptr<float>(0, c)); };
  const auto axes = P.parsedAxes();
  std::vector<cv::Mat> cam(3);
  for (int k = 0; k < 3; ++k) {
    cv::Mat resized;
    cv::resize(plane(axes[static_cast<std::size_t>(k)].channel), resized, image.size(), 0, 0, cv::INTER_LINEAR);
    resized.convertTo(cam[static_cast<std::size_t>(k)], CV_32F, axes[static_cast<std::size_t>(k)].sign * P.outputScale,
                      axes[static_cast<std::size_t>(k)].sign * P.outputOffset);
  }
  NormalMap nm;
  cv::merge(cam, nm.normals);
  nm.planarMask = cv::Mat(image.size(), CV_8UC1, cv::Scalar(255));
  if (P.planarChannel >= 0) {
    cv::Mat prob;
    cv::resize(plane(P.planarChannel), prob, image.size(), 0, 0, cv::INTER_LINEAR);
    nm.planarMask = prob >= P.planarThreshold;
  }
  for (int v = 0; v < image.rows; ++v) {
    auto* n = nm.normals.ptr<cv::Vec3f>(v);
    uchar* m = nm.planarMask.ptr<uchar>(v);
    for (int u = 0; u < image.cols; ++u) {
      const double norm = cv::norm(n[u]);
      if (!std::isfinite(norm) || norm < 1e-3) {
        n[u] = cv::Vec3f(0, 0, 0);
        m[u] = 0;
        continue;
      }
      n[u] /= static_cast<float>(norm);
      if (P.orientTowardsCamera && K) {
        const cv::Vec3f ray(float((u - K->cx) / K->fx), float((v - K->cy) / K->fy), 1.f);
        if (n[u].dot(ray) > 0) n[u] = -n[u];
      }
    }
  }
  return nm;
}

}  // namespace pslam::priors
