#pragma once
// Local mapping of the monocular SLAM core (thesis §2.4.1 ORB-SLAM, §3.4.3): everything ORB-SLAM's
// LocalMapping::Run does for one new keyframe, run to completion on the caller's thread (ordered containers, so
// the same input gives the same map bit for bit; in the System's threaded mode the caller holds the map lock and
// lends it back around the triangulation search and the BA solve, see setOutsideMapLock):
//   1. processNewKeyFrame   - appearance of the keyframe's points, covisibility, spanning-tree link
//   2. cullRecentPoints     - MapPointCulling of recently created points (landmarks::MapPointPolicy)
//   3. createNewMapPoints   - triangulation against the best covisible keyframes (SearchForTriangulation)
//   4. searchInNeighbors    - fusion of duplicates with first/second-order neighbours (Fuse)
//   5. localBundleAdjustment- optimize::localBundleAdjustment on Map::localWindow(kf, N_lBA)
//   6. cullKeyFrames        - KeyFrameCulling of redundant keyframes (never the first two)
// With the probabilistic map-point model every new observation also updates the point's keypoint model
// (§3.3, inverse depth + matching accuracy) stored in MapPoint::landmarkState. See doc/mapping.md.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pslam/core/Params.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/map/KeyFrameCulling.h"
#include "pslam/map/Map.h"
#include "pslam/map/PointUsePolicy.h"
#include "pslam/mapping/MapPointModelPolicy.h"
#include "pslam/optimize/BAFactorSource.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/MapAdapter.h"
#include "pslam/optimize/Params.h"

namespace pslam::mapping {

/// Parameters ([LocalMapping]); defaults are ORB-SLAM's LocalMapping.cc / ORBmatcher.cc (monocular) and Table 3.2.
struct LocalMappingParams {
  // ---- CreateNewMapPoints ----
  int covisibleKeyFrames = 20;
  /// A keyframe with fewer covisible keyframes than this triangulates with the most recent keyframes as well
  /// (0 = ORB-SLAM: covisible only). Used with direct points: a keyframe tracked by them alone shares no
  /// keypoints with the map, and without it no keypoint would ever be triangulated again.
  int minTriangulationNeighbours = 0;
  int maxDescriptorDistance = 50;
  /// Best/second-best distance ratio of SearchForTriangulation; 1 (default) = no ratio test, as ORB-SLAM2's
  /// SearchForTriangulation (the 0.6 it constructs its matcher with is not applied there). Measured on KITTI 00:
  /// 0.6 keeps a third of the triangulations and the tracker then inserts a keyframe almost every frame.
  double nnRatio = 1.0;
  bool checkOrientation = true;
  double minBaselineRatio = 0.01;
  double maxParallaxCos = 0.9998;
  double chi2Threshold = 5.991;
  double scaleConsistencyFactor = 1.5;
  double epipolarMinDistancePixels = 10.0;
  /// Threads of the triangulation search of a keyframe pair (its descriptor distances, the step's main cost); the
  /// matches, and so a sequential run's bytes, do not depend on it. KITTI 00 sequential, 2 against the one-thread
  /// search before: 0.88x the wall time at 0.98x the CPU. 1 = in the mapping thread only. The threaded mode's
  /// keyframes depend on how fast mapping is (doc/performance.md).
  int triangulationThreads = 2;

  // ---- SearchInNeighbors ----
  int fusionNeighbours = 20;
  int fusionSecondOrderNeighbours = 5;
  double fusionRadiusPixels = 3.0;
  /// Fuse accepts a point at [(1 - b) minDistance, (1 + b) maxDistance] from the keyframe. ORB-SLAM's
  /// invariance band is 0.2 (default); 0 (the shipped configs) fuses 2.5x less on KITTI 00, the tracker then
  /// inserts fewer keyframes: half the CPU and a better ATE there (doc/slam.md).
  double fusionDistanceBand = 0.2;

