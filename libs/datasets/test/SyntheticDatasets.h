#pragma once
// Small datasets written by the tests themselves (temp folders), in each supported layout, with known
// timestamps, depth values and poses.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace pslam::datasets::testing {

namespace fs = std::filesystem;

/// Folders made by freshDir(), removed when the test program exits.
struct TempDirs {
  std::vector<fs::path> dirs;
  ~TempDirs() {
    for (const auto& d : dirs) {
      std::error_code ec;
      fs::remove_all(d, ec);
    }
  }
};
inline TempDirs& tempDirs() {
  static TempDirs t;
  return t;
}

inline fs::path freshDir(const std::string& name) {
  // The process id keeps concurrent runs of the tests (several build folders) apart.
  fs::path d = fs::temp_directory_path() / ("pslam_test_datasets_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  tempDirs().dirs.push_back(d);
  return d;
}

inline void writeText(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

/// Deterministic image content that differs per frame.
inline cv::Mat patternImage(int w, int h, int seed, int type = CV_8UC3) {
  cv::Mat m(h, w, type);
  cv::RNG rng(static_cast<uint64_t>(seed) + 1);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

inline cv::Mat depthImage(int w, int h, int seed) {
  cv::Mat d(h, w, CV_16UC1);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) d.at<uint16_t>(r, c) = static_cast<uint16_t>((seed * 7919 + r * 131 + c * 17) % 65536);
  d.at<uint16_t>(0, 0) = 0;      // invalid
  d.at<uint16_t>(1, 1) = 65535;  // largest value
  return d;
}

inline void writeImage(const fs::path& file, const cv::Mat& m) {
  fs::create_directories(file.parent_path());
  if (!cv::imwrite(file.string(), m)) throw std::runtime_error("cannot write " + file.string());
}

/// A smooth, non-trivial camera motion (rotation about a tilted axis + translation).
inline Eigen::Isometry3d motion(double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3 * t + 0.1, Eigen::Vector3d(0.2, 1.0, 0.3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.5 * t, -0.2 + 0.1 * t * t, 1.0 + std::sin(t));
  return T;
}

inline std::string tumLine(double t, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t, T.translation().x(),
                T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
  return buf;
}

inline std::string kittiLine(const Eigen::Isometry3d& T) {
  std::string s;
  char buf[64];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), "%s%.12e", s.empty() ? "" : " ", T.matrix()(r, c));
      s += buf;
    }
  return s + "\n";
}

/// A stamp as it reads back from a TUM text file (6 decimals).
inline double tumStamp(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return std::strtod(buf, nullptr);
}

struct TumSpec {
  int frames = 5;
  int width = 64, height = 48;
  double t0 = 1305031102.175304;
  double dt = 1.0 / 30.0;
  double depthOffset = 0.004;   ///< depth stamps = rgb stamps + offset
  double gtDt = 0.01;           ///< ground truth at 100 Hz
  double gtStart = 1305031102.175304 + 0.05;  ///< ground truth starts after the first frame
};

/// TUM RGB-D layout: rgb/ (PNG colour), depth/ (u16 PNG), rgb.txt, depth.txt, groundtruth.txt.
inline void writeTumDataset(const fs::path& root, const TumSpec& s) {
  std::string rgbTxt = "# color images\n# timestamp filename\n", depthTxt = "# depth maps\n# timestamp filename\n";
  char name[64];
  for (int i = 0; i < s.frames; ++i) {
    const double t = s.t0 + i * s.dt;
    std::snprintf(name, sizeof(name), "%.6f", t);
    writeImage(root / "rgb" / (std::string(name) + ".png"), patternImage(s.width, s.height, i));
    rgbTxt += std::string(name) + " rgb/" + name + ".png\n";
    const double td = t + s.depthOffset;
    std::snprintf(name, sizeof(name), "%.6f", td);
    writeImage(root / "depth" / (std::string(name) + ".png"), depthImage(s.width, s.height, i));
    depthTxt += std::string(name) + " depth/" + name + ".png\n";
  }
  writeText(root / "rgb.txt", rgbTxt);
  writeText(root / "depth.txt", depthTxt);
  std::string gt = "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
  const double tEnd = s.t0 + (s.frames - 1) * s.dt + 0.05;
  for (double t = s.gtStart; t <= tEnd; t += s.gtDt) gt += tumLine(t, motion(t - s.t0));
  writeText(root / "groundtruth.txt", gt);
}

}  // namespace pslam::datasets::testing
