#pragma once
// Scenario presets: a scene, a camera trajectory and the recording conventions of one kind of sequence.
//   room       textured Manhattan room, handheld-like loop with fast turns (ICL-NUIM-like), 30 Hz
//   lowtexture white Manhattan structure in a hall, seen near then far (TUM structure_notexture-like), 30 Hz
//   street     street canyon with parked cars, pedestrians and stop-and-go traffic at a red light, 10 Hz
//   corridor   70 m corridor loop around an inner block, returns to its start (HRBB4-like), 15 Hz
//   jam        stop-and-go motorway jam between homogeneous vegetation, textured trucks, parked cars (Virtual
//              KITTI 20-like), 10 Hz; jam-static is the same without the moving traffic (control)
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "pslam/synth/Scene.h"

namespace pslam::synth {

struct ScenarioInfo {
  std::string name;
  std::string description;
  double fps = 30.0;
  double depthUnit = 1.0 / 5000.0;  ///< metres per u16 depth unit
  double focalAt640 = 525.0;        ///< default fx = fy for a 640-pixel-wide image (scaled with the width)
  int defaultFrames = 300;
  /// Camera paths through the same scene: variant 0 is the preset's path, 1 .. pathVariants-1 other paths
  /// (same seed = same scene, textures and objects; only the camera differs).
  int pathVariants = 1;
};

struct Scenario {
  ScenarioInfo info;
  Scene scene;
  /// Camera pose (T_world_cam, camera x right, y down, z forward) at scenario time t (seconds from 0).
  std::function<Eigen::Isometry3d(double)> T_world_cam;
};

/// Names of the presets, the first one is the default.
const std::vector<std::string>& scenarioNames();
/// Info of a preset without building it. Throws pslam::Error for an unknown name (listing the known ones).
ScenarioInfo scenarioInfo(const std::string& name);
/// Builds a preset. `duration` (seconds) lets open-ended scenes (street, jam) extend far enough; textures,
/// placements of parked cars and pedestrians, traffic and jitter derive from `seed`. `pathVariant` chooses
/// another camera path through the same scene (map reuse: build a map on one path, localize on another):
///   room      1 = the loop shrunk by 15 % towards the room centre and 0.15 m lower; 2 = the loop walked backwards
///   corridor  1 = starts 1 m further along the loop, 0.35 m right of the centre line, camera 0.15 m higher;
///             2 = walks back along the first straight (starts 21 m along the loop, clockwise)
/// Variant 0 is the preset's path, bit for bit. Throws pslam::Error naming the scenario and its variants for a
/// variant it does not have.
Scenario makeScenario(const std::string& name, std::uint32_t seed, double duration, int pathVariant = 0);
/// Throws pslam::Error unless scenario `name` has path variant `pathVariant` (the message lists the ones it has).
void requirePathVariant(const std::string& name, int pathVariant);

}  // namespace pslam::synth
