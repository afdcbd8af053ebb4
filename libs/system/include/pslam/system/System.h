#pragma once
// The System façade: the one entry point of the SLAM core (doc/api.md, doc/architecture.md). Apps (slam-run,
// bench-slam), the end-to-end tests and programs that embed the library drive SLAM only through this class:
//
//   pslam::system::System slam("config/slam/kitti.ini");               // or System(SlamParams, SystemOptions)
//   for (...) {                                                         // images from anywhere ...
//     const auto r = slam.track(image, timestamp);                      // (needs SystemOptions::camera)
//     if (r.pose) std::cout << r.pose->asString() << "\n";               // T_world_cam, mrpt::poses::CPose3D
//   }
//   for (pslam::datasets::Frame f; reader.next(f);) slam.track(f);     // ... or a rawlog's frames
//   slam.saveMap("map.slammap");
//   slam.saveTrajectory("trajectory.txt");
//
// Modes (thesis §3.5.2): sequential (default; every keyframe is mapped to completion before track() returns, so a
// fixed seed gives bit-identical results) or threaded (local mapping in a second thread; live use).
// This header speaks MRPT poses, OpenCV images and the project's camera type only; the JSON of a run is in
// RunReport.h, the parameters in SlamParams.h.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/poses/CPose3D.h>
#include <opencv2/core.hpp>

#include "pslam/core/Trajectory.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam {
class StageTimings;
namespace datasets {
struct Frame;
struct RawlogChannels;
}  // namespace datasets
namespace map {
class Map;
}  // namespace map
namespace tracking {
class LandmarkModule;
}  // namespace tracking
}  // namespace pslam

namespace pslam::system {

struct SlamParams;
class RunRecord;

struct SystemOptions {
  std::uint32_t seed = 0;  ///< seed of every random process (RANSAC, ...)
  /// Overrides [System] threaded when set: local mapping in a second thread (not bit-deterministic).
  std::optional<bool> threaded;
  /// Camera of every frame. Unset: taken from the first rawlog frame's CAMERA intrinsics (then checked against the
  /// image size); track(image, timestamp) needs it. Every later frame must have the same image size.
  std::optional<geometry::PinholeCamera> camera;
  /// Landmark modules of the caller's own (tracking::LandmarkModule, doc/architecture.md "The plug-in seam"), each
  /// made for the run's camera and registered after the shipped ones ([DirectFeatures], [Lines]).
  using ModuleFactory = std::function<std::shared_ptr<tracking::LandmarkModule>(const geometry::PinholeCamera&)>;
  std::vector<ModuleFactory> modules;
};

/// Where tracking stands after a frame.
enum class TrackingState { Initializing, Tracking, Lost, Relocalized };
/// "initializing", "tracking", "lost", "relocalized" (report.json).
const char* toString(TrackingState state);

/// What track() tells about one frame.
struct FrameResult {
  std::size_t index = 0;  ///< the frame's index (the rawlog's, or the count of frames so far)
  double timestamp = 0.0;
  TrackingState state = TrackingState::Initializing;
  /// T_world_cam of the frame when it has a pose (tracked, relocalized, or the initializing frame), else empty.
  std::optional<mrpt::poses::CPose3D> pose;
  bool keyFrame = false;     ///< the frame became a keyframe
  bool mapWasReset = false;  ///< the tracker discarded the map (lost too early) and re-initializes
  /// > 0: this frame was lost right after a relocalization ([Tracking] relocalizationCheckFrames), so the poses
  /// returned for the previous retractedFrames frames are withdrawn (trajectory(), summary and report agree).
  std::size_t retractedFrames = 0;
  std::string method;  ///< initializer / motion / reference / relocalization / manhattan
  int matches = 0;     ///< after the motion / reference / relocalization search
  int inliers = 0;     ///< after local-map tracking
  /// The Manhattan path (§4.4): "manhattan" (its pose was used), "fallback" (6-DoF tracking), "none" (disabled).
  std::string manhattanMode = "none";
  bool normals = false;  ///< the frame had a NORMALS image (Manhattan path enabled)
  std::size_t keyFrames = 0, mapPoints = 0;  ///< in the map after the frame
  std::string message;
};

/// One pose of a trajectory: T_world_cam at a timestamp (seconds).
struct StampedCameraPose {
  double timestamp = 0.0;
  mrpt::poses::CPose3D pose;
};
using CameraTrajectory = std::vector<StampedCameraPose>;
/// The same poses as the project's TUM trajectory type (pslam::writeTumTrajectory writes it).
Trajectory toTrajectory(const CameraTrajectory& trajectory);

/// Counters of a run so far.
struct RunSummary {
  std::size_t framesProcessed = 0, framesTracked = 0, framesLost = 0;
  std::size_t relocalizations = 0, relocalizationsWithdrawn = 0, resets = 0;
  std::optional<std::size_t> initializedAtFrame;  ///< the frame of the last (re)initialization
  std::size_t keyFrames = 0, mapPoints = 0;
  std::size_t loopsClosed = 0, loopsWithdrawn = 0;
  std::size_t manhattanFrames = 0;   ///< frames with a valid Manhattan frame
  std::size_t manhattanTracked = 0;  ///< ... tracked by the Manhattan path
  std::size_t fallbackTracked = 0;   ///< ... tracked by the 6-DoF fallback
  /// The landmark modules' counters ("direct_points", "direct_active", "lines", ...), when they are enabled.
  std::map<std::string, std::size_t> landmarks;
};

class System {
 public:
  /// Checks `params` (throws pslam::Error naming the section and key) and loads the vocabulary. The map, tracker
  /// and mapper are created with the camera: now when options.camera is set, else on the first frame.
  explicit System(const SlamParams& params, SystemOptions options = {});
  /// The same from a config file (paths in it relative to the file) with `overrides` "Section.key=value".
  explicit System(const std::filesystem::path& config, const std::vector<std::string>& overrides = {},
                  SystemOptions options = {});
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  /// Tracks one image (grey CV_8UC1 or BGR CV_8UC3, the size of SystemOptions::camera, which must be set) taken at
  /// `timestamp` seconds; optional SEMANTIC (CV_8UC3, P(static, dynamic, invalid) x 255) and NORMALS (CV_8UC3)
  /// images of the same size. In sequential mode the keyframes it creates are mapped before it returns. Throws
  /// pslam::Error for an empty image, a wrong size or type, or a non-finite timestamp.
  FrameResult track(const cv::Mat& image, double timestamp, const cv::Mat& semantic = cv::Mat(),
                    const cv::Mat& normals = cv::Mat());
  /// The same for one rawlog frame (CAMERA with its intrinsics, optional SEMANTIC, NORMALS). Throws pslam::Error
  /// naming the frame for an empty image, missing or invalid intrinsics, or an image size other than the camera's.
  FrameResult track(const datasets::Frame& frame);

