#include "pslam/eval/DepthRatio.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"

namespace pslam::eval {

std::vector<DepthSample> readDepthSamples(const std::filesystem::path& path) {
  std::ifstream f(path);
  if (!f) throw Error(path.string() + ": cannot open map-point depth file");
  std::vector<DepthSample> out;
  std::string line;
  int lineNo = 0;
  while (std::getline(f, line)) {
    ++lineNo;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    DepthSample s;
    std::string extra;
    const std::string at = path.string() + ":" + std::to_string(lineNo);
    if (!(ss >> s.timestamp >> s.u >> s.v >> s.depth) || (ss >> extra))
      throw Error(at + ": malformed depth line (expected 'timestamp u v depth')");
    if (!std::isfinite(s.timestamp) || !std::isfinite(s.u) || !std::isfinite(s.v) || !std::isfinite(s.depth))
      throw Error(at + ": NaN or Inf value");
    if (s.depth <= 0.0) throw Error(at + ": depth must be > 0");
    out.push_back(s);
  }
  return out;
}

PSLAM_DEFINE_PARAMS(DepthRatioOptions)

nlohmann::json DepthRatioResult::toJson() const {
  return {{"ratio", ratio},
          {"inliers", inliers},
          {"evaluated", evaluated},
          {"without_ground_truth", withoutGroundTruth},
          {"relative_error", relativeError.toJson()}};
}

DepthRatioResult computeDepthRatio(const std::vector<DepthSample>& samples, const std::vector<DepthFrame>& frames,
                                   const DepthRatioOptions& options) {
  options.check();
  if (samples.empty()) throw Error("DR: no map-point depth samples");
  std::vector<std::size_t> order(frames.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return frames[a].timestamp < frames[b].timestamp; });
  DepthRatioResult r;
  std::vector<double> relErrors;
  for (const auto& s : samples) {
    // Nearest frame by stamp.
    const auto it = std::lower_bound(order.begin(), order.end(), s.timestamp,
                                     [&](std::size_t k, double t) { return frames[k].timestamp < t; });
    const DepthFrame* best = nullptr;
    double bestDiff = 0.0;
    for (auto c : {it, it == order.begin() ? it : it - 1}) {
      if (c == order.end()) continue;
      const double d = std::abs(frames[*c].timestamp - s.timestamp);
      if (!best || d < bestDiff) {
        best = &frames[*c];
        bestDiff = d;
      }
    }
    if (!best || bestDiff > options.maxTimeDifference) {
      std::ostringstream ss;
      ss.precision(17);
      ss << "DR: no ground-truth depth frame within " << options.maxTimeDifference << " s of sample stamp "
         << s.timestamp;
      throw Error(ss.str());
    }
    if (best->depth.empty() || best->depth.type() != CV_16UC1 || !(best->depthUnits > 0.0)) {
      std::ostringstream ss;
      ss.precision(17);
      ss << "DR: the frame at stamp " << best->timestamp << " has no valid u16 DEPTH image";
      throw Error(ss.str());
    }
    const long col = std::lround(s.u), row = std::lround(s.v);
    if (col < 0 || row < 0 || col >= best->depth.cols || row >= best->depth.rows) {
      ++r.withoutGroundTruth;
      continue;
    }
    const std::uint16_t raw = best->depth.at<std::uint16_t>(static_cast<int>(row), static_cast<int>(col));
    if (raw == 0) {
      ++r.withoutGroundTruth;
      continue;
    }
    const double dGt = raw * best->depthUnits;
    const double rel = std::abs(options.scale * s.depth - dGt) / dGt;  // eq. 2.104 summand before |.|_tau
    relErrors.push_back(rel);
    if (rel < options.tau) ++r.inliers;
  }
  r.evaluated = relErrors.size();
  if (r.evaluated == 0)
    throw Error("DR: none of the " + std::to_string(samples.size()) + " samples has a valid ground-truth depth");
  r.ratio = static_cast<double>(r.inliers) / static_cast<double>(r.evaluated);
  r.relativeError = computeStatistics(relErrors, "DR relative depth error");
  return r;
}

std::vector<DepthFrame> readDepthFrames(const std::filesystem::path& rawlog, std::vector<double> wanted,
                                       double maxTimeDifference) {
  std::sort(wanted.begin(), wanted.end());
  datasets::RawlogReader reader(rawlog);
  std::vector<DepthFrame> frames;
  datasets::Frame frame;
  while (reader.next(frame)) {
    // Keep only frames some sample may refer to: whole depth images of a long run do not fit in memory.
    const auto it = std::lower_bound(wanted.begin(), wanted.end(), frame.timestamp - maxTimeDifference);
    if (it == wanted.end() || *it > frame.timestamp + maxTimeDifference) continue;
    if (!frame.hasDepth())
      throw Error(rawlog.string() + ": frame " + std::to_string(frame.index) +
                  " is referenced by a depth sample but has no DEPTH observation");
    frames.push_back({frame.timestamp, frame.depth.clone(), frame.depthUnits});
  }
  return frames;
}

DepthRatioResult computeDepthRatio(const std::vector<DepthSample>& samples, const std::filesystem::path& rawlog,
                                   const DepthRatioOptions& options) {
  options.check();
  std::vector<double> wanted;
  for (const auto& s : samples) wanted.push_back(s.timestamp);
  return computeDepthRatio(samples, readDepthFrames(rawlog, std::move(wanted), options.maxTimeDifference), options);
}

}  // namespace pslam::eval
