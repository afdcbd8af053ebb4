#pragma once
// All parameters of a SLAM run, one ini section per component (doc/architecture.md); keys are the field names of
// each struct (pslam/core/Params.h), tables in doc/slam.md:
//   [ORB] features::OrbParams   [Initializer] tracking::InitializerParams   [Tracking] tracking::TrackerParams
//   [PoseOptimization] optimize::PoseOptimizationParams   [BundleAdjustment] optimize::BundleAdjustmentParams
//   [LocalMapping] mapping::LocalMappingParams   [PointModel] landmarks::PointModelParams   [System] SystemParams
//   [DirectFeatures] direct::DirectFeaturesParams   [Lines] lines::LinesParams
//   [Manhattan] tracking::ManhattanPathParams   [ManhattanTracker] manhattan::ManhattanParams
//   [Places] places::PlacesParams   [LoopClosing] loopclosing::LoopClosingParams
// An unknown section or key is an error naming the closest valid one.
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Params.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/lines/LineFrontEnd.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/optimize/Params.h"
#include "pslam/places/PlacesParams.h"
#include "pslam/tracking/MonocularInitializer.h"
#include "pslam/tracking/Tracker.h"

namespace pslam::system {

/// [System]: how the run is put together. The names are validated by the factories that build the parts.
struct SystemParams {
  bool threaded = false;
  /// Threaded mode, how tracking waits for local mapping: "live" (ORB-SLAM's: keyframes when mapping is idle or
  /// after maxFrames; tracking never more than one keyframe ahead; [Tracking] keyFrames.waitRatio says when a
  /// needed keyframe makes it wait) or "afterNewPoints" (each frame after a keyframe waits for that keyframe's
  /// triangulation and fusion; its local BA overlaps). doc/performance.md compares them.
  std::string threadedTracking = "live";
  /// Threaded "live": a keyframe made by a frame with fewer local-map inliers than this holds tracking until its
  /// new points are in the map (as "afterNewPoints" does for every keyframe); 0 = never. 60, twice ORB-SLAM's 30
  /// inliers of a tracked frame. KITTI 00 threaded, 90 runs with 60 or 80 against 90 with 0: 4 runs above 1 m ATE
  /// and 2 lost the camera, against 13 and 4 (doc/performance.md). The same threshold makes a frame that tracks
  /// fewer inliers need a keyframe (tracking::KeyFrameDecisionInput::weakInliers).
  int weakKeyFrameInliers = 60;
  /// Threaded: the waits a frame leaves for the next one (a weak keyframe's points, an urgent keyframe) are taken
  /// after the next frame's feature extraction instead of at the end of this frame, so the extraction overlaps
  /// with the mapping waited for. The next frame is tracked against the same map either way. KITTI 00, 45 runs
  /// alternating with 45 without: wall 0.96x pair by pair, CPU 162 against 159 % (doc/performance.md).
  bool waitAfterNextExtraction = true;
  std::string poseSolver = "full6dof";
  std::string initializer = "twoView";

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, threaded, anyValue, "local mapping in a second thread (live use); false = deterministic");
    PSLAM_FIELD(v, threadedTracking, oneOf({"live", "afterNewPoints"}),
                "threaded: live (keyframes when mapping is idle or after maxFrames) | afterNewPoints (wait for each "
                "keyframe's points)");
    PSLAM_FIELD(v, weakKeyFrameInliers, atLeast(0),
                "threaded live: a keyframe made at fewer inliers waits for its new points (0 = never)");
    PSLAM_FIELD(v, waitAfterNextExtraction, anyValue,
                "threaded: a frame's waits for mapping are taken after the next frame's feature extraction");
    PSLAM_FIELD(v, poseSolver, nonEmpty, "tracking pose solver (full6dof = motion-only BA)");
    PSLAM_FIELD(v, initializer, nonEmpty,
                "map initializer (twoView = H/F two-view initialization; manhattan = §4.4.1, H/F without a Manhattan frame)");
  }
  PSLAM_PARAMS("System")
};

struct SlamParams {
  features::OrbParams orb;
  tracking::InitializerParams initializer;
  tracking::TrackerParams tracking;
  optimize::PoseOptimizationParams poseOptimization;
  optimize::BundleAdjustmentParams bundleAdjustment;
  /// [LocalMapping] (its ba and pointModel are not read from it: localMapping() fills them from their sections).
  mapping::LocalMappingParams mapping;
  landmarks::PointModelParams pointModel;  ///< default heuristic (ORB-SLAM*)
  SystemParams system;
  direct::DirectFeaturesParams directFeatures;  ///< off by default (ORB-SLAM*)
  tracking::ManhattanPathParams manhattan;       ///< off by default (ORB-SLAM*)
  manhattan::ManhattanParams manhattanTracker;   ///< the mean shift of the Manhattan path (Table 4.1)
  lines::LinesParams lines;                     ///< [Lines], off by default
  places::PlacesParams places;                  ///< [Places]: the vocabulary; none by default
  loopclosing::LoopClosingParams loopClosing;   ///< [LoopClosing], off by default

  template <class V>
  void visitSections(V& v) {
    v.section("ORB", orb);
    v.section("Initializer", initializer);
    v.section("Tracking", tracking);
    v.section("PoseOptimization", poseOptimization);
    v.section("BundleAdjustment", bundleAdjustment);
    v.section("LocalMapping", mapping);
    v.section("PointModel", pointModel);
    v.section("System", system);
    v.section("DirectFeatures", directFeatures);
    v.section("Manhattan", manhattan);
    v.section("ManhattanTracker", manhattanTracker);
    v.section("Lines", lines);
    v.section("Places", places);
    v.section("LoopClosing", loopClosing);
  }

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg) const;
  /// Throws params::ParamError `[Section] key = value: reason` for the first invalid value.
  void check() const;
  /// Effective configuration as ini text (for the run report); it reloads to equal parameters.
  std::string toIniText() const;
  /// What the local mapper runs with: [LocalMapping] with [BundleAdjustment] and [PointModel] (the one place they
  /// are copied), and minTriangulationNeighbours 2 with direct points when the config leaves it 0 (a keyframe
  /// tracked by direct points alone shares no keypoint with the map: it triangulates with the two most recent
  /// keyframes).
  mapping::LocalMappingParams localMapping() const;
};

/// Loads and checks an ini file after applying `overrides` (`Section.key=value`, as from a CLI `--set`, later
/// ones win). Errors name the file (`config/slam/kitti.ini: [Tracking] ...`) or the override that set the
/// failing key (`override 'Tracking.x=1': [Tracking] x: unknown key (did you mean ...)`).
SlamParams loadSlamParams(const std::string& iniPath, const std::vector<std::string>& overrides = {});

}  // namespace pslam::system
