#pragma once
// Helpers shared by the eval tests: temporary files and synthetic trajectories.
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <Eigen/Geometry>

#include "pslam/core/Trajectory.h"

namespace pslam::eval::test {

/// A fresh folder under the system temp dir, removed on destruction.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& name) {
    path = std::filesystem::temp_directory_path() / ("pslam_eval_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = path / name;
    std::ofstream(p) << text;
    return p;
  }
};

/// A smooth non-planar camera path with changing orientation (30 Hz stamps from t0).
inline Trajectory makeSpiral(std::size_t n, double t0 = 100.0) {
  Trajectory out;
  for (std::size_t k = 0; k < n; ++k) {
    const double s = 0.1 * static_cast<double>(k);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(std::cos(s), std::sin(s), 0.05 * s + 0.2 * std::sin(2 * s));
    T.linear() = (Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.3 * std::sin(s), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    out.emplace_back(t0 + static_cast<double>(k) / 30.0, T);
  }
  return out;
}

}  // namespace pslam::eval::test
