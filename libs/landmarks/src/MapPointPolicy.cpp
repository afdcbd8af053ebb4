#include "pslam/landmarks/MapPointPolicy.h"

#include <cmath>

#include "pslam/core/Error.h"

namespace pslam::landmarks {

MapPointModel parseMapPointModel(const std::string& text) {
  return params::parseEnum<MapPointModel>(text, "map point model");
}

std::string toString(MapPointModel model) { return params::enumName(model); }

PSLAM_DEFINE_PARAMS(MapPointPolicyParams)

bool orbSlamShouldCull(const HeuristicCounters& c, std::int64_t currentKeyframeId, const MapPointPolicyParams& p) {
  if (c.bad) return true;
  if (c.foundRatio() < p.minFoundRatio) return true;  // seldom matched where it should be visible
  // Created long enough ago but observed by too few keyframes: a spurious triangulation.
  return currentKeyframeId - c.firstKeyframeId >= p.observationWindow && c.observations <= p.minObservations;
}

bool inlierRatioShouldCull(const MapPointRecord& point, const MapPointPolicyParams& p, const KeypointModel& model) {
  if (point.counters.bad) return true;
  if (p.cullInlierRatio <= 0) return false;
  return point.model.depthUpdates >= p.cullMinDepthUpdates && model.inlierRatio(point.model) < p.cullInlierRatio;
}

namespace {

class HeuristicPolicy final : public MapPointPolicy {
 public:
  explicit HeuristicPolicy(MapPointPolicyParams p) : p_(p) {}
  MapPointModel model() const override { return MapPointModel::Heuristic; }
  bool isActive(const MapPointRecord& point) const override { return !point.counters.bad; }
  bool shouldCull(const MapPointRecord& point, std::int64_t kf) const override {
    return orbSlamShouldCull(point.counters, kf, p_);
  }

 private:
  MapPointPolicyParams p_;
};

class MaskingPolicy final : public MapPointPolicy {
 public:
  MaskingPolicy(MapPointPolicyParams p, const KeypointModel& m) : p_(p), model_(m) {}
  MapPointModel model() const override { return MapPointModel::Masking; }
  bool isActive(const MapPointRecord& point) const override {
    return !point.counters.bad &&
           model_.classPosterior(point.model)[int(1)] <= p_.maskingDynamicThreshold;  // class 1 = dynamic
  }
  bool shouldCull(const MapPointRecord& point, std::int64_t kf) const override {
    return orbSlamShouldCull(point.counters, kf, p_);
  }

 private:
  MapPointPolicyParams p_;
  KeypointModel model_;
};

class ProbabilisticPolicy final : public MapPointPolicy {
 public:
  ProbabilisticPolicy(MapPointPolicyParams p, const KeypointModel& m) : p_(p), model_(m) {}
  MapPointModel model() const override { return MapPointModel::Probabilistic; }
  bool isActive(const MapPointRecord& point) const override {
    return !point.counters.bad && model_.isActive(point.model);
  }
  bool shouldCull(const MapPointRecord& point, std::int64_t kf) const override {
    if (point.counters.bad) return true;
    if (p_.orbSlamCulling && orbSlamShouldCull(point.counters, kf, p_)) return true;
    return inlierRatioShouldCull(point, p_, model_);
  }

 private:
  MapPointPolicyParams p_;
  KeypointModel model_;
};

}  // namespace

std::unique_ptr<MapPointPolicy> makeMapPointPolicy(const MapPointPolicyParams& params, const KeypointModel& model) {
  params.check();
  switch (params.model) {
    case MapPointModel::Heuristic: return std::make_unique<HeuristicPolicy>(params);
    case MapPointModel::Masking: return std::make_unique<MaskingPolicy>(params, model);
    case MapPointModel::Probabilistic: return std::make_unique<ProbabilisticPolicy>(params, model);
  }
  throw Error("makeMapPointPolicy: unknown model");
}

}  // namespace pslam::landmarks
