// Per-step timings of LocalMapper::processKeyFrame on a synthetic lateral track (not a test): the tracker
// part links every keypoint of an already-mapped scene point, local mapping does the rest.
//   bench_local_mapping [--points N] [--keyframes K] [--model heuristic|masking|probabilistic]
#include <cstdio>
#include <iostream>
#include <random>

#include <CLI/CLI.hpp>

#include "SyntheticScene.h"
#include "pslam/core/Error.h"
#include "pslam/mapping/LocalMapper.h"

using namespace pslam;
using namespace pslam::mapping::testing;

int main(int argc, char** argv) {
  CLI::App app{"Per-step timings of local mapping on a synthetic scene"};
  int numPoints = 3000, numKeyFrames = 12;
  std::string modelName = "heuristic";
  app.add_option("--points", numPoints, "scene points (about half are seen per keyframe)");
  app.add_option("--keyframes", numKeyFrames, "keyframes along the track (0.25 m apart)");
  app.add_option("--model", modelName, "map-point model: heuristic | masking | probabilistic");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "bench_local_mapping: error: " << e.what() << "\n";
    return 1;
  }
  try {
    if (numPoints < 100 || numKeyFrames < 3) throw pslam::Error("--points must be >= 100 and --keyframes >= 3");
    mapping::LocalMappingParams params;
    params.pointModel.policy.model = landmarks::parseMapPointModel(modelName);
    params.ba.numThreads = 1;
    std::mt19937 rng(31);
    Scene s = makeScene(numPoints, 17);
    map::Map map;
    addKeyFrame(map, s, 0, rng);
    addKeyFrame(map, s, 1, rng);
    const auto initial = addTruePoints(map, s, 0, numPoints / 5, 0, {0, 1});
    mapping::LocalMapper mapper(map, params);
    std::printf("%4s %6s %6s %5s %5s %5s %5s %8s %8s %8s %8s %8s %8s %8s %9s\n", "kf", "kps", "points", "new", "fused",
                "culP", "culK", "process", "cullPts", "triang", "fusion", "localBA", "cullKF", "total", "BA rms px");
    for (int slot = 0; slot < numKeyFrames; ++slot) {
      // The first two keyframes come with the initial map (the tracker's two-view initialization).
      const map::KeyFrameId id = slot < 2 ? s.keyframes[slot] : addKeyFrame(map, s, slot, rng);
      if (slot >= 2) trackKeyFrame(map, s, slot);
      const mapping::LocalMappingReport r = mapper.processKeyFrame(id, slot == 1 ? initial : std::vector<map::MapPointId>{});
      std::printf("%4d %6zu %6zu %5d %5d %5d %5d %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %4.2f>%4.2f\n", slot,
                  map.hasKeyFrame(id) ? map.keyFrame(id).numKeypoints() : 0, map.numMapPoints(), r.newPoints,
                  r.fusedPoints, r.culledPoints, r.culledKeyFrames, r.processMs, r.cullPointsMs, r.triangulationMs,
                  r.fusionMs, r.localBaMs, r.cullKeyFramesMs, r.totalMs, r.baInitialRmsPixels, r.baFinalRmsPixels);
      learnMapPoints(map, s);
    }
    map.checkInvariants("bench_local_mapping");
    std::printf("keyframes %zu, map points %zu\n", map.numKeyFrames(), map.numMapPoints());
  } catch (const std::exception& e) {
    std::cerr << "bench_local_mapping: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
