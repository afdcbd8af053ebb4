#pragma once
// The slam-map application: what is in a saved map (.slammap, libs/map/MapIO.h) and two views of it.
//   info    counts (keyframes, points, observations), camera, format version, file size, extent, keyframe
//           path length and, when the points carry the probabilistic keypoint model (§3.3), statistics of
//           its inlier ratio phi (eq. 3.22) and of the depth updates
//   export  an ASCII PLY of the good map points and the keyframe centres, and a PNG top view of both
//   residuals  the reprojection residuals of the map per pyramid level: a feature-position or calibration
//           bias shows as mean offsets away from zero (doc/features.md)
//   optimum  where the global-BA optimum of the map's own observations lies against ground truth: the keyframe
//           ATE of the saved map, after a global BA from it, and after a global BA started at the ground-truth
//           poses. Two BAs that end at the same cost and error from such different starts say the error left is
//           in the measurements (keypoints, associations), not in the optimization (doc/maps.md)
// A top view needs "up": the map's frame is the first keyframe's camera frame, not a gravity frame, so up is
// taken as the mean of the keyframes' camera -y axes (cameras held roughly level), or, when those disagree,
// as the normal of the plane the keyframe centres span.
// Outputs are prepared before the work and written under temporary names, then renamed (pslam::OutputSet).
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pslam/core/Trajectory.h"
#include "pslam/map/Map.h"

