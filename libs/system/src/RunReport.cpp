#include "pslam/system/RunReport.h"

#include "pslam/system/SlamParams.h"

namespace pslam::system {

nlohmann::json toJson(const RunSummary& s) {
  nlohmann::json j = {{"frames_processed", s.framesProcessed},
                      {"frames_tracked", s.framesTracked},
                      {"frames_lost", s.framesLost},
                      {"relocalizations", s.relocalizations},
                      {"relocalizations_withdrawn", s.relocalizationsWithdrawn},
                      {"initialized", s.initializedAtFrame.has_value()},
                      {"initialized_at_frame", s.initializedAtFrame ? static_cast<long long>(*s.initializedAtFrame) : -1LL},
                      {"keyframes", s.keyFrames},
                      {"map_points", s.mapPoints},
                      {"resets", s.resets},
                      {"loops_closed", s.loopsClosed},
                      {"loops_withdrawn", s.loopsWithdrawn},
                      {"manhattan_frames", s.manhattanFrames},
                      {"manhattan_tracked", s.manhattanTracked},
                      {"fallback_tracked", s.fallbackTracked}};
  for (const auto& [name, n] : s.landmarks) j[name] = n;
  return j;
}

nlohmann::json runReport(const System& system) {
  const SlamParams& params = system.params();
  const RunRecord& record = system.record();
  nlohmann::json r;
  r["config"] = params.toIniText();
  r["seed"] = system.seed();
  r["mode"] = system.threaded() ? "threaded" : "sequential";
  r["mapping_enabled"] = system.mappingEnabled();
  r["pose_solver"] = params.system.poseSolver;
  r["map_initializer"] = params.system.initializer;
  r["summary"] = toJson(system.summary());
  if (system.hasCamera()) {
    const geometry::PinholeCamera& cam = system.camera();
    r["camera"] = {{"fx", cam.fx}, {"fy", cam.fy}, {"cx", cam.cx}, {"cy", cam.cy},
                   {"width", cam.width}, {"height", cam.height}};
    r["point_policy"] = system.pointPolicyName();
    r["timings"] = system.timings().summary();
    r["mapping"] = record.mappingLog();
    r["loops"] = record.loops();
    r["global_ba"] = record.globalBundleAdjustments();
  }
  r["frames"] = record.frames();
  return r;
}

}  // namespace pslam::system