  // ---- MapPointCulling and the map-point model ----
  double depthPixelNoise = 1.0;

  // ---- KeyFrameCulling ----
  bool cullKeyFrames = true;
  map::KeyFrameCullingParams culling;

  // ---- LocalBundleAdjustment (maxLocalKeyFrames = N_lBA = 20, Table 3.2) ----
  bool localBundleAdjustment = true;

  // ---- set by the caller from their own sections (SlamParams copies them), not read from [LocalMapping] ----
  optimize::BundleAdjustmentParams ba;   ///< [BundleAdjustment]
  landmarks::PointModelParams pointModel;  ///< [PointModel]; default heuristic (ORB-SLAM*)

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, covisibleKeyFrames, atLeast(1), "neighbours to triangulate with (monocular 20)");
    PSLAM_FIELD(v, minTriangulationNeighbours, atLeast(0),
                "fewer covisible keyframes than this: the most recent ones fill up (0 = covisible only)");
    PSLAM_FIELD(v, maxDescriptorDistance, inClosed(0, 256), "TH_LOW of SearchForTriangulation");
    PSLAM_FIELD(v, nnRatio, inLeftOpen(0, 1), "best/second-best ratio of SearchForTriangulation; 1 = none");
    PSLAM_FIELD(v, checkOrientation, anyValue, "rotation-histogram consistency (30 bins)");
    PSLAM_FIELD(v, minBaselineRatio, atLeast(0), "skip a neighbour if baseline / median depth < this");
    PSLAM_FIELD(v, maxParallaxCos, inOpen(0, 1), "rays closer than this are not triangulated");
    PSLAM_FIELD(v, chi2Threshold, greaterThan(0), "reprojection test chi2 * sigma^2 (2 DoF, 95 %)");
    PSLAM_FIELD(v, scaleConsistencyFactor, atLeast(1), "ratioFactor = this * scale factor");
    PSLAM_FIELD(v, epipolarMinDistancePixels, atLeast(0), "reject matches nearer the epipole (px x scale)");
    PSLAM_FIELD(v, triangulationThreads, atLeast(1),
                "threads of the triangulation search (the same matches for any number)");
    PSLAM_FIELD(v, fusionNeighbours, atLeast(0), "first-order neighbours of Fuse (monocular 20)");
    PSLAM_FIELD(v, fusionSecondOrderNeighbours, atLeast(0), "per first-order neighbour");
    PSLAM_FIELD(v, fusionRadiusPixels, greaterThan(0), "Fuse search radius th x scale^level (th = 3)");
    PSLAM_FIELD(v, fusionDistanceBand, inRightOpen(0, 1), "Fuse distance band b (ORB-SLAM 0.2)");
    PSLAM_FIELD(v, depthPixelNoise, greaterThan(0), "pixel angle of eq. 2.26 for tau^2");
    PSLAM_FIELD(v, cullKeyFrames, anyValue, "KeyFrameCulling on/off");
    v.flat(culling);
    PSLAM_FIELD(v, localBundleAdjustment, anyValue, "local BA on/off");
    v.fromSection("BundleAdjustment", ba);
    v.fromSection("PointModel", pointModel);
  }
  PSLAM_PARAMS("LocalMapping")
};

