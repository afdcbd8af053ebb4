#include "pslam/landmarks/MapPointPolicy.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"

namespace pslam::landmarks {

MapPointModel parseMapPointModel(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "heuristic") return MapPointModel::Heuristic;
  if (t == "masking") return MapPointModel::Masking;
  if (t == "probabilistic") return MapPointModel::Probabilistic;
  throw Error("map point model '" + text + "' unknown (expected heuristic, masking or probabilistic)");
}

std::string toString(MapPointModel model) {
  switch (model) {
    case MapPointModel::Heuristic: return "heuristic";
    case MapPointModel::Masking: return "masking";
    case MapPointModel::Probabilistic: return "probabilistic";
  }
  return "unknown";
}

void MapPointPolicyParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  model = parseMapPointModel(cfg.read_string_first_word(section, "model", toString(model)));
  minFoundRatio = cfg.read_double(section, "minFoundRatio", minFoundRatio);
  minObservations = static_cast<std::uint32_t>(cfg.read_int(section, "minObservations", int(minObservations)));
  observationWindow = cfg.read_int(section, "observationWindow", int(observationWindow));
  maskingDynamicThreshold = cfg.read_double(section, "maskingDynamicThreshold", maskingDynamicThreshold);
  cullInlierRatio = cfg.read_double(section, "cullInlierRatio", cullInlierRatio);
  cullMinDepthUpdates = static_cast<std::uint32_t>(cfg.read_int(section, "cullMinDepthUpdates", int(cullMinDepthUpdates)));
  check();
}

void MapPointPolicyParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  cfg.write(section, "model", toString(model));
  cfg.write(section, "minFoundRatio", minFoundRatio);
  cfg.write(section, "minObservations", int(minObservations));
  cfg.write(section, "observationWindow", int(observationWindow));
  cfg.write(section, "maskingDynamicThreshold", maskingDynamicThreshold);
  cfg.write(section, "cullInlierRatio", cullInlierRatio);
  cfg.write(section, "cullMinDepthUpdates", int(cullMinDepthUpdates));
}

void MapPointPolicyParams::check() const {
  if (!(minFoundRatio >= 0 && minFoundRatio <= 1)) throw Error("MapPointPolicyParams: minFoundRatio must be in [0, 1]");
  if (observationWindow < 0) throw Error("MapPointPolicyParams: observationWindow must be >= 0");
  if (!(maskingDynamicThreshold >= 0 && maskingDynamicThreshold <= 1))
    throw Error("MapPointPolicyParams: maskingDynamicThreshold must be in [0, 1]");
  if (!(cullInlierRatio >= 0 && cullInlierRatio < 1))
    throw Error("MapPointPolicyParams: cullInlierRatio must be in [0, 1)");
}

bool orbSlamShouldCull(const HeuristicCounters& c, std::int64_t currentKeyframeId, const MapPointPolicyParams& p) {
  if (c.bad) return true;
  if (c.foundRatio() < p.minFoundRatio) return true;  // seldom matched where it should be visible
  // Created long enough ago but observed by too few keyframes: a spurious triangulation.
  return currentKeyframeId - c.firstKeyframeId >= p.observationWindow && c.observations <= p.minObservations;
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
  bool shouldCull(const MapPointRecord& point, std::int64_t) const override {
    if (point.counters.bad) return true;
    if (p_.cullInlierRatio <= 0) return false;
    return point.model.depthUpdates >= p_.cullMinDepthUpdates && model_.inlierRatio(point.model) < p_.cullInlierRatio;
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
