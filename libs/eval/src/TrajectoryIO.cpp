#include "pslam/eval/TrajectoryIO.h"

#include <Eigen/SVD>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <vector>

#include "pslam/core/Error.h"

namespace pslam::eval {

namespace {

std::string where(const std::filesystem::path& path, int line) {
  return path.string() + ":" + std::to_string(line);
}

bool isDataLine(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first != std::string::npos && line[first] != '#';
}

// Splits a line on whitespace and commas into numbers; returns false on a token that is not a number.
bool parseNumbers(const std::string& line, std::vector<double>& values) {
  values.clear();
  std::string cleaned = line;
  for (char& c : cleaned)
    if (c == ',') c = ' ';
  std::istringstream ss(cleaned);
  std::string token;
  while (ss >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') return false;
    values.push_back(v);
  }
  return true;
}

std::ifstream openOrThrow(const std::filesystem::path& path, const std::string& what) {
  std::ifstream f(path);
  if (!f) throw Error(path.string() + ": cannot open " + what);
  return f;
}

}  // namespace

TrajectoryFormat parseTrajectoryFormat(const std::string& name) {
  if (name == "auto") return TrajectoryFormat::Auto;
  if (name == "tum") return TrajectoryFormat::Tum;
  if (name == "kitti") return TrajectoryFormat::Kitti;
  if (name == "euroc") return TrajectoryFormat::Euroc;
  throw Error("trajectory format '" + name + "': expected auto, tum, kitti or euroc");
}

std::string toString(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::Auto: return "auto";
    case TrajectoryFormat::Tum: return "tum";
    case TrajectoryFormat::Kitti: return "kitti";
    case TrajectoryFormat::Euroc: return "euroc";
  }
  return "?";
}

TrajectoryFormat detectTrajectoryFormat(const std::filesystem::path& path) {
  auto f = openOrThrow(path, "trajectory file");
  std::string line;
  int lineNo = 0;
  while (std::getline(f, line)) {
    ++lineNo;
    if (!isDataLine(line)) continue;
    std::vector<double> values;
    if (!parseNumbers(line, values))
      throw Error(where(path, lineNo) + ": cannot detect the trajectory format (non-numeric value)");
    const bool hasComma = line.find(',') != std::string::npos;
    // EuRoC stamps are integer nanoseconds (> 1e15 for any date after 1970-01-12).
    if (hasComma && values.size() >= 8 && values[0] > 1e15 && line.find('.') > line.find(','))
      return TrajectoryFormat::Euroc;
    if (values.size() == 12) return TrajectoryFormat::Kitti;
    if (values.size() == 8) return TrajectoryFormat::Tum;
    throw Error(where(path, lineNo) + ": cannot detect the trajectory format (" + std::to_string(values.size()) +
                " values: TUM has 8, KITTI 12, EuRoC csv >= 8 with a nanosecond stamp)");
  }
  throw Error(path.string() + ": no data line, cannot detect the trajectory format");
}

