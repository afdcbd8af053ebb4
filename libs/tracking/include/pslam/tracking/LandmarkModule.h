#pragma once
// The one seam through which a kind of landmark beside the ORB keypoints joins the system (doc/architecture.md,
// "The plug-in seam"). The direct points of chapter 3 (direct::DirectFrontEnd, thesis §3.2.2, §3.4) and the line
// segments of chapter 4 (lines::LineFrontEnd, eq. 2.59) implement it once; the Tracker, the LocalMapper (as an
// optimize::BAFactorSource) and the System call every registered module, in the order of registration, at each
// stage of a frame and of a keyframe:
//
//   frame     prepareFrame      before tracking, once a map exists (the lines' LSD + LBD)
//             poseFactors       each pose optimization that starts from a pose guess and that the module joins()
//             afterTracking     the frame has its final pose: learn from it (or only count, in localization)
//   keyframe  addKeyFrame       the tracker made a keyframe: its images
//             bundleAdjustmentFactors / afterBundleAdjustment   its local BA
//             afterLocalMapping its local mapping is done: new landmarks of the keyframe, culling
//   map       reset, counts, mapExtension / prepareLoad   (what the module keeps beside the map, in map.slammap)
//
// A module keeps its own store of landmarks next to map::Map and reads the map; it never changes the map.
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/BAFactorSource.h"
#include "pslam/optimize/PhotometricPoseFactor.h"
#include "pslam/optimize/PoseFactor.h"
#include "pslam/tracking/Frame.h"

namespace pslam::tracking {

/// The pose optimization a module is asked to join (LandmarkModule::joins).
struct PoseAttempt {
  bool finalOptimization = false;  ///< the frame's last optimization (after the local-map search)
  int keypointObservations = 0;    ///< usable keypoint matches that enter it
  int minPoseInliers = 0;          ///< [Tracking] minPoseInliers
};

/// What a module adds to one pose optimization.
struct ModulePoseFactors {
  /// Photometric factors, optimized coarse to fine from the module's coarsestLevel() (PoseSolver::solveCoarseToFine).
  std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> pyramid;
  /// Factors at full resolution (e.g. point-to-line reprojection errors).
  std::vector<std::shared_ptr<const optimize::PoseFactor>> factors;
};

/// What a module did in one tracked frame.
struct ModuleFrameReport {
  /// Its counts, flat keys prefixed by the module (report.json "frames", e.g. "direct_inliers").
  nlohmann::json counts = nlohmann::json::object();
  /// Landmarks hosted by the reference keyframe that the module may use, and how many of them the frame sees: the
  /// keyframe decision asks for a keyframe when a module carried the pose but sees too few of them
  /// ([Tracking] keyFrames.directRatio, §3.4.3). Both 0 for a module without hosted landmarks.
  int referenceActive = 0;
  int referenceInView = 0;
};

/// A keyframe the tracker made, with the images of its frame (as in the rawlog: distorted, full size).
struct KeyFrameImages {
  map::KeyFrameId id = map::kNoKeyFrame;
  cv::Mat grey;      ///< CV_8UC1
  cv::Mat semantic;  ///< SEMANTIC (CV_8UC3) or empty
  /// The frame was tracked just before (its matches and brightness are the module's last frame); false for the
  /// two keyframes of a new map.
  bool fromLastFrame = false;
};

class LandmarkModule : public optimize::BAFactorSource {
 public:
  /// The prefix of the module's stage timings ("<name>_factors", "<name>_update").
  virtual std::string name() const = 0;

  // ---- a frame ----
  /// Before tracking, once a map exists; `timings` takes the module's own stages. Default: nothing.
  virtual void prepareFrame(const Frame& /*frame*/, StageTimings& /*timings*/) {}
  /// Does the module take part in `attempt`? Default: every optimization that starts from a pose guess.
  virtual bool joins(const PoseAttempt& /*attempt*/) const { return true; }
  /// Its factors for the frame at its current pose estimate (frame.T_cam_world); `reference` is the tracker's
  /// reference keyframe.
  virtual ModulePoseFactors poseFactors(const Frame& frame, const map::Map& map, map::KeyFrameId reference) = 0;
  /// The coarsest pyramid level of its photometric factors (unused without them).
  virtual int coarsestLevel() const { return 0; }
  /// Inlier factors with which the module alone would carry a pose: its share in the success rule (keypoint
  /// inliers / minKeypointInliers + each module's inliers / minInliers() >= 1).
  virtual int minInliers() const = 0;
  /// Can the module carry a frame whose keypoint matches are too few to be tried (motion model, reference
  /// keyframe, the local map of a frame without keypoint matches)? Default false.
  virtual bool tracksWithoutKeypoints() const { return false; }
  /// The frame was tracked (final pose in frame.T_cam_world). `factorOutliers`: per factor of the last
  /// poseFactors() call ({pyramid, factors} in that order), the flag of the last pose optimization (empty when
  /// the module did not take part). `learn` false (localization): count only, change nothing.
  virtual ModuleFrameReport afterTracking(const Frame& frame, const map::Map& map,
                                          const std::vector<bool>& factorOutliers, bool learn) = 0;

  // ---- a keyframe (bundleAdjustmentFactors / afterBundleAdjustment: optimize::BAFactorSource) ----
  virtual void addKeyFrame(const KeyFrameImages& keyFrame) = 0;
  /// Local mapping of `kf` is done (the keyframe is still in the map): the module's new landmarks and culling.
  /// Its stages go to `timings`, its counts to the keyframe's entry of the mapping log (`log`, flat keys).
  virtual void afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings& timings,
                                 nlohmann::json& log) = 0;

  // ---- the map ----
  /// Forgets every landmark (a new map, a reset, a loaded map).
  virtual void reset() = 0;
  /// Counters of the store for the run summary (e.g. {"lines": n}).
  virtual std::map<std::string, std::size_t> counts() const = 0;
  /// The name of its map extension in map.slammap (map::Map::setExtension); empty: the module saves nothing.
  virtual std::string mapExtensionName() const = 0;
  /// Its store as bytes for the map file; nullopt when it holds nothing.
  virtual std::optional<std::string> mapExtension() const = 0;
  /// Checks a saved store against a loaded map (pslam::Error saying what is wrong, nothing changed) and returns
  /// what installs it, called once the map is in place and the module reset.
  virtual std::function<void()> prepareLoad(const std::string& bytes, const map::Map& loaded) = 0;
};

}  // namespace pslam::tracking
