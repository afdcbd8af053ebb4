#include "pslam/tracking/FrameReport.h"

namespace pslam::tracking {

nlohmann::json ManhattanFrameReport::toJson() const {
  return {{"normals", normals},
          {"frame_valid", frameValid},
          {"observed_axes", observedAxes},
          {"mode", mode},
          {"prior_deviation_deg", priorDeviationDeg},
          {"refinement_deg", refinementDeg},
          {"validation_in_view", validationInView},
          {"validation_inliers", validationInliers},
          {"reason", reason}};
}

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::Initializing: return "initializing";
    case FrameStatus::Tracking: return "tracking";
    case FrameStatus::Lost: return "lost";
    case FrameStatus::Relocalized: return "relocalized";
  }
  return "?";
}

nlohmann::json FrameReport::toJson() const {
  nlohmann::json j = {{"index", index},       {"timestamp", timestamp}, {"status", toString(status)},
                      {"method", method},     {"features", features},   {"matches", matches},
                      {"inliers", inliers},   {"local_map_points", localMapPoints}, {"keyframe", keyFrame},
                      {"active_matches", activeMatches}, {"inactive_matches", inactiveMatches},
                      {"model_updates", modelUpdates}, {"manhattan", manhattan.toJson()},
                      {"map_points", mapPoints}, {"keyframes", keyFrames}, {"message", message}};
  j.update(modules);  // each landmark module's own counts (its keys carry its prefix)
  return j;
}

}  // namespace pslam::tracking
