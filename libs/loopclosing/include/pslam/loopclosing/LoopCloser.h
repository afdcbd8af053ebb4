#pragma once
// Loop closing (ORB-SLAM's LoopClosing, thesis §2.4.1): after local mapping, each keyframe is queried in the
// keyframe database for places seen long before; a candidate must be consistent over several consecutive
// keyframes, then is verified geometrically (vocabulary-guided matches, Sim(3) RANSAC, a projection search of the
// candidate's neighbourhood), and the loop is corrected: the Sim(3) correction propagated to the keyframe's
// neighbourhood, the duplicated points fused, the essential graph (spanning tree, covisibility >= 100, loop
// edges) optimized over Sim(3), and a global bundle adjustment. Sequential: the caller holds the map.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <future>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pslam/core/Params.h"
#include "pslam/geometry/Sim3.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/Params.h"
#include "pslam/places/KeyFrameDatabase.h"

namespace pslam::loopclosing {

struct LoopClosingParams {
  bool enabled = false;
  int minMapKeyFrames = 10;           ///< ORB-SLAM: no loop before 10 keyframes
  int minKeyFramesBetweenLoops = 10;  ///< ORB-SLAM: 10 keyframes after the last loop
  int consistency = 3;                ///< consecutive keyframes whose candidate groups overlap (ORB-SLAM: 3)
  int minBowMatches = 20;             ///< vocabulary-guided point matches for the Sim(3) (ORB-SLAM: 20)
  int minSim3Inliers = 20;            ///< Sim(3) RANSAC inliers (ORB-SLAM: 20)
  int minLoopMatches = 40;            ///< matches after the projection search of the loop neighbourhood (ORB-SLAM: 40)
  int essentialGraphMinWeight = 100;  ///< covisibility edges of the essential graph (ORB-SLAM: 100)
  int essentialGraphIterations = 20;  ///< LM iterations of the Sim(3) pose graph (ORB-SLAM: 20)
  int globalBAIterations = 10;        ///< global BA after the correction (ORB-SLAM: 10); 0 = none
  /// A loop is withdrawn (the map restored as it was) when, after its correction and essential graph, more than
  /// this share of the observations in the loop's keyframes fail the chi-square test with their points refit
  /// (outlierRatio): a false loop bends the map against its own measurements (doc/places.md). 1 = never (ORB-SLAM).
  double maxCorrectionOutlierRatio = 0.15;
  double correctionChi2 = 5.991;      ///< the test of an observation (2 DoF, 95 %; Table 3.2 chi_R)

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, enabled, anyValue, "detect and close loops (needs [Places] vocabulary)");
    PSLAM_FIELD(v, minMapKeyFrames, atLeast(3), "no loop detection before the map has this many keyframes");
    PSLAM_FIELD(v, minKeyFramesBetweenLoops, atLeast(0), "keyframes after a closed loop before the next detection");
    PSLAM_FIELD(v, consistency, atLeast(0), "consecutive keyframes with overlapping candidate groups");
    PSLAM_FIELD(v, minBowMatches, atLeast(3), "vocabulary-guided matches needed for a Sim(3) estimate");
    PSLAM_FIELD(v, minSim3Inliers, atLeast(3), "Sim(3) RANSAC inliers needed");
    PSLAM_FIELD(v, minLoopMatches, atLeast(3), "matches of the loop neighbourhood needed to accept the loop");
    PSLAM_FIELD(v, essentialGraphMinWeight, atLeast(1), "covisibility weight of essential-graph edges");
    PSLAM_FIELD(v, essentialGraphIterations, atLeast(1), "iterations of the Sim(3) pose-graph optimization");
    PSLAM_FIELD(v, globalBAIterations, atLeast(0), "global BA iterations after a correction (0 = none)");
    PSLAM_FIELD(v, maxCorrectionOutlierRatio, inLeftOpen(0, 1),
                "withdraw a loop whose correction leaves more outlier observations than this share (1 = never)");
    PSLAM_FIELD(v, correctionChi2, greaterThan(0), "chi-square test of an observation after a correction");
  }
  PSLAM_PARAMS("LoopClosing")
};

