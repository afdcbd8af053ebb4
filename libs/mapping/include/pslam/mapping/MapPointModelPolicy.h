#pragma once
// map::PointUsePolicy for the three map-point models of thesis §3.5.5.1 (heuristic / masking / probabilistic):
// the landmarks::MapPointPolicy decision on what the map stores of a point (ORB-SLAM's found/visible counters
// and the keypoint-model state of §3.3 in MapPoint::landmarkState). One instance per run is shared by the
// tracker and local mapping, so "may this point be used" is decided in one place.
#include <memory>
#include <string>

#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/map/PointUsePolicy.h"

namespace pslam::mapping {

/// SVO's initial seed spread of a new point's inverse depth: the whole range of the model is +-3 sigma.
double initialInverseDepthVariance(const landmarks::KeypointModelParams& params);

class MapPointModelPolicy : public map::PointUsePolicy {
 public:
  /// Checks both parameter sets (pslam::Error naming the key).
  MapPointModelPolicy(const landmarks::MapPointPolicyParams& policy, const landmarks::KeypointModelParams& keypoint);
  std::string name() const override;
  bool mayUse(const map::MapPoint& point) const override;
  bool shouldCull(const map::MapPoint& point, map::KeyFrameId currentKeyFrame) const override;
  /// Heuristic (ORB-SLAM*): every good point is active.
  bool usesEveryGoodPoint() const override { return model() == landmarks::MapPointModel::Heuristic; }

  landmarks::MapPointModel model() const { return policyParams_.model; }
  const landmarks::KeypointModel& keypointModel() const { return keypointModel_; }
  /// What the policy sees of a map point: its counters and its keypoint-model state (a point without state has
  /// seen no evidence yet: the model's initial state at its current depth).
  landmarks::MapPointRecord recordOf(const map::MapPoint& point) const;

 private:
  landmarks::MapPointPolicyParams policyParams_;
  landmarks::KeypointModel keypointModel_;
  std::unique_ptr<landmarks::MapPointPolicy> policy_;
};

}  // namespace pslam::mapping
