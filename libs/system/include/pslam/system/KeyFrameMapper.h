#pragma once
// What the SLAM system needs from local mapping: process one new keyframe to completion. The real
// implementation is pslam::mapping::LocalMapper (libs/mapping); BuiltinLocalMapper is a minimal ORB-SLAM
// local mapping (triangulation with covisible keyframes, local BA, recent-point culling) used when that
// library is not part of the build.
#include <memory>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>
#include <nlohmann/json.hpp>

#include "pslam/map/KeyFrameCulling.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/Params.h"

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



struct BuiltinMappingParams {
  int covisibleKeyFrames = 10;    ///< neighbours searched for new points (ORB-SLAM monocular: 20)
  int maxDistance = 50;           ///< TH_LOW of SearchForTriangulation
  double minBaselineRatio = 0.01; ///< baseline / median neighbour depth below this: skip the pair
  double maxParallaxCos = 0.9998; ///< rays closer than this angle are not triangulated
  int fusionNeighbours = 20;      ///< SearchInNeighbors: first-order neighbours (ORB-SLAM monocular 20)
  double fusionRadius = 3.0;      ///< Fuse window th * scale^level (ORB-SLAM th = 3)
  bool localBundleAdjustment = true;
  bool cullKeyFrames = true;         ///< key cullKeyFrames: ORB-SLAM KeyFrameCulling after local BA
  map::KeyFrameCullingParams culling;  ///< keys redundantFraction (0.9), redundantMinObservers (3)
  optimize::BundleAdjustmentParams ba;

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  void check() const;
};

class BuiltinLocalMapper : public KeyFrameMapper {
 public:
  BuiltinLocalMapper(map::Map& map, BuiltinMappingParams params);
  std::string name() const override { return "builtin"; }
  MappingStepReport processKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking) override;
  void reset() override { recent_.clear(); }
  std::string configText() const override;

  /// ORB-SLAM CreateNewMapPoints for one keyframe against its covisible neighbours. Returns the new ids.
  std::vector<map::MapPointId> triangulateNewPoints(map::KeyFrameId kf);
  /// ORB-SLAM SearchInNeighbors: fuses the keyframe's points into its neighbours and theirs into it
  /// (ORBmatcher::Fuse). Returns merged points + added observations.
  int fuseWithNeighbours(map::KeyFrameId kf);
  /// ORB-SLAM MapPointCulling of the recently created points. Returns the number erased.
  int cullRecentPoints(map::KeyFrameId current);

 private:
  map::Map& map_;
  BuiltinMappingParams params_;
  std::vector<map::MapPointId> recent_;
};

/// true when this build contains libs/mapping (pslam::mapping::LocalMapper).
bool haveMappingLibrary();

/// The mapper named by [System] localMapper: "mapping" (libs/mapping), "builtin", or "auto" (mapping when
/// built in, else builtin). `iniText` is the run's configuration (the mapping library reads its own keys from
/// [LocalMapping]). Throws pslam::Error for an unknown name or "mapping" in a build without it.
std::unique_ptr<KeyFrameMapper> makeKeyFrameMapper(const std::string& which, map::Map& map, const std::string& iniText,
                                                   const BuiltinMappingParams& builtinParams);

}  // namespace pslam::system
