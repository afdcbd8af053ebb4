#pragma once
// All parameters of a SLAM run, one ini section per component (DESIGN.md §5):
//   [ORB] features::OrbParams   [Initializer] tracking::InitializerParams   [Tracking] tracking::TrackerParams
//   [PoseOptimization] optimize::PoseOptimizationParams   [BundleAdjustment] optimize::BundleAdjustmentParams
//   [LocalMapping] mapping::LocalMappingParams   [System] threaded, localMapper
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/features/OrbExtractor.h"
#include "pslam/optimize/Params.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/tracking/MonocularInitializer.h"
#include "pslam/tracking/Tracker.h"

namespace pslam::system {

struct SlamParams {
  features::OrbParams orb;
  tracking::InitializerParams initializer;
  tracking::TrackerParams tracking;
  optimize::PoseOptimizationParams poseOptimization;
  optimize::BundleAdjustmentParams bundleAdjustment;
  mapping::LocalMappingParams mapping;  ///< [LocalMapping]; mapping.ba is [BundleAdjustment]
  bool threaded = false;  ///< [System] threaded: mapping in a second thread (live use); false = deterministic
  std::string poseSolver = "full6dof";  ///< [System] poseSolver: tracking::makePoseSolver name
  std::string mapInitializer = "twoView";  ///< [System] mapInitializer: tracking::makeMapInitializer name
  std::string localMapper = "auto";  ///< [System] localMapper: auto | mapping (the same: libs/mapping)
  std::string sourceIni;  ///< text of the loaded ini (components outside this struct read their keys from it)

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg) const;
  /// Throws pslam::Error naming the section and key of the first invalid value.
  void check() const;
  /// Effective configuration as ini text (for the run report).
  std::string toIniText() const;
};

/// Loads and checks an ini file with "Section.key=value" overrides applied; errors name the file.
SlamParams loadSlamParams(const std::string& iniPath, const std::vector<std::string>& overrides = {});

}  // namespace pslam::system
