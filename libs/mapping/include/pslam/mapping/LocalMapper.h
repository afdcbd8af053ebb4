#pragma once
// Local mapping of the monocular SLAM core (thesis §2.4.1 ORB-SLAM, §3.4.3): everything ORB-SLAM's
// LocalMapping::Run does for one new keyframe, run to completion on the caller's thread (no threads, only
// ordered containers, so the same input gives the same map bit for bit):
//   1. processNewKeyFrame   - appearance of the keyframe's points, covisibility, spanning-tree link
//   2. cullRecentPoints     - MapPointCulling of recently created points (landmarks::MapPointPolicy)
//   3. createNewMapPoints   - triangulation against the best covisible keyframes (SearchForTriangulation)
//   4. searchInNeighbors    - fusion of duplicates with first/second-order neighbours (Fuse)
//   5. localBundleAdjustment- optimize::localBundleAdjustment on Map::localWindow(kf, N_lBA)
//   6. cullKeyFrames        - KeyFrameCulling of redundant keyframes (never the first two)
// With the probabilistic map-point model every new observation also updates the point's keypoint model
// (§3.3, inverse depth + matching accuracy) stored in MapPoint::landmarkState. See doc/mapping.md.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/landmarks/MatchingAccuracy.h"
#include "pslam/map/Map.h"
#include "pslam/map/PointUsePolicy.h"
#include "pslam/mapping/MapPointModelPolicy.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/MapAdapter.h"
#include "pslam/optimize/Params.h"

namespace mrpt::config {
class CConfigFileBase;
}

namespace pslam::mapping {

/// Parameters; defaults are ORB-SLAM's LocalMapping.cc / ORBmatcher.cc (monocular) and Table 3.2.
struct LocalMappingParams {
  // ---- CreateNewMapPoints ----
  int covisibleKeyFrames = 20;       ///< key covisibleKeyframes: neighbours to triangulate with (monocular 20)
  int maxDescriptorDistance = 50;    ///< key maxDescriptorDistance: TH_LOW of SearchForTriangulation
  /// key nnRatio: best/second-best distance ratio of SearchForTriangulation; 1 (default) = no ratio test, as
  /// ORB-SLAM2's SearchForTriangulation (the 0.6 it constructs its matcher with is not applied there). Measured on
  /// KITTI 00: 0.6 keeps a third of the triangulations and the tracker then inserts a keyframe almost every frame.
  double nnRatio = 1.0;
  bool checkOrientation = true;      ///< key checkOrientation: rotation-histogram consistency (30 bins)
  double minBaselineRatio = 0.01;    ///< key minBaselineRatio: skip a neighbour if baseline/median depth < this
  double maxParallaxCos = 0.9998;    ///< key maxParallaxCos: rays closer than this are not triangulated
  double chi2Threshold = 5.991;      ///< key chi2Threshold: reprojection test chi2 * sigma^2 (2 DoF, 95 %)
  double scaleConsistencyFactor = 1.5;  ///< key scaleConsistencyFactor: ratioFactor = this * scale factor
  double epipolarMinDistancePixels = 10.0;  ///< key epipolarMinDistance: reject matches near the epipole (x scale)

  // ---- SearchInNeighbors ----
  int fusionNeighbours = 20;         ///< key fusionNeighbours: first-order neighbours (monocular 20)
  int fusionSecondOrderNeighbours = 5;  ///< key fusionSecondOrderNeighbours: per first-order neighbour
  double fusionRadiusPixels = 3.0;   ///< key fusionRadius: search radius th * scale^level (Fuse th = 3)
  /// key fusionDistanceBand: Fuse accepts a point at [(1 - b) minDistance, (1 + b) maxDistance] from the keyframe.
  /// ORB-SLAM's invariance band is 0.2 (default); 0 (the shipped configs) fuses 2.5x less on KITTI 00, the
  /// tracker then inserts fewer keyframes: half the CPU and a better ATE there (doc/slam.md).
  double fusionDistanceBand = 0.2;

  // ---- MapPointCulling and the map-point model ----
  /// Keys of landmarks::MapPointPolicyParams (model = heuristic|masking|probabilistic, minFoundRatio, ...),
  /// KeypointModelParams and MatchingAccuracyParams, all read from the same section. Default: heuristic.
  landmarks::MapPointPolicyParams pointPolicy = [] {
    landmarks::MapPointPolicyParams p;
    p.model = landmarks::MapPointModel::Heuristic;
    return p;
  }();
  landmarks::KeypointModelParams keypointModel;     ///< used when pointPolicy.model == Probabilistic
  landmarks::MatchingAccuracyParams matchingAccuracy;
  double depthPixelNoise = 1.0;      ///< key depthPixelNoise: pixel angle of eq. 2.26 for tau^2

