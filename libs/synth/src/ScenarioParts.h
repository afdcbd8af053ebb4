#pragma once
// Building blocks shared by the scenario sources (not installed): seeded dice, materials, poses, boxes, a room.
#include <cstdint>
#include <initializer_list>
#include <random>

#include <Eigen/Geometry>

#include "pslam/synth/Scenarios.h"

namespace pslam::synth::detail {

using Eigen::Vector2d;
using Eigen::Vector3d;

inline std::uint8_t id(TrainId t) { return static_cast<std::uint8_t>(t); }

/// Seeded helpers: every random choice of a scenario comes from one std::mt19937.
struct Dice {
  std::mt19937 rng;
  explicit Dice(std::uint32_t seed) : rng(seed) {}
  /// An independent stream `id` of `seed`: content whose amount depends on the sequence length (street
  /// length) draws from its own stream, so a longer sequence extends the scene without reshuffling it.
  Dice(std::uint32_t seed, std::uint32_t id) {
    std::seed_seq seq{seed, id};
    rng.seed(seq);
  }
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
  bool chance(double p) { return uniform(0, 1) < p; }
  std::uint32_t seed() { return static_cast<std::uint32_t>(rng()); }
};

inline Material material(TextureKind kind, TrainId cls, std::uint32_t seed, float albedo, float contrast,
                  std::initializer_list<float> params = {}) {
  Material m;
  m.kind = kind;
  m.trainId = id(cls);
  m.seed = seed;
  m.albedo = albedo;
  m.contrast = contrast;
  int i = 0;
  for (float p : params) m.param[i++] = p;
  return m;
}

inline Eigen::Isometry3d poseXYYaw(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Vector3d(x, y, 0);
  return T;
}

inline BoxPart part(const Vector3d& size, const Vector3d& bottomCentre, int material) {
  BoxPart p;
  p.size = size;
  p.T_object_box.translation() = bottomCentre + Vector3d(0, 0, 0.5 * size.z());
  p.material = material;
  return p;
}

/// Closed room [0,X]x[0,Y]x[0,Z] with inward-facing textured walls.
inline void addRoomShell(Scene& s, double X, double Y, double Z, int floorMat, const int wallMats[4], int ceilingMat) {
  s.addFloor(0, 0, X, Y, 0, floorMat);
  s.addFloor(0, 0, X, Y, Z, ceilingMat);
  s.addWall({0, 0}, {X, 0}, 0, Z, wallMats[0]);
  s.addWall({X, 0}, {X, Y}, 0, Z, wallMats[1]);
  s.addWall({X, Y}, {0, Y}, 0, Z, wallMats[2]);
  s.addWall({0, Y}, {0, 0}, 0, Z, wallMats[3]);
}

/// The road scenes (RoadScenarios.cpp): a street with traffic, and a motorway traffic jam (with or without traffic).
Scenario makeStreet(std::uint32_t seed, double duration);
Scenario makeJam(std::uint32_t seed, double duration, bool traffic);

}  // namespace pslam::synth::detail
