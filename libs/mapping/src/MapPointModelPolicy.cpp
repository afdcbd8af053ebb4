#include "pslam/mapping/MapPointModelPolicy.h"

#include <algorithm>
#include <cstdint>
#include <string>

#include "pslam/core/Error.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/landmarks/MatchingAccuracy.h"
#include "pslam/landmarks/MeasurementVariance.h"
#include "pslam/map/Map.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping {

double initialInverseDepthVariance(const landmarks::KeypointModelParams& p) {
  const double range = p.inverseDepthMax - p.inverseDepthMin;
  return range * range / 36.0;
}

MapPointModelPolicy::MapPointModelPolicy(const landmarks::PointModelParams& params, double depthPixelNoise)
    : policyParams_(params.policy),
      keypointModel_(params.keypoint),
      matching_(params.matching),
      semantic_(params.semantic),
      depthPixelNoise_(depthPixelNoise) {
  policyParams_.check();
  matching_.check();
  if (!(depthPixelNoise > 0)) throw Error("MapPointModelPolicy: depthPixelNoise must be > 0");
  policy_ = landmarks::makeMapPointPolicy(policyParams_, keypointModel_);
}

std::optional<landmarks::ClassVector> MapPointModelPolicy::classEvidence(
    const std::array<float, 3>* probabilities) const {
  if (!semantic_ || !probabilities) return std::nullopt;
  return landmarks::ClassVector{(*probabilities)[0], (*probabilities)[1], (*probabilities)[2]};
}

landmarks::KeypointState MapPointModelPolicy::stateOf(const map::MapPoint& p) const {
  return p.landmarkState.empty()
             ? keypointModel_.initialize(p.inverseDepthAlongZ(), initialInverseDepthVariance(keypointModel_.params()))
             : decodeKeypointState(p.landmarkState, "map point " + std::to_string(p.id));
}

bool MapPointModelPolicy::observe(const map::Map& map, map::MapPoint& p, const map::PointMeasurement& m) const {
  if (!map.hasKeyFrame(p.anchorKeyFrame)) return false;
  const map::KeyFrame& anchor = map.keyFrame(p.anchorKeyFrame);
  landmarks::KeypointState state = stateOf(p);
  const double alpha = p.descriptor.empty() || m.descriptor.empty()
                           ? 1.0
                           : landmarks::matchingAccuracyFromDescriptors(p.descriptor, m.descriptor,
                                                                        matching_.hammingMaxDistance);
  const std::optional<landmarks::ClassVector> classes = classEvidence(m.classProbabilities);
  bool updated = false;
  const geometry::Matrix34d P1 = geometry::projectionMatrix(
      anchor.camera.K(), anchor.T_cam_world.linear(), anchor.T_cam_world.translation());
  const geometry::Matrix34d P2 =
      geometry::projectionMatrix(m.camera.K(), m.T_cam_world.linear(), m.T_cam_world.translation());
  const Eigen::Vector2d anchorPixel = anchor.pixel(p.anchorKeypoint);
  Eigen::Vector3d X;
  if (geometry::triangulateDLT(P1, anchorPixel, P2, m.pixel, X)) {
    const Eigen::Vector3d X_anchor = anchor.T_cam_world * X;
    const Eigen::Vector3d cameraCentre = -(m.T_cam_world.linear().transpose() * m.T_cam_world.translation());
    const Eigen::Vector3d t_ref_cur = anchor.T_cam_world * cameraCentre;
    if (X_anchor.z() > 0.0 && t_ref_cur.norm() > 0.0) {
      const landmarks::DepthUncertainty tau = landmarks::depthUncertainty(
          anchor.camera.unprojectToBearing(anchorPixel), X_anchor.norm(), t_ref_cur, anchor.camera.fx, depthPixelNoise_);
      if (tau.valid && tau.tau2InverseDepth() > 0.0) {
        keypointModel_.observe(state, 1.0 / X_anchor.z(), tau.tau2InverseDepth(), alpha, classes);
        updated = true;
      }
    }
  }
  if (!updated) keypointModel_.addSemanticObservation(state, classes, alpha);
  p.landmarkState = encodeKeypointState(state);
  return updated;
}

std::string MapPointModelPolicy::name() const { return landmarks::toString(model()); }

landmarks::MapPointRecord MapPointModelPolicy::recordOf(const map::MapPoint& p) const {
  landmarks::MapPointRecord r;
  r.model = stateOf(p);
  r.counters.visible = static_cast<std::uint32_t>(std::max(0, p.visibleCount));
  r.counters.found = static_cast<std::uint32_t>(std::max(0, p.foundCount));
  r.counters.observations = static_cast<std::uint32_t>(p.numObservations());
  r.counters.firstKeyframeId = static_cast<std::int64_t>(p.firstKeyFrame);
  r.counters.bad = p.bad;
  return r;
}

bool MapPointModelPolicy::mayUse(const map::MapPoint& point) const {
  if (point.bad) return false;
  if (usesEveryGoodPoint()) return true;
  return policy_->isActive(recordOf(point));
}

bool MapPointModelPolicy::inlierRatioSaysCull(const map::MapPoint& point) const {
  if (model() != landmarks::MapPointModel::Probabilistic) return false;
  return landmarks::inlierRatioShouldCull(recordOf(point), policyParams_, keypointModel_);
}

bool MapPointModelPolicy::shouldCull(const map::MapPoint& point, map::KeyFrameId currentKeyFrame) const {
  return point.bad || policy_->shouldCull(recordOf(point), static_cast<std::int64_t>(currentKeyFrame));
}

}  // namespace pslam::mapping
