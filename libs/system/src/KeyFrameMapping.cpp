// What happens to each keyframe once the tracker made it (doc/architecture.md, "A keyframe"): local mapping
// (LocalMapper::processKeyFrame), the landmark modules' new landmarks and culling, loop closing; one entry of the
// mapping log and the stage timings. In the tracking thread (sequential) or the mapping thread (threaded, map lock
// held).
#include "MappingScheduler.h"

namespace pslam::system {

void MappingScheduler::mapNow(const std::vector<map::KeyFrameId>& kfs, bool measuredByTracking) {
  map::Map& map = parts_.map;
  StageTimings& timings = record_.mappingTimings();
  for (map::KeyFrameId kf : kfs) {
    if (!map.hasKeyFrame(kf)) continue;  // erased meanwhile
    const mapping::LocalMappingReport r = parts_.mapper->processKeyFrame(kf, {}, measuredByTracking);
    if (r.mapChanged) return;  // threaded: tracking reset the map meanwhile, kf belongs to the old one
    const int generation = record_.generation();
    nlohmann::json entry = {{"generation", generation},
                            {"keyframe", kf},
                            {"new_points", r.newPoints},
                            {"culled_points", r.culledPoints},
                            {"culled_recent", r.culledRecent},
                            {"culled_inlier_ratio", r.culledInlierRatio},
                            {"landmark_updates", r.landmarkUpdates},
                            {"culled_keyframes", r.culledKeyFrames},
                            {"ba_observations_erased", r.baObservationsErased},
                            {"ba_stopped", r.baStopped},
                            {"ba_final_rms_px", r.baFinalRmsPixels},
                            {"fused", r.fusedPoints},
                            {"map_points", map.numMapPoints()},
                            {"keyframes", map.numKeyFrames()}};
    // The landmark modules: new landmarks of the keyframe at its refined pose (after local BA), culling.
    if (map.hasKeyFrame(kf))
      for (const auto& module : parts_.modules) module->afterLocalMapping(map, kf, timings, entry);
    record_.addMappedKeyFrame(std::move(entry));
    // Loop closing: the keyframe is queried for a place seen long before, after its local mapping.
    if (parts_.loopCloser && map.hasKeyFrame(kf)) {
      const loopclosing::LoopReport lr = parts_.loopCloser->processKeyFrame(kf);  // calls onLoopKeyFramesMoved
      timings.add("loop_closing", lr.ms);
      if (lr.closed && !lr.globalBaAsynchronous) timings.add("global_ba", lr.globalBaMs);
      nlohmann::json loop;  // only keyframes with candidates are reported
      if (lr.candidates > 0) {
        loop = lr.toJson();
        loop["generation"] = generation;
      }
      record_.addLoop(std::move(loop), lr.closed, lr.withdrawn);
      if (lr.globalBaAsynchronous) {
        std::lock_guard<std::mutex> lk(queueMutex_);
        if (globalBa_ == GlobalBaState::None) globalBa_ = GlobalBaState::Running;  // Ready when it was that quick
      }
    }
    // Every step of a keyframe's local mapping (doc/performance.md, mapping cost per keyframe).
    timings.add("mapping_insert", r.processMs);  // keyframe insertion, model updates of its points
    timings.add("culling_points", r.cullPointsMs);
    timings.add("triangulation", r.triangulationMs);
    timings.add("fusion", r.fusionMs);
    timings.add("local_ba", r.localBaMs);
    timings.add("culling_keyframes", r.cullKeyFramesMs);
    timings.add("mapping_total", r.totalMs);
  }
}

void MappingScheduler::onLoopKeyFramesMoved(const loopclosing::LoopReport& lr,
                                            const std::map<map::KeyFrameId, Eigen::Isometry3d>& posesBefore) {
  // Frames are kept relative to their reference keyframe, so their offsets follow its change of scale, and the
  // tracker's last frame follows its reference keyframe.
  record_.rescaleFrames(lr.keyFrameScales);
  const map::KeyFrameId ref = parts_.tracker->referenceKeyFrame();
  const auto before = posesBefore.find(ref);
  if (before == posesBefore.end() || !parts_.map.hasKeyFrame(ref)) return;
  const auto sc = lr.keyFrameScales.find(ref);
  parts_.tracker->onKeyFramesMoved(ref, before->second, sc != lr.keyFrameScales.end() ? sc->second : 1.0);
}

void MappingScheduler::applyGlobalBa() {
  if (!parts_.loopCloser) return;
  if (std::optional<nlohmann::json> applied = parts_.loopCloser->applyGlobalBundleAdjustment()) {
    (*applied)["generation"] = record_.generation();
    record_.mappingTimings().add("global_ba", (*applied)["global_ba_ms"].get<double>());
    record_.mappingTimings().add("global_ba_apply", (*applied)["apply_ms"].get<double>());
    record_.addGlobalBundleAdjustment(std::move(*applied));
  }
}

}  // namespace pslam::system