namespace pslam::apps {

/// Statistics of one quantity over the map points (count 0: no value).
struct ValueStats {
  std::size_t count = 0;
  double mean = 0, median = 0, min = 0, max = 0;
  static ValueStats of(std::vector<double> values);
  nlohmann::json toJson() const;
};

struct MapInfo {
  std::filesystem::path file;
  std::uintmax_t fileBytes = 0;
  int formatVersion = 0;
  geometry::PinholeCamera camera;
  std::string vocabulary;                   ///< fingerprint of the vocabulary the map was built with, or empty
  /// What the map carries beside its points (format 2 extensions): name -> bytes.
  std::map<std::string, std::size_t> extensions;
  std::size_t lines = 0, lineKeyFrames = 0;  ///< the line store ("lines"): good lines, keyframes with segments
  std::string linesError;                    ///< why the stored lines do not fit the map (empty: they do)
  std::size_t directPoints = 0, directHosts = 0;  ///< the direct points ("direct_points") and their host keyframes
  std::string directError;                         ///< why the stored direct points do not fit the map
  std::size_t loopEdges = 0;                 ///< "loop_edges"
  std::string loopEdgesError;                ///< why the stored loop edges do not fit the map
  std::size_t keyFrames = 0, mapPoints = 0, badPoints = 0, observations = 0;
  double firstStamp = 0, lastStamp = 0;     ///< keyframe timestamps
  double keyFramePathLength = 0;            ///< along the keyframe centres in timestamp order (map units)
  ValueStats observationsPerPoint;
  Eigen::Vector3d pointMin = Eigen::Vector3d::Zero(), pointMax = Eigen::Vector3d::Zero();  ///< good points
  // The probabilistic keypoint model (empty counts: the points carry none, e.g. a heuristic run).
  std::size_t pointsWithModel = 0, invalidModelStates = 0;
  ValueStats inlierRatio;                   ///< phi of eq. 3.22 (default keypoint-model parameters)
  std::size_t activePoints = 0;             ///< phi >= psi_min
  double psiMin = 0;
  ValueStats depthUpdates;
  nlohmann::json toJson() const;
  std::string toText() const;
};

/// Reprojection residuals of the observations of one pyramid level (or of all): keypoint minus the projection of
/// its point into the keyframe, in pixels (undistorted).
struct LevelResiduals {
  int level = -1;  ///< -1: all levels
  std::size_t count = 0;
  double meanX = 0, meanY = 0;  ///< mean offset
  double meanRadial = 0;        ///< mean offset along the direction from the principal point to the keypoint
  double rms = 0;               ///< root mean square of the residual norm
  double median = 0, p90 = 0;   ///< median and 90th percentile of the residual norm (the tail against the RMS)
  nlohmann::json toJson() const;
};

struct MapResiduals {
  std::filesystem::path file;
  std::vector<LevelResiduals> levels;  ///< the levels with observations, ascending
  LevelResiduals all;
  std::size_t behindCamera = 0;  ///< observations of points behind their keyframe (left out)
  nlohmann::json toJson() const;
  std::string toText() const;
};

/// The residuals of every observation of a good point. A map whose keypoints are unbiased has means near 0 on
/// every level (doc/features.md: ORB-SLAM's level -> image mapping leaves offsets of up to 0.4 px).
MapResiduals mapResiduals(const map::Map& map);
/// Reads `file` (map::loadMap: errors name the file) first.
MapResiduals mapResiduals(const std::filesystem::path& file);

/// Reads `file` (map::loadMap: errors name the file) and summarizes it.
MapInfo mapInfo(const std::filesystem::path& file);
/// The same for a map in memory (file size 0 unless `file` exists).
MapInfo mapInfo(const map::Map& map, const std::filesystem::path& file = {});

/// The inlier ratio phi of every good point that carries a valid keypoint-model state (default parameters of
/// landmarks::KeypointModelParams; the map does not store the run's [PointModel]); by point id.
std::vector<std::pair<map::MapPointId, double>> inlierRatios(const map::Map& map);

struct OptimumOptions {
  std::filesystem::path map;
  std::filesystem::path groundTruth;  ///< TUM, KITTI or EuRoC trajectory (eval::readTrajectory)
  int iterations = 50;                ///< per global BA (Ceres' function tolerance usually ends it earlier)
  std::size_t segments = 8;           ///< the keyframe path in this many stretches for the scale spread; 0 = none
  double maxTimeDifference = 0.01;    ///< seconds between a keyframe's stamp and its ground-truth pose
  void check() const;                 ///< throws pslam::Error naming the option
};

/// One state of the map against the ground truth.
struct OptimumStage {
  std::string name;
  double ate = 0;          ///< keyframe ATE rmse after a Sim(3) alignment, ground-truth units
  double scaleSpread = 0;  ///< largest / smallest Sim(3) scale of the stretches - 1 (0 without segments)
  double cost = 0;         ///< Ceres cost of the global problem (Huber, 1/2 sum of squares) in this state
  double rmsPixels = 0;    ///< reprojection RMS over the global BA's inliers in this state
  int iterations = 0;      ///< of the BA that produced this state (0: none)
  std::size_t outliers = 0;
  nlohmann::json toJson() const;
};

struct MapOptimum {
  std::filesystem::path file, groundTruth;
  std::size_t keyFrames = 0, observations = 0;
  /// "saved", "ba_from_saved", "groundtruth_poses" (depths refit with the poses held), "ba_from_groundtruth".
  std::vector<OptimumStage> stages;
  nlohmann::json toJson() const;
  std::string toText() const;
};

/// The four states above. Every keyframe needs a ground-truth pose within options.maxTimeDifference of its stamp
/// (pslam::Error naming the keyframe and the ground-truth file otherwise); at least 3 keyframes, and 3 per stretch.
MapOptimum mapOptimum(const map::Map& map, const Trajectory& groundTruth, const OptimumOptions& options);
/// Reads options.map (map::loadMap) and options.groundTruth (eval::readTrajectory) first; errors name the file.
MapOptimum mapOptimum(const OptimumOptions& options);

struct MapExportOptions {
  std::filesystem::path map;
  std::filesystem::path ply;  ///< empty: no PLY
  std::filesystem::path png;  ///< empty: no PNG
  int pngWidth = 1200, pngHeight = 900;
};

struct MapExportSummary {
  std::size_t points = 0, keyFrames = 0;
  std::size_t pointsOutsideView = 0;  ///< PNG: far outliers left out of the top view
  bool colouredByInlierRatio = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< the map direction shown as "up" (out of the top view)
  std::string toText() const;
};

/// The map's "up" direction for a top view (see the top of this file). Throws pslam::Error for an empty map.
Eigen::Vector3d mapUpDirection(const map::Map& map);

/// Writes the PLY and/or the PNG (at least one). Throws pslam::Error naming the file at fault; nothing is
/// written unless all outputs succeed.
MapExportSummary exportMap(const MapExportOptions& options);

}  // namespace pslam::apps
