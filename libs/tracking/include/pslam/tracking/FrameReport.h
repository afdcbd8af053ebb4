#pragma once
// What tracking reports about one frame (report.json "frames", doc/slam.md).
#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

namespace pslam::tracking {

/// What the Manhattan path did in one frame (report.json).
struct ManhattanFrameReport {
  bool normals = false;         ///< the frame had a NORMALS channel (and the path is enabled)
  bool frameValid = false;      ///< the mean shift gave a valid Manhattan frame
  int observedAxes = 0;
  std::string mode = "none";    ///< manhattan | fallback | none (path disabled or not tracking)
  double priorDeviationDeg = -1;  ///< angle between the Manhattan rotation and the motion model's prediction
  double refinementDeg = -1;    ///< rotation the 6-DoF refinement applied to the Manhattan rotation
  int validationInView = 0;     ///< points of the last n keyframes in view at the Manhattan pose
  int validationInliers = 0;    ///< ... that are inliers of the frame
  std::string reason;           ///< why the Manhattan pose was not used (empty when it was)
  nlohmann::json toJson() const;
};

enum class FrameStatus { Initializing, Tracking, Lost, Relocalized };
const char* toString(FrameStatus status);

struct FrameReport {
  std::size_t index = 0;
  double timestamp = 0;
  FrameStatus status = FrameStatus::Initializing;
  std::string method;          ///< initializer / motion / reference / relocalization / reset
  int features = 0;
  int matches = 0;             ///< after motion / reference / relocalization search
  int inliers = 0;             ///< after local-map tracking
  int localMapPoints = 0;      ///< candidates projected in local-map tracking
  int activeMatches = 0;       ///< final matches of points the policy lets tracking use (all of them: heuristic)
  int inactiveMatches = 0;     ///< final matches of points it does not (kept as measurements only, §3.4.2)
  int modelUpdates = 0;        ///< depth measurements applied to the points' models in this frame (§3.4.2)
  ManhattanFrameReport manhattan;  ///< the Manhattan path (§4.4; mode "none" when disabled)
  /// The landmark modules' counts (LandmarkModule::afterTracking), flat keys prefixed by each module.
  nlohmann::json modules = nlohmann::json::object();
  bool keyFrame = false;
  std::size_t mapPoints = 0, keyFrames = 0;
  std::string message;
  nlohmann::json toJson() const;
};

}  // namespace pslam::tracking
