#pragma once
// The books of a SLAM run (doc/architecture.md, "Outputs"): the poses of the tracked frames relative to their
// reference keyframes (what trajectory() resolves), the counters, the per-frame reports, one entry per mapped
// keyframe, the loops and the global BAs, and the stage timings. The System writes them; the apps read them
// (RunReport.h makes report.json of them). Every call takes the record's own lock, except the timings, which
// each thread writes without one (read them once the run is finished).
#include <cstddef>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/map/Map.h"
#include "pslam/system/System.h"

namespace pslam::system {

/// Counters of the run (RunSummary without the map's counts).
struct RunCounters {
  std::size_t frames = 0, tracked = 0, lost = 0, relocalizations = 0, relocalizationsWithdrawn = 0, resets = 0;
  std::size_t loopsClosed = 0;
  std::size_t loopsWithdrawn = 0;  ///< verified loops whose correction failed the outlier test (map restored)
  std::size_t manhattanFrames = 0, manhattanTracked = 0, fallbackTracked = 0;
  long long initializedAtFrame = -1;
};

/// What the System records about one tracked frame.
struct FrameEntry {
  FrameResult result;       ///< what track() returned
  nlohmann::json report;    ///< the tracker's frame report (report.json "frames")
  bool manhattanFrame = false;  ///< the frame had a valid Manhattan frame
  /// A new map: its reference frame (timestamp, T_cam_world) gets a pose retroactively, relative to `root`.
  std::optional<std::pair<double, Eigen::Isometry3d>> initialReference;
  map::KeyFrameId root = map::kNoKeyFrame;
  /// The frame's pose relative to its reference keyframe (identity and kNoKeyFrame when it has none), and as tracked.
  map::KeyFrameId reference = map::kNoKeyFrame;
  Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
};

class RunRecord {
 public:
  // ---- written by the System ----
  /// Books one frame (the counters, the trajectory, the frame reports; a withdrawn relocalization takes back the
  /// poses of its frames).
  void addFrame(const FrameEntry& frame);
  /// A new map generation: the poses of earlier maps are never mixed with the new one.
  void newGeneration();
  int generation() const;
  /// System::reset(): the next map's initialization counts as the first.
  void forgetInitialization();
  /// Loop closing moved keyframes: the frames follow their reference keyframe's change of scale.
  void rescaleFrames(const std::map<map::KeyFrameId, double>& keyFrameScales);
  /// One mapped keyframe (the entry of the mapping log), a loop-closing report with candidates, a loop closed or
  /// withdrawn, a global BA written back.
  void addMappedKeyFrame(nlohmann::json entry);
  void addLoop(nlohmann::json entry, bool closed, bool withdrawn);
  void addGlobalBundleAdjustment(nlohmann::json entry);
  /// Stage timings of tracking (the tracking thread) and of mapping (the mapping thread).
  StageTimings& trackingTimings() { return trackingTimings_; }
  StageTimings& mappingTimings() { return mappingTimings_; }

  // ---- read by anyone ----
  /// The frames with a pose, each resolved against the current pose of its reference keyframe in `map`
  /// (System::trajectory), in timestamp order.
  CameraTrajectory trajectory(const map::Map& map) const;
  RunCounters counters() const;
  nlohmann::json frames() const;       ///< one report per frame
  nlohmann::json mappingLog() const;   ///< one entry per mapped keyframe
  nlohmann::json loops() const;        ///< loop-closing reports of keyframes with candidates
  nlohmann::json globalBundleAdjustments() const;  ///< threaded mode: each loop's global BA written back
  /// Tracking and mapping stages together.
  StageTimings timings() const;

 private:
  struct TrackedPose {
    double timestamp = 0.0;
    int generation = 0;
    map::KeyFrameId reference = map::kNoKeyFrame;
    Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();    ///< relative to the reference keyframe
    Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();  ///< as tracked (reference gone / unknown)
  };
  /// A member's value, read under the lock.
  template <class T>
  T copyOf(const T& member) const;
  mutable std::mutex mutex_;
  std::vector<TrackedPose> poses_;  ///< of the current generation
  int generation_ = 0;
  RunCounters counters_;
  nlohmann::json frames_ = nlohmann::json::array();
  nlohmann::json mappingLog_ = nlohmann::json::array();
  nlohmann::json loops_ = nlohmann::json::array();
  nlohmann::json globalBa_ = nlohmann::json::array();
  StageTimings trackingTimings_, mappingTimings_;
};

}  // namespace pslam::system
