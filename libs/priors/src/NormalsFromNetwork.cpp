#include "pslam/priors/NormalsFromNetwork.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <vector>

#include <opencv2/core/utils/logger.hpp>
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
  {
    const auto logLevel = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    try {
      impl_->net = cv::dnn::readNet(params_.model, params_.config, params_.framework);
    } catch (const cv::Exception& e) {
      cv::utils::logging::setLogLevel(logLevel);
      throw Error(params_.model + ": cannot load network: " + e.err);
    }
    cv::utils::logging::setLogLevel(logLevel);
  }
  require(!impl_->net.empty(), params_.model, "cannot load network (empty net)");
  impl_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  impl_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  // A model that does not fit its section (another input size, another output layout) fails here, once, with
  // one line naming the file, instead of on the first frame (OpenCV's own multi-line log is silenced).
  const cv::Mat probe(std::vector<int>{1, 3, params_.inputHeight, params_.inputWidth}, CV_32F, cv::Scalar(0));
  cv::Mat out;
  const auto logLevel = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  try {
    impl_->net.setInput(probe);
    out = params_.normalsOutput.empty() ? impl_->net.forward() : impl_->net.forward(params_.normalsOutput);
  } catch (const cv::Exception& e) {
    cv::utils::logging::setLogLevel(logLevel);
    throw Error(params_.model + ": does not run on a " + std::to_string(params_.inputWidth) + "x" +
                std::to_string(params_.inputHeight) + " input (inputWidth/inputHeight of [" +
                NetworkNormalParams::kSection + "]" + (params_.normalsOutput.empty() ? "" : ", or normalsOutput") +
                " do not match the model): " + e.err);
  }
  cv::utils::logging::setLogLevel(logLevel);
  checkOutputLayout(out);
}

void NetworkNormalEstimator::checkOutputLayout(const cv::Mat& out) const {
  require(out.dims == 4 && out.size[0] == 1, params_.model, "normals output must be a 1xCxHxW blob");
  const int C = out.size[1];
  require(C >= 3, params_.model, "normals output has " + std::to_string(C) + " channels, needs >= 3");
  require(params_.planarChannel < C, params_.model,
          "planarChannel " + std::to_string(params_.planarChannel) + " but the output has " + std::to_string(C) +
              " channels");
}

NetworkNormalEstimator::~NetworkNormalEstimator() = default;

NormalMap NetworkNormalEstimator::compute(const cv::Mat& image, const PinholeIntrinsics* K) {
  require(!image.empty(), kCtx, "empty input image");
  require(image.type() == CV_8UC3 || image.type() == CV_8UC1, kCtx, "input image must be 8-bit grey or BGR");
  cv::Mat bgr = image;
  if (image.channels() == 1) cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  const NetworkNormalParams& P = params_;
  // Shrinking by area averaging: blobFromImage's bilinear resize would alias a large frame (640 -> 128 columns
  // samples one pixel in five), unlike the anti-aliased images a network is trained on.
  const cv::Size inputSize(P.inputWidth, P.inputHeight);
  if (bgr.cols > inputSize.width && bgr.rows > inputSize.height) {
    cv::Mat small;
    cv::resize(bgr, small, inputSize, 0, 0, cv::INTER_AREA);
    bgr = small;
  }
  const cv::Mat blob = cv::dnn::blobFromImage(bgr, P.scale, inputSize, cv::Scalar(P.mean[0], P.mean[1], P.mean[2]),
                                              P.swapRB, false);
  impl_->net.setInput(blob);
  cv::Mat out;
  try {
    out = P.normalsOutput.empty() ? impl_->net.forward() : impl_->net.forward(P.normalsOutput);
  } catch (const cv::Exception& e) {
    throw Error(P.model + ": forward pass failed: " + e.what());
  }
  checkOutputLayout(out);
  const int H = out.size[2], W = out.size[3];
  auto plane = [&](int c) { return cv::Mat(H, W, CV_32F, out.ptr<float>(0, c)); };
  const auto axes = P.parsedAxes();
  NormalMap nm;
  nm.normals.create(image.size(), CV_32FC3);
  nm.planarMask = cv::Mat(image.size(), CV_8UC1, cv::Scalar(255));
  if (P.planarChannel >= 0) {
    cv::Mat prob;
    cv::resize(plane(P.planarChannel), prob, image.size(), 0, 0, cv::INTER_LINEAR);
    nm.planarMask = prob >= P.planarThreshold;
  }
  // One pass in float over the image: bilinear upsampling of the three output planes (pixel centres aligned and
  // borders clamped, as cv::resize INTER_LINEAR), axis mapping, normalization, dropping (near-)zero and
  // non-finite vectors, orientation towards the camera. No full-size intermediate images.
  struct Tap {
    int i0, i1;
    float w1;
  };
  const auto taps = [](int n, int nSrc) {
    std::vector<Tap> t(static_cast<std::size_t>(n));
    const double scale = double(nSrc) / n;
    for (int i = 0; i < n; ++i) {
      const double s = std::clamp((i + 0.5) * scale - 0.5, 0.0, double(nSrc - 1));
      const int i0 = std::min(static_cast<int>(s), nSrc - 1);
      t[static_cast<std::size_t>(i)] = {i0, std::min(i0 + 1, nSrc - 1), static_cast<float>(s - i0)};
    }
    return t;
  };
  const std::vector<Tap> tu = taps(image.cols, W), tv = taps(image.rows, H);
  const float* src[3];
  float gain[3], offset[3];
  for (std::size_t k = 0; k < 3; ++k) {
    src[k] = out.ptr<float>(0, axes[k].channel);
    gain[k] = static_cast<float>(axes[k].sign * P.outputScale);
    offset[k] = static_cast<float>(axes[k].sign * P.outputOffset);
  }
  const bool orient = P.orientTowardsCamera && K;
  const float ifx = orient ? float(1.0 / K->fx) : 0.f, ify = orient ? float(1.0 / K->fy) : 0.f;
  const float cx = orient ? float(K->cx) : 0.f, cy = orient ? float(K->cy) : 0.f;
  for (int v = 0; v < image.rows; ++v) {
    const Tap& ty = tv[static_cast<std::size_t>(v)];
    auto* n = nm.normals.ptr<cv::Vec3f>(v);
    uchar* m = nm.planarMask.ptr<uchar>(v);
    const float ry = (float(v) - cy) * ify;
    for (int u = 0; u < image.cols; ++u) {
      const Tap& tx = tu[static_cast<std::size_t>(u)];
      float c[3];
      for (int k = 0; k < 3; ++k) {
        const float* r0 = src[k] + static_cast<std::size_t>(ty.i0) * W;
        const float* r1 = src[k] + static_cast<std::size_t>(ty.i1) * W;
        const float top = r0[tx.i0] + tx.w1 * (r0[tx.i1] - r0[tx.i0]);
        const float bottom = r1[tx.i0] + tx.w1 * (r1[tx.i1] - r1[tx.i0]);
        c[k] = gain[k] * (top + ty.w1 * (bottom - top)) + offset[k];
      }
      const float norm = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
      if (!(norm >= 1e-3f) || !std::isfinite(norm)) {  // also NaN
        n[u] = cv::Vec3f(0, 0, 0);
        m[u] = 0;
        continue;
      }
      float s = 1.f / norm;
      if (orient && c[0] * ((float(u) - cx) * ifx) + c[1] * ry + c[2] > 0) s = -s;
      n[u] = cv::Vec3f(c[0] * s, c[1] * s, c[2] * s);
    }
  }
  return nm;
}

}  // namespace pslam::priors