  // ---- KeyFrameCulling ----
  bool cullKeyFrames = true;         ///< key cullKeyFrames
  double redundantFraction = 0.9;    ///< key redundantFraction: cull when this share of points is redundant
  int redundantMinObservers = 3;     ///< key redundantMinObservers: other keyframes at same or finer scale

  // ---- LocalBundleAdjustment (maxLocalKeyFrames = N_lBA = 20, Table 3.2) ----
  bool localBundleAdjustment = true; ///< key localBundleAdjustment
  optimize::BundleAdjustmentParams ba;  ///< loaded by the caller from its own section (not by this struct)

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  /// Throws pslam::Error naming the offending key.
  void check() const;
};

/// What one processKeyFrame() call did.
struct LocalMappingReport {
  int newPoints = 0;            ///< created by createNewMapPoints
  int fusedPoints = 0;          ///< duplicates merged (map::fuseMapPoints) + observations added by fusion
  int culledPoints = 0;         ///< recent points erased by MapPointCulling
  int culledKeyFrames = 0;      ///< redundant keyframes erased
  int baObservationsErased = 0; ///< outlier observations removed after local BA
  int baPointsErased = 0;       ///< points that lost their last observation in local BA
  int landmarkUpdates = 0;      ///< keypoint-model depth updates (masking / probabilistic; 0 for heuristic)
  double baInitialRmsPixels = 0.0, baFinalRmsPixels = 0.0;
  // Timings per step (wall clock, ms).
  double processMs = 0.0, cullPointsMs = 0.0, triangulationMs = 0.0, fusionMs = 0.0, localBaMs = 0.0,
         cullKeyFramesMs = 0.0, totalMs = 0.0;
};

class LocalMapper {
 public:
  /// Keeps a reference to `map` (must outlive the mapper). Calls params.check(). Culling and the BA window ask
  /// `pointUsePolicy` whether a point may be used; null = the MapPointModelPolicy of params.pointPolicy (share it
  /// with the tracker through pointUsePolicy(), so both decide alike).
  LocalMapper(map::Map& map, const LocalMappingParams& params,
              std::shared_ptr<const map::PointUsePolicy> pointUsePolicy = nullptr);
  ~LocalMapper();
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  /// All steps for keyframe `kf`, which the tracker already inserted (Map::addKeyFrame) and linked to its
  /// matched points (Map::addObservation). `recentlyAddedByTracking`: points the tracker created for this
  /// keyframe (e.g. the initial map); they join the recent-point list checked by MapPointCulling.
  /// Throws pslam::Error if `kf` is not in the map.
  LocalMappingReport processKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking);

  /// Forgets the recent-point list (after the tracker cleared the map).
  void reset();

  /// Is the point used for tracking / BA (pointUsePolicy()->mayUse)?
  bool isActive(map::MapPointId point) const;
  /// The policy culling and the BA window ask (the tracker should be given the same one).
  std::shared_ptr<const map::PointUsePolicy> pointUsePolicy() const;
  landmarks::MapPointModel model() const;
  const LocalMappingParams& params() const { return params_; }
  /// Points still under MapPointCulling probation (ascending id).
  const std::vector<map::MapPointId>& recentPoints() const { return recent_; }

  // ---- individual steps (public for tests; processKeyFrame runs them in this order) ----
  void processNewKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking);
  int cullRecentPoints(map::KeyFrameId kf);
  std::vector<map::MapPointId> createNewMapPoints(map::KeyFrameId kf);
  int searchInNeighbors(map::KeyFrameId kf);
  optimize::MapUpdateSummary runLocalBundleAdjustment(map::KeyFrameId kf, optimize::BAResult* result = nullptr);
  int cullKeyFrames(map::KeyFrameId kf);
  /// ORB-SLAM ORBmatcher::Fuse: projects `points` into keyframe `kf` and fuses / adds observations.
  /// Returns the number of fusions plus new observations.
  int fuseInto(map::KeyFrameId kf, const std::vector<map::MapPointId>& points);

 private:
  struct Impl;
  map::Map& map_;
  LocalMappingParams params_;
  std::vector<map::MapPointId> recent_;
  int landmarkUpdates_ = 0;
  std::unique_ptr<Impl> impl_;
};

/// MapPoint::landmarkState <-> landmarks::KeypointState (flat vector of doubles, fixed order, versioned by
/// its length). decode throws pslam::Error naming `context` on a wrong length or invalid values.
std::vector<double> encodeKeypointState(const landmarks::KeypointState& state);
landmarks::KeypointState decodeKeypointState(const std::vector<double>& values, const std::string& context);

}  // namespace pslam::mapping
