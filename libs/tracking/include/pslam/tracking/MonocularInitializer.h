#pragma once
// Monocular map initialization (ORB-SLAM's Tracking::MonocularInitialization + CreateInitialMapMonocular,
// thesis §3.4.1): a reference frame is kept until a later frame has enough SearchForInitialization matches and
// the two-view initializer (H/F model selection, Algorithm 1) accepts a reconstruction. The initial map is two
// keyframes and the triangulated points, refined by global BA and scaled so that the median scene depth of the
// first keyframe is 1.
#include <cstddef>
#include <optional>
#include <random>
#include <string>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/features/Matching.h"
#include "pslam/geometry/TwoViewInitializer.h"
#include "pslam/manhattan/TranslationSolver.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/Params.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/MapInitializer.h"

namespace pslam::tracking {

/// [Initializer] manhattan.*: the decoupled initializer of §4.4.1 (ManhattanInitializer).
struct ManhattanInitParams {
  /// With the rotation known, far fewer pairs fix the translation than the H/F models need (§4.4.1).
  int minMatches = 20;
  int minInliers = 15;
  int minTriangulated = 15;
  int minMapPoints = 15;
  /// A triangulated point needs this parallax (ORB-SLAM's two-view test: 1 deg).
  double minParallaxDeg = 1.0;
  /// Median rotation-compensated parallax of the pairs below this: rotation only, the frame is skipped.
  double minMedianParallaxDeg = 0.3;
  /// Largest rotation between the two frames (the Manhattan frames' labels are matched within it).
  double maxRotationDeg = 40.0;
  /// Frames skipped (too few matches / inliers / points) before the reference is replaced (§4.4.1).
  int maxSkippedFrames = 30;
  /// ... or once a skipped frame is this much later than the reference (s; 0 = no limit): the views drift apart
  /// with time, not with the frame count. 1 s is 30 frames at 30 Hz; at a low rate (TUM fr3_cabinet every 20th
  /// frame, 0.67 s apart) it replaces the reference at the second frame that fails.
  double maxSkippedSeconds = 1.0;
  manhattan::TranslationRansacParams ransac;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minMatches, atLeast(2), "SearchForInitialization pairs needed around the rotated reference keypoints");
    PSLAM_FIELD(v, minInliers, atLeast(2), "eq. 4.1 RANSAC inliers needed, else the frame is skipped");
    PSLAM_FIELD(v, minTriangulated, atLeast(2), "inlier pairs triangulated with enough parallax, else the frame is skipped");
    PSLAM_FIELD(v, minMapPoints, atLeast(1), "points after global BA, else the initial map is discarded");
    PSLAM_FIELD(v, minParallaxDeg, inRightOpen(0, 90), "parallax a triangulated point needs (deg)");
    PSLAM_FIELD(v, minMedianParallaxDeg, inRightOpen(0, 90), "median parallax of the pairs below this = rotation only (deg)");
    PSLAM_FIELD(v, maxRotationDeg, inOpen(0, 45), "largest rotation between the initialization frames (deg)");
    PSLAM_FIELD(v, maxSkippedFrames, atLeast(1), "skipped frames before the reference frame is replaced");
    PSLAM_FIELD(v, maxSkippedSeconds, atLeast(0), "... or a skipped frame this much later than the reference (s), 0 = off");
    PSLAM_NESTED(v, ransac);
  }
};

