#pragma once
// The System façade: the one entry point of the SLAM core (DESIGN.md §1). Apps (slam-run, bench-slam), the
// end-to-end tests and users who embed the library drive SLAM only through this class:
//
//   pslam::system::System slam(pslam::system::loadSlamParams("config/slam/kitti.ini"));
//   pslam::datasets::RawlogReader reader("kitti_00.rawlog");
//   for (pslam::datasets::Frame f; reader.next(f);) {
//     const auto r = slam.track(f);
//     if (r.pose) std::cout << r.pose->asString() << "\n";   // T_world_cam as mrpt::poses::CPose3D
//   }
//   slam.saveMap("map.slammap");
//   pslam::writeTumTrajectory("trajectory.txt", slam.trajectory());
//
// Modes (thesis §3.5.2): sequential (default; every keyframe is mapped to completion before track() returns,
// so a fixed seed gives bit-identical results) or threaded (local mapping in a second thread; live use).
// The public surface speaks MRPT pose types (CPose3D) and the rawlog frame type; Eigen stays inside.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <mrpt/poses/CPose3D.h>
#include <nlohmann/json.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"
#include "pslam/system/SlamParams.h"
#include "pslam/tracking/Tracker.h"

namespace pslam::system {

struct SystemOptions {
  std::uint32_t seed = 0;  ///< seed of every random process (RANSAC, ...)
  /// Overrides [System] threaded when set: local mapping in a second thread (not bit-deterministic).
  std::optional<bool> threaded;
  /// Camera of every frame. Unset: taken from the first frame's CAMERA intrinsics (then checked against the
  /// image size); every later frame must have the same image size.
  std::optional<geometry::PinholeCamera> camera;
};

/// What track() tells about one frame.
struct TrackResult {
  tracking::FrameStatus status = tracking::FrameStatus::Initializing;
  /// T_world_cam of the frame when it has a pose (tracked, relocalized, or the initializing frame), else empty.
  std::optional<mrpt::poses::CPose3D> pose;
  bool keyFrame = false;     ///< the frame became a keyframe
  bool mapWasReset = false;  ///< the tracker discarded the map (lost too early) and re-initializes
  /// > 0: this frame was lost right after a relocalization ([Tracking] relocalizationCheckFrames), so the poses
  /// returned for the previous retractedFrames frames are withdrawn (trajectory(), summary and report agree).
  std::size_t retractedFrames = 0;
  tracking::FrameReport report;  ///< per-frame counts, method, message (report.json "frames")
};

class System {
 public:
  /// Checks `params` (throws pslam::Error naming the section and key). The map, tracker and mapper are
  /// created with the camera: now when options.camera is set, else on the first frame.
  explicit System(SlamParams params, SystemOptions options = {});
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  /// The rawlog channels a System with `params` uses besides CAMERA, so that a reader decodes no more
  /// (datasets::RawlogChannels): SEMANTIC for the point model's semantic prior ([PointModel] semantic), NORMALS for
  /// the Manhattan path ([Manhattan] enabled), DEPTH never. track() ignores the others.
  static datasets::RawlogChannels channelsUsed(const SlamParams& params);

  /// Tracks one rawlog frame (all its channels: CAMERA, optional DEPTH, SEMANTIC, NORMALS) and, in sequential
  /// mode, maps the keyframes it created. Throws pslam::Error naming the frame for an empty image, missing or
  /// invalid intrinsics, or an image size other than the camera's.
  TrackResult track(const datasets::Frame& frame);

  /// Threaded mode: waits until local mapping has processed every queued keyframe and a loop's global BA is
  /// written back. No-op when sequential.
  void finish();
  /// Threaded mode: blocks until the mapping thread has mapped every queued keyframe; a loop's global BA, on its
  /// own thread, may still run (finish() waits for it too). For a caller that wants tracking not to run ahead of
  /// local mapping (tests, step-by-step use). Sequential mode: returns at once.
  void waitForLocalMapping();

