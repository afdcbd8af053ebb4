#include "pslam/system/RunRecord.h"

#include <algorithm>

#include "pslam/core/Trajectory.h"

namespace pslam::system {

void RunRecord::addFrame(const FrameEntry& f) {
  std::lock_guard<std::mutex> lock(mutex_);
  const FrameResult& r = f.result;
  RunCounters& c = counters_;
  ++c.frames;
  if (r.mapWasReset) ++c.resets;
  if (f.initialReference) {
    if (c.initializedAtFrame < 0 || r.mapWasReset) c.initializedAtFrame = static_cast<long long>(r.index);
    poses_.push_back({f.initialReference->first, generation_, f.root, Eigen::Isometry3d::Identity(),
                      f.initialReference->second});
  }
  if (r.retractedFrames > 0) {
    // The tracker withdrew a relocalization (lost again right after it): its frames lose their poses, in the
    // trajectory, the counters and report.json alike. They are the last frames with a pose, none a keyframe.
    const std::size_t n = std::min({r.retractedFrames, poses_.size(), frames_.size()});
    poses_.erase(poses_.end() - static_cast<std::ptrdiff_t>(n), poses_.end());
    for (std::size_t k = frames_.size() - n; k < frames_.size(); ++k) {
      frames_[k]["status"] = toString(TrackingState::Lost);
      frames_[k]["relocalization_withdrawn"] = true;
    }
    c.tracked -= n;
    c.lost += n;
    if (c.relocalizations > 0) --c.relocalizations;
    ++c.relocalizationsWithdrawn;
  }
  const bool hasPose = r.pose.has_value();
  if (r.state == TrackingState::Lost) ++c.lost;
  if (f.manhattanFrame) ++c.manhattanFrames;
  if (hasPose && r.manhattanMode == "manhattan") ++c.manhattanTracked;
  if (hasPose && r.manhattanMode == "fallback") ++c.fallbackTracked;
  if (r.state == TrackingState::Relocalized) ++c.relocalizations;
  if (hasPose) {
    ++c.tracked;
    poses_.push_back({r.timestamp, generation_, f.reference, f.T_cam_ref, f.T_cam_world});
  }
  frames_.push_back(f.report);
}

void RunRecord::newGeneration() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++generation_;
  poses_.clear();
}

int RunRecord::generation() const { return copyOf(generation_); }

void RunRecord::forgetInitialization() {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.initializedAtFrame = -1;
}

void RunRecord::rescaleFrames(const std::map<map::KeyFrameId, double>& keyFrameScales) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (TrackedPose& p : poses_) {
    const auto sc = keyFrameScales.find(p.reference);
    if (p.generation == generation_ && sc != keyFrameScales.end()) p.T_cam_ref.translation() /= sc->second;
  }
}

void RunRecord::addMappedKeyFrame(nlohmann::json entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  mappingLog_.push_back(std::move(entry));
}

void RunRecord::addLoop(nlohmann::json entry, bool closed, bool withdrawn) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!entry.is_null()) loops_.push_back(std::move(entry));
  if (closed) ++counters_.loopsClosed;
  if (withdrawn) ++counters_.loopsWithdrawn;
}

void RunRecord::addGlobalBundleAdjustment(nlohmann::json entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  globalBa_.push_back(std::move(entry));
}

CameraTrajectory RunRecord::trajectory(const map::Map& map) const {
  std::lock_guard<std::mutex> lock(mutex_);
  // As ORB-SLAM's SaveTrajectoryTUM: each frame at its pose relative to its reference keyframe, which may have been
  // culled since (its pose then follows its spanning-tree parent).
  CameraTrajectory out;
  out.reserve(poses_.size());
  for (const TrackedPose& p : poses_) {
    Eigen::Isometry3d T_cam_world = p.T_cam_world;
    if (p.reference != map::kNoKeyFrame)
      if (const auto T_ref_world = map.keyFramePoseIncludingErased(p.reference)) T_cam_world = p.T_cam_ref * *T_ref_world;
    out.push_back({p.timestamp, toCPose3D(T_cam_world.inverse())});
  }
  std::stable_sort(out.begin(), out.end(), [](const StampedCameraPose& a, const StampedCameraPose& b) {
    return a.timestamp < b.timestamp;
  });
  return out;
}

template <class T>
T RunRecord::copyOf(const T& member) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return member;
}

RunCounters RunRecord::counters() const { return copyOf(counters_); }
nlohmann::json RunRecord::frames() const { return copyOf(frames_); }
nlohmann::json RunRecord::mappingLog() const { return copyOf(mappingLog_); }
nlohmann::json RunRecord::loops() const { return copyOf(loops_); }
nlohmann::json RunRecord::globalBundleAdjustments() const { return copyOf(globalBa_); }

StageTimings RunRecord::timings() const {
  StageTimings all = trackingTimings_;
  for (const auto& [stage, samples] : mappingTimings_.samples())
    for (double v : samples) all.add(stage, v);
  return all;
}

}  // namespace pslam::system