/// The share of the observations (of good points) in keyframes with id >= `firstKeyFrame` that fail the chi-square
/// test `chi2` at their level's sigma (or see their point behind the camera) once each point is refit to all its
/// observations with the keyframe poses held (5 Gauss-Newton steps with Huber weights, delta 2.448, from where it
/// is; the map is not changed); 0 without observations. After a loop correction, with `firstKeyFrame` the matched
/// keyframe: how far the corrected loop's poses disagree with its own measurements. The refit leaves out what the
/// correction did to the points alone (each followed one keyframe), which the global BA would mend anyway.
double outlierRatio(const map::Map& map, map::KeyFrameId firstKeyFrame, double chi2);

/// What loop closing did with one keyframe (report.json "loops").
struct LoopReport {
  map::KeyFrameId keyFrame = map::kNoKeyFrame;
  int candidates = 0;            ///< database candidates
  int consistentCandidates = 0;  ///< of those, consistent over `consistency` keyframes
  /// Per verified candidate: its id, vocabulary matches, Sim(3) inliers, loop matches (-1 = stage not reached).
  struct Verification {
    map::KeyFrameId candidate = map::kNoKeyFrame;
    int bowMatches = -1, sim3Inliers = -1, loopMatches = -1;
  };
  std::vector<Verification> verified;
  bool closed = false;
  /// A verified loop whose correction failed the outlier test (maxCorrectionOutlierRatio): the map was restored.
  bool withdrawn = false;
  /// After the correction and essential graph: the share of the loop keyframes' observations failing the test.
  double correctionOutlierRatio = -1.0;
  map::KeyFrameId matchedKeyFrame = map::kNoKeyFrame;
  double scale = 1.0;               ///< scale of the correction S_cw (the drift in scale)
  double correctionMetres = 0.0;    ///< how far the keyframe's centre moved
  int correctedKeyFrames = 0, fusedPoints = 0, essentialGraphEdges = 0;
  double ms = 0.0;
  /// The global BA of a closed loop: its time (sequential: in place; threaded: the time until it was started on
  /// its own thread, the BA itself is in GlobalBaReport) and whether it runs asynchronously.
  double globalBaMs = 0.0;
  bool globalBaAsynchronous = false;
  /// Sequential mode: the global BA's solver summary (globalBaSummary()); threaded, it is in GlobalBaReport.
  nlohmann::json globalBa;
  /// Threaded: the loop was closed while the previous loop's global BA still ran; that BA was stopped and its
  /// result dropped (ORB-SLAM's), this loop's global BA covers both.
  bool abortedGlobalBa = false;
  /// A closed loop's scale change of every keyframe: camera-frame lengths of keyframe k before the correction are
  /// keyFrameScales[k] x those after (what frames tracked relative to k rescale by). Not in toJson().
  std::map<map::KeyFrameId, double> keyFrameScales;
  nlohmann::json toJson() const;
};

class LoopCloser {
 public:
  /// `vocabulary`'s keyframes must carry their BoW vectors and direct index (the tracker computes them).
  /// Calls params.check().
  LoopCloser(map::Map& map, const LoopClosingParams& params, const optimize::BundleAdjustmentParams& ba,
             std::uint32_t seed);

  /// Loop detection, verification and correction for keyframe `kf` (after local mapping processed it). The
  /// keyframe joins the loop database either way.
  LoopReport processKeyFrame(map::KeyFrameId kf);