  /// Every frame that had a pose since the last map (re)initialization, in timestamp order, camera-to-world,
  /// each resolved against the current pose of its reference keyframe (ORB-SLAM's SaveTrajectoryTUM: frames
  /// follow the refined keyframes; a culled reference keyframe is followed through its spanning-tree parent).
  /// Threaded mode: call finish() first for the final poses.
  Trajectory trajectory() const;
  /// The keyframes of the map, camera-to-world, by keyframe id.
  Trajectory keyFrameTrajectory() const;

  /// Writes the map (map::saveMap; atomic). Throws pslam::Error naming the path.
  void saveMap(const std::filesystem::path& path) const;
  /// Replaces the map by a saved one and sets the camera to the map's. Tracking then relocalizes against it
  /// (the next frames are "lost" until relocalization succeeds). Throws pslam::Error naming the file for a
  /// missing, corrupt or foreign map, or a map whose camera differs from options.camera.
  void loadMap(const std::filesystem::path& path);
  /// The same with a map already in memory (e.g. read with map::loadMap to check it before the run); `source`
  /// names it in errors (a file name). Throws pslam::Error for a map without keyframes or with another camera.
  void setMap(map::Map map, const std::string& source);

  /// Localization only (stella_vslam's disable_mapping_module): false = no new keyframes are mapped, the map
  /// is not changed by tracking; true (default) = full SLAM.
  void setMappingEnabled(bool enabled);
  bool mappingEnabled() const { return mappingEnabled_; }
  /// places::Vocabulary::fingerprint() of [Places] vocabulary, empty without one. With mapping on, saved maps
  /// and mapSnapshot() record it (map::Map::vocabulary); in localization mode the loaded map keeps its record.
  const std::string& vocabularyFingerprint() const { return vocabularyFingerprint_; }

  /// Discards the map and the trajectory; the next frames initialize a new map.
  void reset();

  /// A consistent copy of the map (taken under the map lock: safe while mapping runs in threaded mode).
  map::Map mapSnapshot() const;
  bool initialized() const;
  bool hasCamera() const { return camera_.has_value(); }
  const geometry::PinholeCamera& camera() const;
  const SlamParams& params() const { return params_; }
  std::uint32_t seed() const { return options_.seed; }
  bool threaded() const { return threaded_; }

  /// Tracking stages (extraction, matching, pose_optimization, local_map, ...) and mapping stages
  /// (triangulation, local_ba, fusion) per call, in ms.
  StageTimings timings() const;
  /// One entry per mapped keyframe: {generation, keyframe, new_points, culled_points, culled_keyframes, ...}.
  nlohmann::json mappingLog() const;
  /// Loop closing ([LoopClosing] enabled): one entry per keyframe that had loop candidates: candidates, the
  /// consistent ones, each verification's matches / Sim(3) inliers / loop matches, and for a closed loop the
  /// matched keyframe, scale, correction and fused points.
  nlohmann::json loops() const;
  /// Counters of the run so far (frames, tracked, lost, relocalizations, initialized_at_frame, keyframes,
  /// map points, resets).
  nlohmann::json summary() const;
  /// The run report of DESIGN.md §4 without the app's fields: effective config, seed, mode, camera, timings,
  /// summary, per-frame reports, mapping log.
  nlohmann::json report() const;

 private:
  /// Makes map, tracker and mapper for `camera` (with the current mapping mode).
  void start(const geometry::PinholeCamera& camera);
  struct Impl;
  SlamParams params_;
  SystemOptions options_;
  bool threaded_ = false;
  bool mappingEnabled_ = true;
  std::optional<geometry::PinholeCamera> camera_;
  std::shared_ptr<const places::Vocabulary> vocabulary_;  ///< [Places] vocabulary, loaded by the constructor
  std::string vocabularyFingerprint_;
  std::unique_ptr<Impl> impl_;
};

/// Process CPU time (all threads) in seconds.
double processCpuSeconds();

}  // namespace pslam::system