struct InitializerParams {
  int minKeypoints = 100;
  int minMatches = 100;
  int minMapPoints = 100;
  int maxReferenceAge = 30;
  float windowHalfSize = 100.f;
  float nnRatio = 0.9f;
  /// Reference keypoints above this pyramid level are not matched (ORB-SLAM: 0, only the finest level).
  int maxOctave = 0;
  int octaveSlack = 0;
  /// ORB-SLAM2 (monocular) extracts featureFactor x nFeatures keypoints while initializing: only level-0
  /// keypoints take part in SearchForInitialization, and enough matches are needed to keep a reference frame
  /// long enough for parallax to build up.
  double featureFactor = 2.0;
  /// §3.4.1: with a SEMANTIC channel, only keypoints with P(static) >= this take part in the initial map
  /// (p_min^static = 0.8 in the thesis' system); 0 (default, ORB-SLAM*) = every keypoint.
  double minStaticProbability = 0.0;
  geometry::TwoViewParams twoView;
  ManhattanInitParams manhattan;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minKeypoints, atLeast(8), "a frame with fewer keypoints cannot be a reference (ORB-SLAM: 100)");
    PSLAM_FIELD(v, minMatches, atLeast(8), "fewer SearchForInitialization matches: the current frame becomes the reference");
    PSLAM_FIELD(v, minMapPoints, atLeast(1), "fewer points after global BA: the initial map is discarded (ORB-SLAM: 100)");
    PSLAM_FIELD(v, maxReferenceAge, atLeast(1), "frames: an older reference is replaced (not in ORB-SLAM)");
    PSLAM_FIELD(v, windowHalfSize, greaterThan(0), "SearchForInitialization window (px)");
    PSLAM_FIELD(v, nnRatio, inLeftOpen(0, 1), "SearchForInitialization ratio");
    PSLAM_FIELD(v, maxOctave, inClosed(0, 31), "reference keypoints of levels 0..this are matched (ORB-SLAM: 0)");
    PSLAM_FIELD(v, octaveSlack, inClosed(0, 31), "current keypoints within +-this many levels are candidates (ORB-SLAM: 0)");
    PSLAM_FIELD(v, featureFactor, inClosed(1, 10), "keypoints extracted while initializing = this x nFeatures");
    PSLAM_FIELD(v, minStaticProbability, inClosed(0, 1),
                "with SEMANTIC: only keypoints with P(static) >= this initialize the map (§3.4.1: 0.8); 0 = all");
    v.flat(twoView);
    PSLAM_NESTED(v, manhattan);
  }
  PSLAM_PARAMS("Initializer")
};

/// The "twoView" MapInitializer.
class MonocularInitializer : public MapInitializer {
 public:
  MonocularInitializer(const geometry::PinholeCamera& camera, InitializerParams params,
                       optimize::BundleAdjustmentParams baParams);

  /// Feeds one frame. On success `map` (which must be empty) holds the initial map, `current` has its pose and
  /// its matches to the new points, and the reference frame is returned in `referenceOut` with its pose.
  std::string name() const override { return "twoView"; }
  InitializationOutcome process(Frame& current, map::Map& map, std::mt19937& rng,
                                Frame* referenceOut = nullptr) override;
  void reset() override { reference_.reset(); }
  bool hasReference() const override { return reference_.has_value(); }

 private:
  geometry::PinholeCamera camera_;
  InitializerParams params_;
  optimize::BundleAdjustmentParams baParams_;
  geometry::TwoViewInitializer twoView_;
  std::optional<Frame> reference_;
  std::vector<cv::Point2f> prevMatched_;
};

/// §3.4.1: keeps the pairs whose keypoints both have P(static) >= minStaticProbability (a keypoint without
/// semantics counts as static); minStaticProbability <= 0 keeps every pair.
void keepStaticMatches(const Frame& reference, const Frame& current, double minStaticProbability,
                       std::vector<features::IndexMatch>& matches);

/// The map keyframe of a tracked frame (measurements only; associations are added by the caller).
map::KeyFrame toKeyFrame(const Frame& frame);

struct InitialMapOutcome {
  bool accepted = false;
  std::string message;  ///< "<n> points, median depth <d>" or why the map was rejected
  map::KeyFrameId kf1 = map::kNoKeyFrame, kf2 = map::kNoKeyFrame;
};

/// The initial map of every initializer (ORB-SLAM's CreateInitialMapMonocular): `reference` becomes the world
/// frame and keyframe 1, `current` keyframe 2 at T_cur_ref; one point per keypoint pair (reference keypoint,
/// current keypoint) at `points_ref` (reference frame); global BA; points that became outliers are dropped; the
/// map is scaled so that the median depth in keyframe 1 is 1. Fewer than `minMapPoints` points tracked by
/// keyframe 2, or a non-positive median depth: the map is cleared and the outcome not accepted. On success both
/// frames get their pose and their associations with the surviving points.
InitialMapOutcome buildInitialMap(Frame& reference, Frame& current, const Eigen::Isometry3d& T_cur_ref,
                                  const std::vector<std::pair<int, int>>& pairs,
                                  const std::vector<Eigen::Vector3d>& points_ref,
                                  const optimize::BundleAdjustmentParams& baParams, int minMapPoints, map::Map& map);

}  // namespace pslam::tracking