/// What one processKeyFrame() call did.
struct LocalMappingReport {
  int newPoints = 0;            ///< created by createNewMapPoints
  int fusedPoints = 0;          ///< duplicates merged (map::fuseMapPoints) + observations added by fusion
  int culledPoints = 0;         ///< points erased by MapPointCulling (the sum of the two below)
  int culledRecent = 0;         ///< ... recent points, by the policy's rule (ORB-SLAM's; probabilistic: + phi)
  int culledInlierRatio = 0;    ///< ... points past probation, by the probabilistic model's phi rule
  int culledKeyFrames = 0;      ///< redundant keyframes erased
  int baObservationsErased = 0; ///< outlier observations removed after local BA
  int baPointsErased = 0;       ///< points that lost their last observation in local BA
  int landmarkUpdates = 0;      ///< keypoint-model depth updates (masking / probabilistic; 0 for heuristic)
  double baInitialRmsPixels = 0.0, baFinalRmsPixels = 0.0;
  /// Threaded mode: the tracker reset the map while a computation ran outside the map lock; the steps after it
  /// were not run (the keyframe belongs to a map that no longer exists).
  bool mapChanged = false;
  bool baStopped = false;  ///< local BA ended early by interruptBundleAdjustment
  // Timings per step (wall clock, ms).
  double processMs = 0.0, cullPointsMs = 0.0, triangulationMs = 0.0, fusionMs = 0.0, localBaMs = 0.0,
         cullKeyFramesMs = 0.0, totalMs = 0.0;
};

/// A keypoint pair proposed for triangulation: keypoint i1 of the first keyframe, i2 of the second.
struct PairMatch {
  std::size_t i1 = 0, i2 = 0;
};

/// How searchForTriangulation finds the candidates of a keypoint: every free keypoint of the second keyframe
/// (ORB-SLAM's search without a vocabulary), or only those in grid cells the epipolar band crosses. Both give
/// the same matches (the guided candidates are a superset of those within the band, visited in the same order).
/// VocabularyNode: only the free keypoints of the second keyframe in the same vocabulary node (the keyframes'
/// direct index, KeyFrame::bowFeatures; ORB-SLAM's SearchForTriangulation): fewer candidates, fewer matches
/// (a keypoint without a node, or whose match fell into another node, gets none). Falls back to Guided when either
/// keyframe has no direct index.
enum class TriangulationSearch { Exhaustive, Guided, VocabularyNode };

/// ORB-SLAM's SearchForTriangulation: keypoints of kf1 and kf2 without a map point, on the epipolar line of F12
/// (x1^T F12 x2 = 0; chi2 3.84 with kf2's level sigma^2), far enough from the epipole, best descriptor distance
/// <= maxDescriptorDistance (and the ratio test when nnRatio < 1), one kf1 keypoint per kf2 keypoint, then the
/// rotation histogram. Exposed for tests and benchmarks; local mapping uses Guided. `threads` > 1 splits the
/// descriptor distances over that many threads; the matches are the same for any number.
std::vector<PairMatch> searchForTriangulation(const map::KeyFrame& kf1, const map::KeyFrame& kf2,
                                              const Eigen::Matrix3d& F12, const LocalMappingParams& params,
                                              TriangulationSearch mode, int threads = 1);

