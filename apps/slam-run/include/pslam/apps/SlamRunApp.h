#pragma once
// The slam-run application: rawlog + ini (+ --set overrides) + seed + frame range -> the outputs of DESIGN.md §4
// in an output folder, produced by driving the System façade (libs/system) frame by frame:
//   trajectory.txt  every tracked frame (TUM, camera-to-world), System::trajectory()
//   keyframes.txt   keyframe poses (TUM), System::keyFrameTrajectory()
//   map.slammap     the map (System::saveMap)
//   depths.txt      map-point depths per keyframe observation, for `slam-eval --depths` (DR, eq. 2.104)
//   report.json     System::report() + the run's inputs (rawlog, config file, overrides, frame range)
// Every file is written atomically; the four are prepared before the run (none may be an input or replace a
// folder: pslam::OutputSet) and committed together at its end, so a failed run writes none of them.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pslam::apps {

struct SlamRunOptions {
  std::filesystem::path config;
  std::vector<std::string> overrides;  ///< "Section.key=value" applied over the ini (--set)
  std::filesystem::path rawlog;
  std::filesystem::path outDir;
  std::uint32_t seed = 0;
  std::size_t first = 0;        ///< first frame index (0-based, inclusive)
  long long last = -1;          ///< last frame index (inclusive), < 0 = to the end
  bool threaded = false;        ///< overrides [System] threaded when set
  bool progress = true;
};

struct SlamRunSummary {
  std::size_t framesRead = 0, framesProcessed = 0, framesTracked = 0, framesLost = 0, relocalizations = 0;
  long long initializedAtFrame = -1;
  std::size_t keyFrames = 0, mapPoints = 0, resets = 0;
  double wallSeconds = 0, cpuSeconds = 0;
  bool initialized() const { return initializedAtFrame >= 0; }
  nlohmann::json toJson() const;
  std::string toText() const;
};

class SlamRunApp {
 public:
  explicit SlamRunApp(SlamRunOptions options);
  /// Throws pslam::Error naming the file (and frame) for bad input: missing/invalid config or override,
  /// rawlog without CAMERA, missing intrinsics, images that change size.
  SlamRunSummary run();

 private:
  SlamRunOptions options_;
};

}  // namespace pslam::apps
