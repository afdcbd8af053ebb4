#pragma once
// The system-wide choice of map-point model compared in §3.5.5.1 (Table 3.3):
//   heuristic     - ORB-SLAM*: found/visible bookkeeping and ORB-SLAM's map-point culling; every point is used.
//   masking       - ORB-SLAM* culling, and a point is inactive while P(dynamic) > 0.5 (semantic masking).
//   probabilistic - the keypoint model of §3.3: active while the inlier ratio phi >= psi_min.
// The SLAM core keeps a MapPointRecord per point and asks the policy; switching models is a config key.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "pslam/core/Params.h"
#include "pslam/landmarks/KeypointModel.h"

namespace pslam::landmarks {

enum class MapPointModel { Heuristic, Masking, Probabilistic };
/// The names of the models in configs (params::Codec).
constexpr std::array<std::pair<MapPointModel, const char*>, 3> enumNames(MapPointModel) {
  return {{{MapPointModel::Heuristic, "heuristic"},
           {MapPointModel::Masking, "masking"},
           {MapPointModel::Probabilistic, "probabilistic"}}};
}

/// "heuristic" | "masking" | "probabilistic" (case-insensitive). Throws pslam::Error listing the choices.
MapPointModel parseMapPointModel(const std::string& text);
std::string toString(MapPointModel model);

/// ORB-SLAM's bookkeeping (MapPoint::mnVisible / mnFound, observation count, first keyframe id).
struct HeuristicCounters {
  std::uint32_t visible = 1;       ///< frames in whose frustum the point projected
  std::uint32_t found = 1;         ///< frames in which it was matched
  std::uint32_t observations = 0;  ///< keyframes observing it
  std::int64_t firstKeyframeId = 0;
  bool bad = false;                ///< set once culled
  double foundRatio() const { return visible == 0 ? 0.0 : double(found) / double(visible); }
};

/// Everything a policy may look at for one map point.
struct MapPointRecord {
  KeypointState model;
  HeuristicCounters counters;
};

struct MapPointPolicyParams {
  MapPointModel model = MapPointModel::Probabilistic;
  // ORB-SLAM LocalMapping::MapPointCulling constants.
  double minFoundRatio = 0.25;
  std::uint32_t minObservations = 2;
  std::int64_t observationWindow = 2;
  double maskingDynamicThreshold = 0.5;
  /// probabilistic: cull once phi < this after at least `cullMinDepthUpdates` depth updates (design choice,
  /// the thesis keeps inactive points; 0 disables culling).
  double cullInlierRatio = 0.1;
  std::uint32_t cullMinDepthUpdates = 5;
  /// probabilistic: ORB-SLAM's MapPointCulling of recent points (found ratio, observations) applies as well.
  /// The thesis builds on ORB-SLAM and names no change to it; without it, spurious triangulations that are
  /// seldom re-found stay in the map (KITTI 00: 0.66 m ATE instead of ... , doc/experiments.md).
  bool orbSlamCulling = true;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, model, anyValue, "heuristic | masking | probabilistic");
    PSLAM_FIELD(v, minFoundRatio, inClosed(0, 1), "cull when found/visible < this");
    PSLAM_FIELD(v, minObservations, anyValue, "cnThObs (monocular): cull when observations <= this ...");
    PSLAM_FIELD(v, observationWindow, atLeast(0), "... and at least this many keyframes have passed since creation");
    PSLAM_FIELD(v, maskingDynamicThreshold, inClosed(0, 1), "masking: inactive when P(dynamic) > this (§3.5.5.1)");
    PSLAM_FIELD(v, cullInlierRatio, inRightOpen(0, 1), "probabilistic: cull once phi < this (0 = never)");
    PSLAM_FIELD(v, cullMinDepthUpdates, anyValue, "probabilistic: ... after at least this many depth updates");
    PSLAM_FIELD(v, orbSlamCulling, anyValue, "probabilistic: ORB-SLAM's recent-point culling as well");
  }
  PSLAM_PARAMS("PointModel")
};

class MapPointPolicy {
 public:
  virtual ~MapPointPolicy() = default;
  virtual MapPointModel model() const = 0;
  /// Use the point for tracking / bundle adjustment now?
  virtual bool isActive(const MapPointRecord& point) const = 0;
  /// Remove the point from the map (checked by local mapping at each new keyframe)?
  virtual bool shouldCull(const MapPointRecord& point, std::int64_t currentKeyframeId) const = 0;
};

/// ORB-SLAM's culling rules on the counters (shared by the heuristic and masking policies).
bool orbSlamShouldCull(const HeuristicCounters& counters, std::int64_t currentKeyframeId,
                       const MapPointPolicyParams& params);

/// The probabilistic model's own rule: phi < cullInlierRatio after at least cullMinDepthUpdates depth updates.
bool inlierRatioShouldCull(const MapPointRecord& point, const MapPointPolicyParams& params, const KeypointModel& model);

/// The policy for params.model; the keypoint model supplies class posteriors and inlier ratios.
std::unique_ptr<MapPointPolicy> makeMapPointPolicy(const MapPointPolicyParams& params, const KeypointModel& model);

}  // namespace pslam::landmarks
