#pragma once
// The JSON of a SLAM run (report.json, doc/slam.md "Outputs"): the apps' output format, kept out of System.h.
#include <nlohmann/json.hpp>

#include "pslam/system/RunRecord.h"
#include "pslam/system/System.h"

namespace pslam::system {

/// {frames_processed, frames_tracked, frames_lost, relocalizations, relocalizations_withdrawn, initialized,
/// initialized_at_frame (-1: never), keyframes, map_points, resets, loops_closed, loops_withdrawn, manhattan_frames,
/// manhattan_tracked, fallback_tracked} and the landmark modules' counters (direct_points, lines, ...).
nlohmann::json toJson(const RunSummary& summary);

/// The run report without the app's fields: effective config, seed, mode, camera, point policy, timings, summary,
/// per-frame reports, mapping log, loops, global BAs.
nlohmann::json runReport(const System& system);

}  // namespace pslam::system
