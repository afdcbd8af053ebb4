#pragma once
// map::PointUsePolicy for the three map-point models of thesis §3.5.5.1 (heuristic / masking / probabilistic):
// the landmarks::MapPointPolicy decision on what the map stores of a point (ORB-SLAM's found/visible counters
// and the keypoint-model state of §3.3 in MapPoint::landmarkState). One instance per run is shared by the
// tracker and local mapping, so "may this point be used" is decided in one place.
#include <memory>
#include <optional>
#include <string>

#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/map/PointUsePolicy.h"

namespace pslam::mapping {

/// SVO's initial seed spread of a new point's inverse depth: the whole range of the model is +-3 sigma.
double initialInverseDepthVariance(const landmarks::KeypointModelParams& params);

class MapPointModelPolicy : public map::PointUsePolicy {
 public:
  /// Checks the parameters (pslam::Error naming the key). `depthPixelNoise`: the pixel angle of eq. 2.26 for
  /// the variance tau^2 of a depth measurement.
  MapPointModelPolicy(const landmarks::PointModelParams& params, double depthPixelNoise);
  std::string name() const override;
  bool mayUse(const map::MapPoint& point) const override;
  bool shouldCull(const map::MapPoint& point, map::KeyFrameId currentKeyFrame) const override;
  /// Heuristic (ORB-SLAM*): every good point is active.
  bool usesEveryGoodPoint() const override { return model() == landmarks::MapPointModel::Heuristic; }
  /// Masking and probabilistic keep the keypoint model of §3.3 up to date.
  bool learnsFromMeasurements() const override { return !usesEveryGoodPoint(); }
  /// §3.4.2: the inverse depth along the anchor's z axis is re-triangulated from the anchor keypoint and this
  /// view (DLT), tau^2 follows eq. 2.24-2.29, alpha is eq. 3.2 of the Hamming distance between the point's
  /// descriptor and the measured one; the view's class evidence (classEvidence) comes first. Returns true when
  /// the depth was updated (a view without parallax to the anchor gives only the class evidence).
  bool observe(const map::Map& map, map::MapPoint& point, const map::PointMeasurement& measurement) const override;

  /// The class evidence of a keypoint (eq. 3.10): its SEMANTIC probabilities, or none when the semantic prior is
  /// off (PointModelParams::semantic) or the view has no SEMANTIC channel (a point without evidence is static,
  /// landmarks::KeypointModel::classPosterior).
  std::optional<landmarks::ClassVector> classEvidence(const std::array<float, 3>* probabilities) const;
  /// The probabilistic model's own culling rule (landmarks::inlierRatioShouldCull), for points past ORB-SLAM's
  /// recent-point probation; false for the other models.
  bool inlierRatioSaysCull(const map::MapPoint& point) const;
  /// The state of a point that has none yet: the model's initial state at its current depth.
  landmarks::KeypointState stateOf(const map::MapPoint& point) const;

  landmarks::MapPointModel model() const { return policyParams_.model; }
  const landmarks::KeypointModel& keypointModel() const { return keypointModel_; }
  /// What the policy sees of a map point: its counters and its keypoint-model state (a point without state has
  /// seen no evidence yet: the model's initial state at its current depth).
  landmarks::MapPointRecord recordOf(const map::MapPoint& point) const;

 private:
  landmarks::MapPointPolicyParams policyParams_;
  landmarks::KeypointModel keypointModel_;
  landmarks::MatchingAccuracyParams matching_;
  bool semantic_ = true;
  double depthPixelNoise_ = 1.0;
  std::unique_ptr<landmarks::MapPointPolicy> policy_;
};

}  // namespace pslam::mapping