  /// Threaded mode: the global BA of a closed loop runs on a thread of its own (ORB-SLAM's fourth thread) on a copy
  /// of the map, so that local mapping and tracking go on while it runs; `ready` is called on that thread when its
  /// result is ready, and applyGlobalBundleAdjustment() writes it back. Without it (sequential mode, the default)
  /// the BA runs in place, and the results are the same bit for bit as before.
  void setAsynchronousGlobalBa(std::function<void()> ready) {
    asynchronousGlobalBa_ = true;
    globalBaReady_ = std::move(ready);
  }
  /// Building block (public for tests): copies the map and starts its global BA on a thread of its own (needs
  /// setAsynchronousGlobalBa), for the loop closed at `loopKeyFrame`.
  void startGlobalBundleAdjustment(map::KeyFrameId loopKeyFrame);
  /// A global BA started by a loop and not yet written back.
  bool globalBaPending() const { return pending_ != nullptr; }
  /// The pending global BA has its result (applyGlobalBundleAdjustment() will not wait for the solver).
  bool globalBaFinished() const { return pending_ && pending_->done.load(); }
  /// Stops the pending global BA after its current iteration and drops its result: the map keeps the loop
  /// correction the BA started from. Returns whether one was pending. It does not wait (it is called with the map
  /// lock held): the stopped job's thread ends on its own and is joined later (reset(), the destructor, or the next
  /// start / write-back once it has ended). A loop closed while a global BA runs calls it once its own correction
  /// passed the outlier test (ORB-SLAM's mbStopGBA, which detaches the thread).
  bool abortGlobalBundleAdjustment();
  /// Writes a finished global BA back (map lock held, between two keyframes' local mapping; waits for the BA if it
  /// still runs): the keyframes and points of the copy take its result, unless the map culled them or moved a
  /// point to another anchor meanwhile; keyframes made since follow the change of their spanning-tree parent (as
  /// ORB-SLAM propagates a global BA's correction), and the points anchored in them with them. Local BA results of
  /// the keyframes in the copy made meanwhile are overwritten (ORB-SLAM alike). Calls the keyframes-moved
  /// callback. Empty when no global BA was pending.
  std::optional<nlohmann::json> applyGlobalBundleAdjustment();
  /// Called, map lock held, when a closed loop's keyframe poses have changed, with the report (its
  /// keyFrameScales) and the keyframe poses just before the change (every keyframe of the map): whoever keeps poses
  /// relative to keyframes (the trajectory, the tracker's last frame) re-expresses them. Without a runner it is
  /// called once, after the global BA; asynchronously, once after the correction (before tracking goes on in the
  /// corrected map) and once when the global BA is written back (scales 1: the BA keeps the map's scale).
  using KeyFramesMoved = std::function<void(const LoopReport& report,
                                            const std::map<map::KeyFrameId, Eigen::Isometry3d>& posesBefore)>;
  void setKeyFramesMoved(KeyFramesMoved callback) { keyFramesMoved_ = std::move(callback); }
  /// Forgets the database and the consistency state (a new map); a running global BA is waited for and dropped.
  void reset();
  ~LoopCloser();
  /// The loop edges of the loops closed so far (kept in the essential graph of later loops), saved with the map as
  /// its extension "loop_edges": u64 count, then per edge two u64 keyframe ids.
  const std::vector<std::pair<map::KeyFrameId, map::KeyFrameId>>& loopEdges() const { return loopEdges_; }
  std::string serializeLoopEdges() const;
  /// Edges whose keyframes were culled since are left out.
  /// Takes the loop edges of a loaded map (serializeLoopEdges' bytes): both keyframes of each must be keyframes of
  /// `map` (the loaded one, before it replaces the live map). Throws pslam::Error ("loop edges: ...") and keeps none
  /// otherwise.
  void restoreLoopEdges(const std::string& bytes, const map::Map& map);
  /// The edges of serializeLoopEdges' bytes, checked against `map` as restoreLoopEdges does (throws the same).
  static std::vector<std::pair<map::KeyFrameId, map::KeyFrameId>> parseLoopEdges(const std::string& bytes,
                                                                                 const map::Map& map);
  static constexpr const char* kMapExtension = "loop_edges";

