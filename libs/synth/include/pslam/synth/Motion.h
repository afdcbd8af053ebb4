#pragma once
// Smooth motions for the synthetic scenes: monotone cubic interpolation of key values (no overshoot, so a
// camera never swings through a wall between keys), speed profiles for stop-and-go traffic, and look-at
// camera paths with handheld jitter.
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

namespace pslam::synth {

/// Monotone piecewise-cubic Hermite interpolation (Fritsch-Carlson, C1). Outside the keys the value is held
/// at the end key. `periodic` wraps the time modulo (t_last - t_first) and matches the end slopes, which
/// needs y_last == y_first.
class MonotoneCubic {
 public:
  MonotoneCubic() = default;
  MonotoneCubic(std::vector<double> t, std::vector<double> y, bool periodic = false);
  double operator()(double t) const;
  double period() const { return t_.empty() ? 0.0 : t_.back() - t_.front(); }

 private:
  std::vector<double> t_, y_, m_;
  bool periodic_ = false;
};

/// Distance along a path from a speed profile: speed keys (t_i, v_i) joined by smoothstep ramps, so the
/// acceleration is continuous; the distance is the closed-form integral (a segment contributes
/// (t_{i+1}-t_i)(v_i+v_{i+1})/2). Before the first key and after the last the speed is held.
class SpeedProfile {
 public:
  SpeedProfile() = default;
  SpeedProfile(std::vector<double> t, std::vector<double> v, double s0 = 0.0);
  double speed(double t) const;
  double distance(double t) const;

 private:
  std::vector<double> t_, v_, s_;
  double s0_ = 0.0;
};

/// Rotation whose columns are the camera axes (x right, y down, z forward) in world coordinates, looking
/// along `forward` with world `up` (+z) pointing up in the image, then rolled by `roll` about the optical axis.
Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up, double roll = 0.0);

/// Handheld-like shake: smooth seeded noise on the three rotation angles (rad) and position (m).
struct Jitter {
  double angle = 0.0;     ///< amplitude in radians
  double position = 0.0;  ///< amplitude in metres
  double frequency = 0.7; ///< Hz of the smooth noise
  std::uint32_t seed = 1;
};

/// Camera path from keys (time, position, look-at target) interpolated component-wise with MonotoneCubic.
class CameraPath {
 public:
  struct Key {
    double t;
    Eigen::Vector3d position;
    Eigen::Vector3d target;
  };
  CameraPath() = default;
  CameraPath(const std::vector<Key>& keys, Jitter jitter, bool periodic);
  /// T_world_cam at time t (seconds).
  Eigen::Isometry3d pose(double t) const;

 private:
  MonotoneCubic p_[3], q_[3];
  Jitter jitter_;
};

/// Applies a Jitter to a pose at time t.
Eigen::Isometry3d applyJitter(const Eigen::Isometry3d& T_world_cam, const Jitter& jitter, double t);

}  // namespace pslam::synth
