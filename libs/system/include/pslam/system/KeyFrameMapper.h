#pragma once
// What the SLAM system needs from local mapping: process one new keyframe to completion. The implementation
// is pslam::mapping::LocalMapper (libs/mapping); the interface keeps SlamSystem independent of its details.
#include <memory>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>
#include <nlohmann/json.hpp>

#include "pslam/map/Map.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::system {

struct MappingStepReport {
  int newPoints = 0;
  int culledPoints = 0;
  int culledKeyFrames = 0;  ///< redundant keyframes erased (KeyFrameCulling)
  int baObservationsErased = 0;
  int fused = 0;  ///< duplicates merged + observations added by fusion
  double fusionMs = 0;
  double triangulationMs = 0, localBaMs = 0;
};

class KeyFrameMapper {
 public:
  virtual ~KeyFrameMapper() = default;
  virtual std::string name() const = 0;
  virtual MappingStepReport processKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking) = 0;
  /// Called after the tracker cleared the map (re-initialization).
  virtual void reset() = 0;
  /// Effective parameters as ini text (for the run report).
  virtual std::string configText() const = 0;
};



/// The local mapper of a run: libs/mapping's LocalMapper (ORB-SLAM LocalMapping with the map-point models of
/// chapter 3) configured by `params` ([LocalMapping] keys; `params.ba` from [BundleAdjustment], `params.pointModel`
/// from [PointModel]). `which`: "mapping" or "auto" (the same; there is one mapper). The former "builtin" mapper
/// was merged into libs/mapping on 2026-11-30 (its fusion gate is `fusionDistanceBand = 0`); asking for it throws
/// pslam::Error saying so.
std::unique_ptr<KeyFrameMapper> makeKeyFrameMapper(const std::string& which, map::Map& map,
                                                   const mapping::LocalMappingParams& params);

}  // namespace pslam::system