 private:
  struct Group {
    std::set<map::KeyFrameId> keyFrames;
    int consistency = 0;
  };
  /// Candidates consistent over params_.consistency keyframes (ORB-SLAM's DetectLoop).
  std::vector<map::KeyFrameId> detect(map::KeyFrameId kf, LoopReport& report);
  /// Loop matches of keyframe `kf` (keypoint -> loop point) for `candidate`, with S_cw, if verified.
  bool verify(map::KeyFrameId kf, map::KeyFrameId candidate, geometry::Sim3& S_cw,
              std::map<std::size_t, map::MapPointId>& loopMatches, LoopReport::Verification& v);
  /// Steps 1-4 of the correction (neighbourhood, loop fusion, loop connections, essential graph); returns every
  /// keyframe's pose before it.
  std::map<map::KeyFrameId, Eigen::Isometry3d> correct(map::KeyFrameId kf, map::KeyFrameId matched,
                                                       const geometry::Sim3& S_cw,
                                                       const std::map<std::size_t, map::MapPointId>& loopMatches,
                                                       LoopReport& report);
  /// Projection of `points` into keyframe `kf` at S_cw: per keypoint not in `taken`, the best point within the
  /// window (descriptor <= TH_LOW). Returns keypoint -> point.
  std::map<std::size_t, map::MapPointId> searchByProjection(map::KeyFrameId kf, const geometry::Sim3& S_cw,
                                                            const std::vector<map::MapPointId>& points,
                                                            const std::set<std::size_t>& taken, float radius) const;
  bool usablePoint(map::MapPointId id) const;
  /// What a global BA's solver did (report.json): iterations, whether it was stopped, the reprojection RMS of its
  /// inlier observations before and after (pixels), observations and outliers.
  static nlohmann::json globalBaSummary(const optimize::BAResult& result, std::size_t observations);
  /// The BA parameters of a loop's global BA (params_.globalBAIterations iterations, at least 1).
  optimize::BundleAdjustmentParams globalBaParams() const;
  /// Step 5 of correct(): the global BA, in place or started on its own thread; calls keyFramesMoved_.
  void globalBundleAdjustment(const std::map<map::KeyFrameId, Eigen::Isometry3d>& posesBeforeCorrection,
                              LoopReport& report);

  map::Map& map_;
  LoopClosingParams params_;
  optimize::BundleAdjustmentParams ba_;
  std::mt19937 rng_;
  places::KeyFrameDatabase database_;
  std::vector<Group> groups_;
  map::KeyFrameId lastLoopKeyFrame_ = map::kNoKeyFrame;
  /// Loop edges of the loops closed so far (kept in the essential graph of later loops).
  std::vector<std::pair<map::KeyFrameId, map::KeyFrameId>> loopEdges_;
  KeyFramesMoved keyFramesMoved_;
  bool asynchronousGlobalBa_ = false;
  std::function<void()> globalBaReady_;
  struct PendingGlobalBa {
    optimize::BAProblem problem;
    map::KeyFrameId loopKeyFrame = map::kNoKeyFrame;
    std::chrono::steady_clock::time_point started;
    std::atomic<bool> stop{false};  ///< set by abortGlobalBundleAdjustment(), read by the solver
    std::atomic<bool> done{false};  ///< the solver returned (set before the ready callback)
    /// Declared last, so destroyed first: its destructor waits for the thread, which reads the members above.
    std::future<optimize::BAResult> result;
  };
  std::unique_ptr<PendingGlobalBa> pending_;
  /// Stopped global BAs whose threads may still be ending their current iteration (never applied).
  std::vector<std::unique_ptr<PendingGlobalBa>> stopped_;
  /// Joins the stopped jobs whose solver has returned.
  void reapStoppedGlobalBas();
};

}  // namespace pslam::loopclosing
