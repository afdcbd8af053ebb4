#include "pslam/core/Trajectory.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"

namespace pslam {

StampedPose::StampedPose(double t, const Eigen::Isometry3d& T)
    : timestamp(t), position(T.translation()), orientation(Eigen::Quaterniond(T.linear()).normalized()) {}

Eigen::Isometry3d StampedPose::T_world_cam() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = orientation.normalized().toRotationMatrix();
  T.translation() = position;
  return T;
}

mrpt::poses::CPose3D toCPose3D(const Eigen::Isometry3d& T) {
  mrpt::math::CMatrixDouble44 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = T.matrix()(r, c);
  return mrpt::poses::CPose3D(M);
}

Eigen::Isometry3d toIsometry(const mrpt::poses::CPose3D& T) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  const auto M = T.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.matrix()(r, c) = M(r, c);
  return out;
}

mrpt::poses::CPose3D StampedPose::toCPose3D() const { return pslam::toCPose3D(T_world_cam()); }

StampedPose StampedPose::fromCPose3D(double t, const mrpt::poses::CPose3D& T_world_cam) {
  return StampedPose(t, toIsometry(T_world_cam));
}

std::string stampOrderError(const std::filesystem::path& path, int line, double stamp, int previousLine) {
  char t[64];
  std::snprintf(t, sizeof t, "%.6f", stamp);
  return path.string() + ":" + std::to_string(line) + ": timestamp " + t + " is before the previous one (line " +
         std::to_string(previousLine) + ")";
}

std::string duplicateStampNote(const Trajectory& trajectory, const std::filesystem::path& path) {
  std::size_t duplicates = 0, first = 0;
  for (std::size_t k = 1; k < trajectory.size(); ++k)
    if (trajectory[k].timestamp == trajectory[k - 1].timestamp && duplicates++ == 0) first = k;
  if (duplicates == 0) return "";
  char t[64];
  std::snprintf(t, sizeof t, "%.6f", trajectory[first].timestamp);
  return path.string() + ": " + std::to_string(duplicates) + " pose" + (duplicates > 1 ? "s have" : " has") +
         " the timestamp of the previous one (first: pose " + std::to_string(first) + ", " + t + ")";
}

Trajectory readTumTrajectory(const std::filesystem::path& path, StampOrder order) {
  std::ifstream f(path);
  if (!f) throw Error(path.string() + ": cannot open trajectory file");
  Trajectory out;
  std::string line;
  int lineNo = 0, previousLine = 0;
  while (std::getline(f, line)) {
    ++lineNo;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream ss(line);
    double v[8];
    static const char* const kColumns[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    for (int k = 0; k < 8; ++k) {
      std::string token;
      if (!(ss >> token))
        throw Error(path.string() + ":" + std::to_string(lineNo) +
                    ": malformed TUM line (expected 'timestamp tx ty tz qx qy qz qw'; " + kColumns[k] + " is missing)");
      // strtod rather than >>: it tells a value that is no number from one out of range or not finite.
      errno = 0;
      char* end = nullptr;
      v[k] = std::strtod(token.c_str(), &end);
      const std::string at = path.string() + ":" + std::to_string(lineNo) + ": " + kColumns[k] + " = '" + token + "'";
      if (end != token.c_str() + token.size()) throw Error(at + ": not a number");
      if (errno == ERANGE && std::isinf(v[k])) throw Error(at + ": out of the range of a double");
      if (!std::isfinite(v[k])) throw Error(at + ": not a finite number");
    }
    std::string extra;
    if (ss >> extra)
      throw Error(path.string() + ":" + std::to_string(lineNo) + ": more than 8 values on a TUM line");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-6) throw Error(path.string() + ":" + std::to_string(lineNo) + ": zero quaternion");
    if (order == StampOrder::NonDecreasing && !out.empty() && v[0] < out.back().timestamp)
      throw Error(stampOrderError(path, lineNo, v[0], previousLine));
    previousLine = lineNo;
    StampedPose p;
    p.timestamp = v[0];
    p.position = Eigen::Vector3d(v[1], v[2], v[3]);
    p.orientation = q.normalized();
    out.push_back(p);
  }
  return out;
}

std::string formatTumLine(const StampedPose& p) {
  char buf[256];
  const Eigen::Quaterniond q = p.orientation.normalized();
  std::snprintf(buf, sizeof(buf), "%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g", p.timestamp, p.position.x(),
                p.position.y(), p.position.z(), q.x(), q.y(), q.z(), q.w());
  return buf;
}

void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                        const std::string& headerComment) {
  writeFileAtomically(path, [&](std::ostream& os) {
    if (!headerComment.empty()) os << "# " << headerComment << "\n";
    os << "# timestamp tx ty tz qx qy qz qw (camera-to-world)\n";
    for (const auto& p : trajectory) os << formatTumLine(p) << "\n";
  });
}

const StampedPose* nearestPose(const Trajectory& sortedByStamp, double t, double maxDt) {
  const auto it = std::lower_bound(sortedByStamp.begin(), sortedByStamp.end(), t,
                                   [](const StampedPose& p, double s) { return p.timestamp < s; });
  const StampedPose* best = it != sortedByStamp.end() ? &*it : nullptr;
  if (it != sortedByStamp.begin() && (!best || std::abs((it - 1)->timestamp - t) < std::abs(best->timestamp - t)))
    best = &*(it - 1);
  return best && std::abs(best->timestamp - t) <= maxDt ? best : nullptr;
}

}  // namespace pslam
