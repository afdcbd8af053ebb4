#include "pslam/priors/NormalMap.h"

#include <algorithm>
#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"

namespace pslam::priors {

namespace {
bool isZero(const cv::Vec3f& n) { return n[0] == 0.f && n[1] == 0.f && n[2] == 0.f; }
}  // namespace

cv::Mat encodeNormalMap(const cv::Mat& normals32f, const cv::Mat& mask) {
  require(normals32f.type() == CV_32FC3, "encodeNormalMap", "normals must be CV_32FC3");
  require(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == normals32f.size()), "encodeNormalMap",
          "mask must be CV_8UC1 of the normal map's size");
  cv::Mat out(normals32f.size(), CV_8UC3, cv::Scalar::all(0));
  for (int v = 0; v < normals32f.rows; ++v) {
    const auto* n = normals32f.ptr<cv::Vec3f>(v);
    const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(v);
    auto* o = out.ptr<cv::Vec3b>(v);
    for (int u = 0; u < normals32f.cols; ++u) {
      if ((m && !m[u]) || isZero(n[u]) || !std::isfinite(n[u][0] + n[u][1] + n[u][2])) continue;
      o[u] = datasets::encodeNormal(cv::Vec3d(n[u][0], n[u][1], n[u][2]));
    }
  }
  return out;
}

cv::Mat decodeNormalMap(const cv::Mat& normals8u, const std::string& context) {
  require(normals8u.type() == CV_8UC3, context, "NORMALS must be CV_8UC3");
  cv::Mat out(normals8u.size(), CV_32FC3, cv::Scalar::all(0));
  for (int v = 0; v < normals8u.rows; ++v) {
    const auto* p = normals8u.ptr<cv::Vec3b>(v);
    auto* o = out.ptr<cv::Vec3f>(v);
    for (int u = 0; u < normals8u.cols; ++u) {
      cv::Vec3d n;
      if (datasets::decodeNormal(p[u], n)) o[u] = cv::Vec3f(n);
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> collectNormals(const cv::Mat& normals32f, int stride) {
  require(normals32f.type() == CV_32FC3, "collectNormals", "normals must be CV_32FC3");
  require(stride >= 1, "collectNormals", "stride must be >= 1");
  std::vector<Eigen::Vector3d> out;
  for (int v = 0; v < normals32f.rows; v += stride) {
    const auto* n = normals32f.ptr<cv::Vec3f>(v);
    for (int u = 0; u < normals32f.cols; u += stride) {
      if (isZero(n[u])) continue;
      Eigen::Vector3d e(n[u][0], n[u][1], n[u][2]);
      const double norm = e.norm();
      if (!std::isfinite(norm) || norm < 1e-6) continue;
      out.push_back(e / norm);
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> sampleNormals(const cv::Mat& normals8u, int stride, const std::string& context) {
  require(stride >= 1, context, "normal stride must be >= 1");
  if (normals8u.type() != CV_8UC3) decodeNormalMap(normals8u, context);  // says what the type should be
  cv::Mat picked((normals8u.rows + stride - 1) / stride, (normals8u.cols + stride - 1) / stride, CV_8UC3);
  for (int r = 0; r < picked.rows; ++r) {
    const auto* in = normals8u.ptr<cv::Vec3b>(r * stride);
    auto* out = picked.ptr<cv::Vec3b>(r);
    for (int c = 0; c < picked.cols; ++c) out[c] = in[c * stride];
  }
  return collectNormals(decodeNormalMap(picked, context), 1);
}

double normalAngleDeg(const cv::Vec3f& est, const cv::Vec3f& gt) {
  const double ne = cv::norm(est), ng = cv::norm(gt);
  const double c = std::clamp(static_cast<double>(est.dot(gt)) / (ne * ng), -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;  // eq. 4.3
}

nlohmann::json NormalAccuracy::toJson() const {
  return {{"count", count},           {"mean_deg", meanDeg},       {"median_deg", medianDeg},
          {"rmse_deg", rmseDeg},      {"under_11_25", under11_25}, {"under_22_5", under22_5},
          {"under_30", under30}};
}

NormalErrorAccumulator::NormalErrorAccumulator()
    : histogram_(static_cast<std::size_t>(180.0 / kBinDeg) + 1, 0) {}

void NormalErrorAccumulator::add(double e) {
  require(std::isfinite(e) && e >= 0.0, "NormalErrorAccumulator", "error must be finite and >= 0");
  const auto bin = std::min(histogram_.size() - 1, static_cast<std::size_t>(e / kBinDeg));
  ++histogram_[bin];
  ++count_;
  sum_ += e;
  sumSq_ += e * e;
  // eq. 4.7 uses a strict "< tau"
  if (e < 11.25) ++under_[0];
  if (e < 22.5) ++under_[1];
  if (e < 30.0) ++under_[2];
}

void NormalErrorAccumulator::addMaps(const cv::Mat& est, const cv::Mat& gt) {
  require(est.type() == CV_32FC3 && gt.type() == CV_32FC3, "NormalErrorAccumulator",
          "both normal maps must be CV_32FC3");
  require(est.size() == gt.size(), "NormalErrorAccumulator", "normal maps differ in size");
  for (int v = 0; v < est.rows; ++v) {
    const auto* a = est.ptr<cv::Vec3f>(v);
    const auto* b = gt.ptr<cv::Vec3f>(v);
    for (int u = 0; u < est.cols; ++u)
      if (!isZero(a[u]) && !isZero(b[u])) add(normalAngleDeg(a[u], b[u]));
  }
}

NormalAccuracy NormalErrorAccumulator::summary() const {
  NormalAccuracy s;
  s.count = count_;
  if (count_ == 0) {
    s.meanDeg = s.medianDeg = s.rmseDeg = std::nan("");
    return s;
  }
  const double n = static_cast<double>(count_);
  s.meanDeg = sum_ / n;             // eq. 4.4
  s.rmseDeg = std::sqrt(sumSq_ / n);  // eq. 4.6
  // eq. 4.5: the median as the centre of the bin holding the middle element (lower median for even n)
  const std::size_t target = (count_ - 1) / 2;
  std::size_t seen = 0;
  for (std::size_t b = 0; b < histogram_.size(); ++b) {
    seen += histogram_[b];
    if (seen > target) {
      s.medianDeg = (static_cast<double>(b) + 0.5) * kBinDeg;
      break;
    }
  }
  s.under11_25 = under_[0] / n;
  s.under22_5 = under_[1] / n;
  s.under30 = under_[2] / n;
  return s;
}

}  // namespace pslam::priors