class LocalMapper {
 public:
  /// Keeps a reference to `map` (must outlive the mapper). Calls params.check(). Culling and the BA window ask
  /// `pointUsePolicy` whether a point may be used; null = the MapPointModelPolicy of params.pointModel (share it
  /// with the tracker through pointUsePolicy(), so both decide alike).
  LocalMapper(map::Map& map, const LocalMappingParams& params,
              std::shared_ptr<const map::PointUsePolicy> pointUsePolicy = nullptr);
  ~LocalMapper();
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  /// All steps for keyframe `kf`, which the tracker already inserted (Map::addKeyFrame) and linked to its
  /// matched points (Map::addObservation). `recentlyAddedByTracking`: points the tracker created for this
  /// keyframe (e.g. the initial map); they join the recent-point list checked by MapPointCulling.
  /// `measuredByTracking`: the tracker already applied this keyframe's measurements to the points' models
  /// (Tracker::track does for every frame it tracks; the two keyframes of the initial map are not).
  /// Throws pslam::Error if `kf` is not in the map.
  LocalMappingReport processKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking,
                                     bool measuredByTracking = false);

  /// Forgets the recent-point list (after the tracker cleared the map).
  void reset();

  /// Other landmark kinds and priors in local BA (§3.4.3: direct points; eq. 2.59: lines; §4.4: Manhattan rotation
  /// priors): each source adds its factors to the window's problem (BAProblem::factors) after those of the sources
  /// added before, and gets the outlier flags of its own factors after the solve. None: keypoints only.
  void addBAFactorSource(std::shared_ptr<optimize::BAFactorSource> source);

  /// Threaded mode (the System shares the map between tracking and this mapper under one lock held for the whole
  /// processKeyFrame call): `runner` runs a computation that reads no map data, only copies taken under the lock
  /// (the triangulation search of a keyframe pair, the local BA solve), with the lock released, and returns false
  /// when the map was reset meanwhile; processKeyFrame then stops at once and says so (LocalMappingReport::
  /// mapChanged). No runner (sequential mode, the default): the computations run in place, on the live keyframes,
  /// and the results are the same bit for bit as with a runner that changes nothing.
  using OutsideMapLock = std::function<bool(const std::function<void()>& computation)>;
  void setOutsideMapLock(OutsideMapLock runner) { outsideMapLock_ = std::move(runner); }
  /// ORB-SLAM's InterruptBA, callable from any thread: the running (or next) local BA of the keyframe being mapped
  /// ends after its current iteration, without the second pass. Cleared when the next keyframe's mapping starts.
  void interruptBundleAdjustment() { stopBundleAdjustment_ = true; }
  /// Called (map lock held) once the keyframe's new points are in the map: after triangulation and fusion, before
  /// local BA. Threaded mode: tracking may go on from there.
  void setNewPointsReady(std::function<void(map::KeyFrameId)> callback) { newPointsReady_ = std::move(callback); }
  /// How triangulation finds candidate keypoint pairs (default Guided; VocabularyNode when the keyframes carry the
  /// vocabulary's direct index, [Places] triangulation).
  void setTriangulationSearch(TriangulationSearch mode) { triangulationSearch_ = mode; }

  /// Is the point used for tracking / BA (pointUsePolicy()->mayUse)?
  bool isActive(map::MapPointId point) const;
  /// The policy culling and the BA window ask (the tracker should be given the same one).
  std::shared_ptr<const map::PointUsePolicy> pointUsePolicy() const;
  landmarks::MapPointModel model() const;
  const LocalMappingParams& params() const { return params_; }
  /// Points still under MapPointCulling probation (ascending id).
  const std::vector<map::MapPointId>& recentPoints() const { return recent_; }

  // ---- individual steps (public for tests; processKeyFrame runs them in this order) ----
  void processNewKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recentlyAddedByTracking,
                          bool measuredByTracking = false);
  /// Returns the points erased; `byInlierRatio` (optional) gets those of the probabilistic model's own rule on
  /// points past probation.
  int cullRecentPoints(map::KeyFrameId kf, int* byInlierRatio = nullptr);
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
  std::vector<std::shared_ptr<optimize::BAFactorSource>> baSources_;
  OutsideMapLock outsideMapLock_;
  TriangulationSearch triangulationSearch_ = TriangulationSearch::Guided;
  std::function<void(map::KeyFrameId)> newPointsReady_;
  bool mapChanged_ = false;  ///< the map was reset while a computation ran outside the lock
  std::atomic<bool> stopBundleAdjustment_{false};
  /// Runs `computation` through outsideMapLock_ (or in place); false (and mapChanged_) when the map was reset.
  bool runOutsideMapLock(const std::function<void()>& computation);
  std::unique_ptr<Impl> impl_;
};

/// MapPoint::landmarkState <-> landmarks::KeypointState (flat vector of doubles, fixed order, versioned by
/// its length). decode throws pslam::Error naming `context` on a wrong length or invalid values.
std::vector<double> encodeKeypointState(const landmarks::KeypointState& state);
landmarks::KeypointState decodeKeypointState(const std::vector<double>& values, const std::string& context);

}  // namespace pslam::mapping