Trajectory readKittiTrajectory(const std::filesystem::path& path, const std::filesystem::path& timesPath) {
  auto f = openOrThrow(path, "KITTI trajectory file");
  Trajectory out;
  std::string line;
  int lineNo = 0;
  std::vector<double> v;
  while (std::getline(f, line)) {
    ++lineNo;
    if (!isDataLine(line)) continue;
    if (!parseNumbers(line, v) || v.size() != 12)
      throw Error(where(path, lineNo) + ": malformed KITTI line (expected 12 numbers, a row-major 3x4 [R|t])");
    for (double x : v)
      if (!std::isfinite(x)) throw Error(where(path, lineNo) + ": NaN or Inf value");
    Eigen::Matrix3d R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    // Nearest rotation (polar decomposition) of the rounded matrix; refuses matrices far from SO(3).
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d Rn = svd.matrixU() * svd.matrixV().transpose();
    if (Rn.determinant() < 0 || (Rn - R).norm() > 1e-2)
      throw Error(where(path, lineNo) + ": the 3x3 block is not a rotation matrix");
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Rn;
    T.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
    out.emplace_back(static_cast<double>(out.size()), T);
  }
  if (!timesPath.empty()) {
    auto tf = openOrThrow(timesPath, "KITTI times file");
    std::size_t k = 0;
    int tl = 0, previousLine = 0;
    while (std::getline(tf, line)) {
      ++tl;
      if (!isDataLine(line)) continue;
      if (!parseNumbers(line, v) || v.size() != 1 || !std::isfinite(v[0]))
        throw Error(where(timesPath, tl) + ": malformed times line (expected one finite number)");
      if (k >= out.size())
        throw Error(timesPath.string() + ": more times than the " + std::to_string(out.size()) + " poses of " +
                    path.string());
      if (k > 0 && v[0] < out[k - 1].timestamp) throw Error(stampOrderError(timesPath, tl, v[0], previousLine));
      previousLine = tl;
      out[k++].timestamp = v[0];
    }
    if (k != out.size())
      throw Error(timesPath.string() + ": " + std::to_string(k) + " times for " + std::to_string(out.size()) +
                  " poses of " + path.string());
  }
  return out;
}

Trajectory readEurocTrajectory(const std::filesystem::path& path) {
  auto f = openOrThrow(path, "EuRoC csv trajectory file");
  Trajectory out;
  std::string line;
  int lineNo = 0, previousLine = 0;
  std::int64_t previousNs = 0;
  std::vector<double> v;
  while (std::getline(f, line)) {
    ++lineNo;
    if (!isDataLine(line)) continue;
    const auto comma = line.find(',');
    if (comma == std::string::npos)
      throw Error(where(path, lineNo) + ": malformed EuRoC line (expected comma-separated values)");
    // The stamp is parsed as an integer: a double holds ~16 digits and ns stamps have 19.
    std::int64_t ns = 0;
    try {
      std::size_t used = 0;
      const std::string stampText = line.substr(0, comma);
      ns = std::stoll(stampText, &used);
      if (stampText.find_first_not_of(" \t", used) != std::string::npos) throw std::invalid_argument("tail");
    } catch (const std::exception&) {
      throw Error(where(path, lineNo) + ": malformed EuRoC timestamp (expected integer nanoseconds)");
    }
    if (!parseNumbers(line.substr(comma + 1), v) || v.size() < 7)
      throw Error(where(path, lineNo) + ": malformed EuRoC line (expected 'ns, px, py, pz, qw, qx, qy, qz')");
    for (int k = 0; k < 7; ++k)
      if (!std::isfinite(v[k])) throw Error(where(path, lineNo) + ": NaN or Inf value");
    Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    if (q.norm() < 1e-6) throw Error(where(path, lineNo) + ": zero quaternion");
    StampedPose p;
    // Seconds = whole seconds + fractional part, so no precision is lost before the final double.
    p.timestamp = static_cast<double>(ns / 1000000000) + static_cast<double>(ns % 1000000000) * 1e-9;
    if (!out.empty() && ns < previousNs) throw Error(stampOrderError(path, lineNo, p.timestamp, previousLine));
    previousLine = lineNo;
    previousNs = ns;
    p.position = Eigen::Vector3d(v[0], v[1], v[2]);
    p.orientation = q.normalized();
    out.push_back(p);
  }
  return out;
}

Trajectory readTrajectory(const std::filesystem::path& path, TrajectoryFormat format,
                          const std::filesystem::path& kittiTimesPath) {
  if (format == TrajectoryFormat::Auto) format = detectTrajectoryFormat(path);
  switch (format) {
    case TrajectoryFormat::Tum: return readTumTrajectory(path, StampOrder::NonDecreasing);
    case TrajectoryFormat::Kitti: return readKittiTrajectory(path, kittiTimesPath);
    case TrajectoryFormat::Euroc: return readEurocTrajectory(path);
    case TrajectoryFormat::Auto: break;
  }
  throw Error(path.string() + ": unknown trajectory format");
}

}  // namespace pslam::eval