  /// The rawlog channels a System with `params` uses besides CAMERA, so that a reader decodes no more: SEMANTIC for
  /// the point model's semantic prior ([PointModel] semantic), NORMALS for the Manhattan path ([Manhattan]
  /// enabled), DEPTH never. track() ignores the others.
  static datasets::RawlogChannels channelsUsed(const SlamParams& params);

  /// Threaded mode: waits until local mapping has processed every queued keyframe and a loop's global BA is
  /// written back. No-op when sequential.
  void finish();
  /// Threaded mode: blocks until the mapping thread has mapped every queued keyframe; a loop's global BA, on its
  /// own thread, may still run (finish() waits for it too). Sequential mode: returns at once.
  void waitForLocalMapping();

  /// Every frame that had a pose since the last map (re)initialization, in timestamp order, T_world_cam, each
  /// resolved against the current pose of its reference keyframe (ORB-SLAM's SaveTrajectoryTUM: frames follow the
  /// refined keyframes; a culled reference keyframe is followed through its spanning-tree parent). Threaded mode:
  /// call finish() first for the final poses.
  CameraTrajectory trajectory() const;
  /// The keyframes of the map, T_world_cam, by keyframe id.
  CameraTrajectory keyFrameTrajectory() const;
  /// trajectory() / keyFrameTrajectory() as a TUM file (atomic write). Throws pslam::Error naming the path.
  void saveTrajectory(const std::filesystem::path& path) const;
  void saveKeyFrameTrajectory(const std::filesystem::path& path) const;

  /// Writes the map (map::saveMap; atomic). Throws pslam::Error naming the path.
  void saveMap(const std::filesystem::path& path) const;
  /// Replaces the map by a saved one and sets the camera to the map's. Tracking then relocalizes against it (the
  /// next frames are "lost" until relocalization succeeds). Throws pslam::Error naming the file for a missing,
  /// corrupt or foreign map, or a map whose camera differs from options.camera.
  void loadMap(const std::filesystem::path& path);
  /// The same with a map already in memory (map::loadMap, e.g. to check it before the run); `source` names it in
  /// errors (a file name). Throws pslam::Error for a map without keyframes or with another camera.
  void setMap(map::Map map, const std::string& source);
  /// A consistent copy of the map (taken under the map lock: safe while mapping runs in threaded mode), with the
  /// stores of the landmark modules and the loop edges as its extensions (what saveMap writes).
  map::Map mapSnapshot() const;

  /// Localization only (stella_vslam's disable_mapping_module): false = no new keyframes are mapped, the map is not
  /// changed by tracking; true (default) = full SLAM.
  void setMappingEnabled(bool enabled);
  bool mappingEnabled() const { return mappingEnabled_; }
  /// places::Vocabulary::fingerprint() of [Places] vocabulary, empty without one. With mapping on, saved maps
  /// record it (map::Map::vocabulary); in localization mode the loaded map keeps its record.
  const std::string& vocabularyFingerprint() const;

  /// Discards the map and the trajectory; the next frames initialize a new map.
  void reset();

  bool initialized() const;
  bool hasCamera() const { return camera_.has_value(); }
  const geometry::PinholeCamera& camera() const;
  const SlamParams& params() const;
  std::uint32_t seed() const { return options_.seed; }
  bool threaded() const { return threaded_; }

  /// Counters of the run so far.
  RunSummary summary() const;
  /// Tracking stages (extraction, matching, pose_optimization, local_map, ...) and mapping stages (triangulation,
  /// local_ba, fusion) per call, in ms.
  StageTimings timings() const;
  /// The books of the run: per-frame reports, mapping log, loops (RunRecord.h; its JSON in RunReport.h).
  const RunRecord& record() const;
  /// The name of the point-use policy ([PointModel] model), empty before the first frame.
  std::string pointPolicyName() const;

 private:
  /// Makes map, tracker, mapper and modules for `camera` (with the current mapping mode).
  void start(const geometry::PinholeCamera& camera);
  FrameResult trackInput(const datasets::Frame& frame);
  struct Impl;
  struct Setup;
  SystemOptions options_;
  bool threaded_ = false;
  bool mappingEnabled_ = true;
  std::optional<geometry::PinholeCamera> camera_;
  std::unique_ptr<Setup> setup_;  ///< the parameters and the vocabulary, from the constructor
  std::unique_ptr<Impl> impl_;    ///< the parts, from the camera on
};

/// Process CPU time (all threads) in seconds.
double processCpuSeconds();

}  // namespace pslam::system
