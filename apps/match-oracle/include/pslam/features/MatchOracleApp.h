#pragma once
// The `match-oracle` tool: how many ORB correspondences the ground truth allows between frames of a rawlog, and
// how many of them a descriptor search can find. For each pair of frames (k, k + s), s = 1..steps, every
// keypoint of frame k with a depth is moved into frame k + s with the ground-truth poses; a keypoint of frame
// k + s within the search radius is a true correspondence. This bounds what any ORB tracker can match between
// two views, independently of its motion prediction: a dataset whose frames share too few correspondences
// cannot be tracked by matching them, however the search is done.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pslam::features {

struct MatchOracleOptions {
  std::filesystem::path rawlog;       ///< input rawlog with DEPTH (doc/architecture.md, "Data contracts")
  std::filesystem::path groundTruth;  ///< TUM file; default `<stem>_groundtruth.txt` beside the rawlog
  std::filesystem::path config;       ///< SLAM ini: its [ORB] section sets the extractor (required)
  std::vector<std::string> overrides; ///< `Section.key=value`, as slam-run's --set
  int steps = 3;                      ///< pairs (k, k + s) for s = 1..steps
  double radius = 5.0;                ///< [px] at level 0, times the keypoint's level scale
  int maxHamming = 50;                ///< a correspondence is matchable at this distance or less (ORB-SLAM TH_LOW)
  double ratio = 0.8;                 ///< nearest-neighbour ratio of the whole-image descriptor search
  double depthTolerance = 0.05;       ///< relative: a point behind the second frame's depth is occluded
  double maxGroundTruthDt = 0.02;     ///< [s] ground-truth association window
  int minMatches = 30;                ///< pairs reported with at least this many (ORB-SLAM: lost below 30 inliers)
  /// Also align the second keypoint of every matchable correspondence to the first keypoint's patch
  /// (features::alignPatch, the warp from the true poses and the first keypoint's depth) and report where the
  /// aligned positions land: what [LocalMapping] refinement can do for a keyframe observation.
  bool align = false;
  std::filesystem::path outputJson;   ///< optional, written atomically
  /// Optional PNG: the counts of the pairs one frame apart against the first frame's index, and minMatches.
  std::filesystem::path outputPlot;
  bool progress = true;

  /// Throws pslam::Error naming the option.
  void check() const;
};

/// Counts of one frame pair. Each count is a subset of the one before, except `foundByDescriptor` (a subset of
/// `matchable`).
struct PairCounts {
  std::size_t first = 0, second = 0;  ///< frame indices
  int step = 0;
  double baseline = 0;                ///< [m] between the two camera centres (ground truth)
  double rotationDeg = 0;             ///< relative rotation (ground truth)
  std::size_t keypoints = 0;          ///< ORB keypoints of the first frame
  std::size_t withDepth = 0;          ///< ... with a valid depth
  std::size_t visible = 0;            ///< ... in front of the second camera, inside its image, not occluded
  std::size_t repeated = 0;           ///< ... with a keypoint of the second frame within the radius
  std::size_t matchable = 0;          ///< ... whose best descriptor within the radius is <= maxHamming
  std::size_t foundByDescriptor = 0;  ///< ... which the whole-image nearest neighbour (ratio test) also finds
};

/// Where the matchable correspondences land: the second frame's keypoint (the best descriptor within the radius)
/// minus the first frame's keypoint moved there by the true poses and depth, in pixels of the first keypoint's
/// pyramid level (level-0 pixels / its scale). It measures how consistently the extractor places a keypoint on
/// the same surface point in two views, the noise a bundle adjustment of these keypoints sees; an error common
/// to both views (a corner detected half a pixel inside in both) cancels. Pixel-grid rounding alone gives
/// uniform errors of RMS 0.41 level px per view, 0.58 for the difference of two.
struct LevelOffsets {
  int level = 0;
  std::vector<float> dx, dy;  ///< [level px], one entry per matchable correspondence of this level
  /// With --align: the aligned second keypoints (accepted alignments only) against the same true transfer, and
  /// how many alignments were tried.
  std::vector<float> alignedDx, alignedDy;
  std::size_t alignTried = 0;
};

struct MatchOracleResult {
  std::vector<PairCounts> pairs;
  std::vector<LevelOffsets> offsets;  ///< per pyramid level of the first keypoint, every pair and step
  nlohmann::json report;  ///< options, per pair, summary per step
  std::string text;       ///< summary tables: per step, then the offsets per level
};

/// Throws pslam::Error naming the file or option on bad input: no depth, no ground truth for a frame, lens
/// distortion (the projection is a pinhole one), an unreadable config. The JSON and the plot are written only when
/// the run completes (both or neither).
MatchOracleResult runMatchOracle(const MatchOracleOptions& options);

}  // namespace pslam::features
