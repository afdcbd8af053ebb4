#include "pslam/datasets/DatasetIndex.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <mrpt/core/Clock.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam::datasets {

double quantizeStamp(double seconds) {
  require(std::isfinite(seconds), "timestamp", "NaN or Inf");
  const double microseconds = std::round(seconds * 1e6) / 1e6;
  return mrpt::Clock::toDouble(mrpt::Clock::fromDouble(microseconds));
}

void requireSortedStamps(const Trajectory& samples, const std::string& source) {
  for (std::size_t k = 1; k < samples.size(); ++k) {
    if (!(samples[k].timestamp > samples[k - 1].timestamp))
      throw Error(source + ": ground-truth stamps are not strictly increasing at pose " + std::to_string(k) +
                  " (" + std::to_string(samples[k - 1].timestamp) + " then " +
                  std::to_string(samples[k].timestamp) + ")");
  }
}

std::optional<Eigen::Isometry3d> interpolatePose(const Trajectory& samples, double t, double maxGap) {
  if (samples.empty() || !std::isfinite(t)) return std::nullopt;
  if (t < samples.front().timestamp || t > samples.back().timestamp) return std::nullopt;
  // First sample with stamp >= t.
  const auto upper = std::lower_bound(samples.begin(), samples.end(), t,
                                      [](const StampedPose& p, double v) { return p.timestamp < v; });
  if (upper->timestamp == t) return upper->T_world_cam();
  const auto lower = upper - 1;
  const double span = upper->timestamp - lower->timestamp;
  if (maxGap > 0 && span > maxGap) return std::nullopt;
  const double alpha = (t - lower->timestamp) / span;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = (1.0 - alpha) * lower->position + alpha * upper->position;
  T.linear() = lower->orientation.normalized().slerp(alpha, upper->orientation.normalized()).toRotationMatrix();
  return T;
}

void selectFrames(DatasetIndex& index, std::size_t first, std::size_t last, std::size_t stride) {
  const std::string ctx = index.root.string();
  require(!index.frames.empty(), ctx, "empty dataset: no frames found");
  require(stride >= 1, ctx, "stride must be at least 1");
  const std::size_t n = index.frames.size();
  require(first < n, ctx,
          "first frame " + std::to_string(first) + " is beyond the " + std::to_string(n) + " frames of the dataset");
  require(last >= first, ctx, "last frame " + std::to_string(last) + " is before the first " + std::to_string(first));
  const std::size_t end = std::min(last, n - 1);
  std::vector<FrameEntry> kept;
  for (std::size_t i = first; i <= end; i += stride) kept.push_back(std::move(index.frames[i]));
  index.frames = std::move(kept);
}

Frame loadFrame(const DatasetIndex& index, std::size_t i, ColorMode mode) {
  require(i < index.frames.size(), index.root.string(), "frame " + std::to_string(i) + " out of range");
  const FrameEntry& e = index.frames[i];
  Frame f;
  f.index = i;
  f.timestamp = e.timestamp;
  f.camera = index.camera;
  f.sensorPoseOnBody = index.sensorPoseOnBody;

  cv::Mat img = cv::imread(e.image.string(), cv::IMREAD_UNCHANGED);
  if (img.empty()) throw Error(e.image.string() + ": cannot read image (missing, empty or not an image)");
  if (img.depth() != CV_8U)
    throw Error(e.image.string() + ": CAMERA image must be 8-bit (found " + std::to_string(8 * img.elemSize1()) +
                "-bit)");
  if (img.channels() == 4) cv::cvtColor(img, img, cv::COLOR_BGRA2BGR);
  if (img.channels() != 1 && img.channels() != 3)
    throw Error(e.image.string() + ": unsupported channel count " + std::to_string(img.channels()));
  if (mode == ColorMode::Grey && img.channels() == 3) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
  if (mode == ColorMode::Colour && img.channels() == 1) cv::cvtColor(img, img, cv::COLOR_GRAY2BGR);
  f.image = img;

  if (!e.depth.empty()) {
    cv::Mat depth = cv::imread(e.depth.string(), cv::IMREAD_UNCHANGED);
    if (depth.empty()) throw Error(e.depth.string() + ": cannot read depth image (missing, empty or not an image)");
    if (depth.type() != CV_16UC1)
      throw Error(e.depth.string() + ": depth image must be 16-bit single channel (raw units kept as is)");
    f.depth = depth;
    f.depthUnits = index.depthUnits;
  }
  validateFrame(f, e.image.string());
  return f;
}

Trajectory groundTruthTrajectory(const DatasetIndex& index) {
  Trajectory out;
  for (const auto& e : index.frames)
    if (e.T_world_cam) out.emplace_back(e.timestamp, *e.T_world_cam);
  return out;
}

}  // namespace pslam::datasets
