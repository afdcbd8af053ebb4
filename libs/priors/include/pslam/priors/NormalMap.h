#pragma once
// Dense camera-frame normal maps (the NORMALS channel of the rawlog contract, doc/architecture.md) and the
// normal-accuracy metrics of thesis §4.5.3 (eqs. 4.3-4.7).
#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace pslam::priors {

/// One dense normal map in the camera frame (x right, y down, z forward).
struct NormalMap {
  cv::Mat normals;     ///< CV_32FC3 unit normals; (0,0,0) where there is no normal
  cv::Mat planarMask;  ///< CV_8UC1, 255 = pixel lies on a detected plane (the map's normals are used there)
  cv::Mat planeLabels; ///< CV_32SC1 plane index (>= 0) or -1; may be empty for sources without segmentation
  int planeCount = 0;
};

/// Encodes a normal map into the NORMALS channel (CV_8UC3): only pixels inside `mask` (CV_8UC1, non-zero)
/// with a non-zero normal get a value; all others are (0,0,0). An empty mask means "every valid normal".
cv::Mat encodeNormalMap(const cv::Mat& normals32f, const cv::Mat& mask = cv::Mat());

/// Decodes a NORMALS channel (CV_8UC3) into CV_32FC3 unit normals, (0,0,0) for "no normal".
/// Throws pslam::Error naming `context` on a wrong type.
cv::Mat decodeNormalMap(const cv::Mat& normals8u, const std::string& context = "NORMALS");

/// Collects the valid normals of a CV_32FC3 map, taking every `stride`-th pixel in both directions.
std::vector<Eigen::Vector3d> collectNormals(const cv::Mat& normals32f, int stride = 1);

/// The valid normals of every `stride`-th pixel of a NORMALS channel (CV_8UC3): the same normals in the same order
/// as collectNormals(decodeNormalMap(normals8u), stride), decoding only the pixels taken. Throws pslam::Error
/// naming `context` on a wrong type or a stride < 1.
std::vector<Eigen::Vector3d> sampleNormals(const cv::Mat& normals8u, int stride, const std::string& context);

/// Summary of per-normal angular errors (thesis eqs. 4.3-4.7), angles in degrees.
struct NormalAccuracy {
  std::size_t count = 0;
  double meanDeg = 0.0, medianDeg = 0.0, rmseDeg = 0.0;
  double under11_25 = 0.0, under22_5 = 0.0, under30 = 0.0;  ///< shares in [0,1]
  nlohmann::json toJson() const;
};

/// Accumulates eq. 4.3 errors over many frames in O(1) memory: sums for mean/RMSE, exact counts for the
/// thresholds, and a 0.01-degree histogram for the median (so the median is exact to 0.01 degrees).
class NormalErrorAccumulator {
 public:
  NormalErrorAccumulator();
  /// Adds one error in degrees.
  void add(double errorDeg);
  /// Adds every pixel where both CV_32FC3 maps hold a normal. Sizes must agree (pslam::Error otherwise).
  void addMaps(const cv::Mat& estimated32f, const cv::Mat& groundTruth32f);
  NormalAccuracy summary() const;

 private:
  static constexpr double kBinDeg = 0.01;
  std::vector<std::size_t> histogram_;
  std::size_t count_ = 0;
  double sum_ = 0.0, sumSq_ = 0.0;
  std::array<std::size_t, 3> under_{};
};

/// Per-normal error of eq. 4.3 in degrees (inputs need not be exactly unit length).
double normalAngleDeg(const cv::Vec3f& estimated, const cv::Vec3f& groundTruth);

}  // namespace pslam::priors
