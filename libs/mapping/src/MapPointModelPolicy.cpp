#include "pslam/mapping/MapPointModelPolicy.h"

#include <algorithm>
#include <cstdint>

#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping {

double initialInverseDepthVariance(const landmarks::KeypointModelParams& p) {
  const double range = p.inverseDepthMax - p.inverseDepthMin;
  return range * range / 36.0;
}

MapPointModelPolicy::MapPointModelPolicy(const landmarks::MapPointPolicyParams& policy,
                                         const landmarks::KeypointModelParams& keypoint)
    : policyParams_(policy), keypointModel_(keypoint) {
  policyParams_.check();
  policy_ = landmarks::makeMapPointPolicy(policyParams_, keypointModel_);
}

std::string MapPointModelPolicy::name() const { return landmarks::toString(model()); }

landmarks::MapPointRecord MapPointModelPolicy::recordOf(const map::MapPoint& p) const {
  landmarks::MapPointRecord r;
  r.model = p.landmarkState.empty()
                ? keypointModel_.initialize(p.inverseDepthAlongZ(), initialInverseDepthVariance(keypointModel_.params()))
                : decodeKeypointState(p.landmarkState, "map point " + std::to_string(p.id));
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

bool MapPointModelPolicy::shouldCull(const map::MapPoint& point, map::KeyFrameId currentKeyFrame) const {
  return point.bad || policy_->shouldCull(recordOf(point), static_cast<std::int64_t>(currentKeyFrame));
}

}  // namespace pslam::mapping
