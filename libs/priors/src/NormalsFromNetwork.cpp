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
  params::load(*this, c, s);
  resolvePaths(baseDir);
}

void NetworkNormalParams::saveToConfigFile(mrpt::config::CConfigFileBase& c, const std::string& s) const {
  params::save(*this, c, s);
}

void NetworkNormalParams::check() const { params::check(*this, kSection); }

void NetworkNormalParams::resolvePaths(const std::string& baseDir) {
  model = resolve(model, baseDir);
  config = resolve(config, baseDir);
}

std::optional<std::string> NetworkNormalParams::axisMappingProblem(const std::string& mapping) {
  std::stringstream ss(mapping);
  std::string tok;
  int k = 0;
  bool used[3] = {false, false, false};
  while (std::getline(ss, tok, ',')) {
    tok.erase(0, tok.find_first_not_of(" \t"));
    tok.erase(tok.find_last_not_of(" \t") + 1);
    if (k == 3) return "must have exactly three entries";
    if (!tok.empty() && (tok[0] == '-' || tok[0] == '+')) tok = tok.substr(1);
    if (tok != "x" && tok != "y" && tok != "z") return "entry '" + tok + "' must be [+|-]x, y or z";
    if (used[tok[0] - 'x']) return "must use each of x, y, z once";
    used[tok[0] - 'x'] = true;
    ++k;
  }
  if (k != 3) return "must have exactly three entries";
  return std::nullopt;
}

std::array<NetworkNormalParams::Axis, 3> NetworkNormalParams::parsedAxes() const {
  if (auto why = axisMappingProblem(axisMapping))
    throw Error(std::string(kCtx) + ": axisMapping '" + axisMapping + "' " + *why);
  std::array<Axis, 3> axes{};
  std::stringstream ss(axisMapping);
  std::string tok;
  for (std::size_t k = 0; k < 3 && std::getline(ss, tok, ','); ++k) {
    tok.erase(0, tok.find_first_not_of(" \t"));
    const double sign = !tok.empty() && tok[0] == '-' ? -1.0 : 1.0;
    if (!tok.empty() && (tok[0] == '-' || tok[0] == '+')) tok = tok.substr(1);
    axes[k] = {tok[0] - 'x', sign};
  }
  return axes;
}

struct NetworkNormalEstimator::Impl {
  cv::dnn::Net net;
};

NetworkNormalEstimator::NetworkNormalEstimator(NetworkNormalParams params)
    : params_(std::move(params)), impl_(std::make_unique<Impl>()) {
  params_.check();
  if (params_.model.empty())
    throw params::ParamError(NetworkNormalParams::kSection, "model", "", "missing (the network's weights file)");
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
