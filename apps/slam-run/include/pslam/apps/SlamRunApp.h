#pragma once
// The slam-run application: rawlog + ini (+ --set overrides) + seed + frame range -> the outputs of doc/architecture.md, "Data contracts"
// in an output folder, produced by driving the System façade (libs/system) frame by frame:
//   trajectory.txt  every tracked frame (TUM, camera-to-world), System::trajectory()
//   keyframes.txt   keyframe poses (TUM), System::keyFrameTrajectory()
//   map.slammap     the map (System::saveMap)
//   depths.txt      map-point depths per keyframe observation, for `slam-eval --depths` (DR, eq. 2.104)
//   report.json     System::report() + the run's inputs (rawlog, config file, overrides, frame range)
// Every file is written atomically; the four are prepared before the run (none may be an input or replace a
// folder: pslam::OutputSet) and committed together at its end, so a failed run writes none of them.
//
// Map reuse (doc/maps.md): with `mapIn` the run starts from a saved map instead of initializing one: the map is
// read and checked before the first frame (missing, corrupt, other format version: an error naming the file), its
// camera must equal the rawlog's (first frame in range), and tracking relocalizes against it. Mapping then goes
// on (new keyframes extend the loaded map) unless `localization` is set: the map stays fixed (not even the
// points' counters change) and every frame is only tracked or relocalized; map.slammap is then the input map.
// report.json gives each frame `localized` (the frame has a pose in the map) and the summary counts them.
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
  /// Hand each frame to SLAM no earlier than its timestamp says (relative to the first processed frame), as a live
  /// camera does; a frame whose time has passed goes at once (none is dropped). For the threaded mode's live use.
  bool realtime = false;
  /// realtime: the longest wait for one frame [s]. A longer gap between stamps (a clock jump, a pause in the
  /// recording) is cut to this, counted and named in a warning: a stamp 1e6 s ahead must not stall the run.
  double realtimeMaxWait = 5.0;
  /// Frames whose stamps go back or repeat are read in stamp order, with a warning (default: an error).
  bool sortStamps = false;
  bool progress = true;
  std::filesystem::path mapIn;  ///< start from this saved map (empty: initialize a new one)
  bool localization = false;    ///< with mapIn: the map stays fixed, frames are only localized in it
};

struct SlamRunSummary {
  std::size_t framesRead = 0, framesProcessed = 0, framesTracked = 0, framesLost = 0, relocalizations = 0;
  long long initializedAtFrame = -1;
  std::size_t keyFrames = 0, mapPoints = 0, resets = 0;
  double wallSeconds = 0, cpuSeconds = 0;
  /// The frames alone: from the first frame handed to the System to the end of its mapping (System::finish), wall
  /// and process CPU (their ratio is how much of the machine tracking and mapping use), and the writing of the
  /// outputs after it (trajectories, map, depths), wall.
  double framesWallSeconds = 0, framesCpuSeconds = 0, outputsWallSeconds = 0;
  /// realtime: frames handed over after their time (tracking fell behind the camera) and the largest delay.
  std::size_t framesLate = 0;
  double maxLatenessSeconds = 0.0;
  /// realtime: waits cut to realtimeMaxWait, and the stamp gap of the first of them.
  std::size_t waitsCut = 0;
  /// Warnings for the user, one line each naming the rawlog (realtime waits cut, frames read in stamp order).
  std::vector<std::string> warnings;
  /// Map reuse: the run started from a saved map (of loadedKeyFrames keyframes), localization only or not.
  bool mapLoaded = false, localization = false;
  std::size_t loadedKeyFrames = 0, loadedMapPoints = 0;
  std::size_t framesLocalized = 0;        ///< processed frames with a pose in the map
  long long firstLocalizedFrame = -1;     ///< index of the first of them (-1: none)
  /// Non-empty when the loaded map records another vocabulary than this run's (it still works: the keyframes'
  /// BoW vectors are recomputed with this run's, but place recognition is not what it was).
  std::string vocabularyWarning;
  bool initialized() const { return initializedAtFrame >= 0; }
  /// Has the run produced a map to track in: initialized, or started from a loaded map.
  bool hasMap() const { return initialized() || mapLoaded; }
  nlohmann::json toJson() const;
  std::string toText() const;
};

class SlamRunApp {
 public:
  explicit SlamRunApp(SlamRunOptions options);
  /// Throws pslam::Error naming the file (and frame) for bad input: missing/invalid config or override,
  /// rawlog without CAMERA, missing intrinsics, images that change size; --localization without a map; a
  /// missing, corrupt or foreign map, or one whose camera differs from the rawlog's.
  SlamRunSummary run();

 private:
  SlamRunOptions options_;
};

}  // namespace pslam::apps
