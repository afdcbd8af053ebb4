#pragma once
// Direct (photometric) map points in the running system (thesis §3.2.2, §3.4, Table 3.2):
//   - selection: DSO's multi-resolution, block-wise gradient selection (features::DirectPointSelector) on every
//     new keyframe and on the first keyframe of a new map (§3.4.1), "only on the key frames";
//   - initial matches: pyramidal Lucas-Kanade optical flow from the host keyframe into its best covisible
//     keyframe, starting at the position the host's map-point depths predict, then an epipolar check that
//     tolerates pose errors (§3.2.2); triangulation as for the keypoints (DLT), inverse depth along the bearing;
//   - the keypoint model of §3.3 for every direct point (same KeypointModel and policy as the ORB points:
//     heuristic / masking / probabilistic), with the matching accuracy of eq. 3.4-3.5 (exposure-normalized SSD of
//     the 9-pixel pattern) and the class evidence of the SEMANTIC channel at the point;
//   - tracking (a tracking::LandmarkModule): the active points of the reference keyframe and the most recent
//     keyframes join the frame's pose optimization with the photometric error of eq. 3.6 (PhotometricPoseFactor),
//     coarse to fine; afterwards every point in view (active or not) is measured: optical flow from its host
//     into the frame, re-triangulated against the host -> one depth update of its model (§3.4.2);
//   - local BA (§3.4.3): the active points hosted in the BA window join it with PhotometricBAFactor in every
//     other window keyframe that sees them; the refined inverse depths become the filter means.
// Points live next to the map; map.slammap carries them as its extension "direct_points" (DirectStoreIO.cpp).
// Everything is deterministic (ordered containers, fixed strides, no randomness). Sources: DirectFrontEnd.cpp (the
// store, the module's stages, measurements), DirectFactors.cpp (pose and BA factors), DirectPointCreation.cpp (new
// points of a keyframe), DirectStoreIO.cpp (the map extension).
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/features/DirectMatching.h"
#include "pslam/features/DirectPointSelector.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/ImagePyramid.h"
#include "pslam/optimize/PhotometricBAFactor.h"
#include "pslam/optimize/PhotometricError.h"
#include "pslam/tracking/LandmarkModule.h"

namespace pslam::direct {

/// [DirectFeatures]: the direct points of §3.2.2 / Table 3.2 (off by default: ORB-SLAM*).
struct DirectFeaturesParams {
  bool enabled = false;
  /// Selection (Algorithm 3) on the keyframe's pyramid: targetPoints = N_F^Direct (Table 3.2: 5000).
  features::DirectSelectorParams selector = [] {
    features::DirectSelectorParams p;
    p.targetPoints = 2000;
    return p;
  }();
  int selectionLevels = 3;        ///< pyramid levels the selection runs on ("multi-resolution", §3.2.2)
  int pyramidLevels = 4;          ///< levels of the photometric pyramids (coarse-to-fine tracking)
  int coarsestLevel = 3;          ///< first level of the coarse-to-fine pose optimization
  int hostKeyFrames = 3;          ///< keyframes whose points track a frame: the reference + the most recent
  int maxTrackingPoints = 800;    ///< active points in one pose optimization (evenly thinned beyond)
  int maxMeasuredPoints = 1500;   ///< points measured (optical flow + depth update) per frame
  int minTrackingInliers = 60;    ///< direct inliers with which a pose succeeds without enough keypoints
  /// Per-frame affine brightness (a, b) from the tracked points' intensities (median / MAD match). Off by
  /// default: on the synthetic room (constant exposure) the estimate's noise raised the ATE from 0.008 to 0.36 m.
  bool estimateAffine = false;
  // Matching for new points (optical flow + epipolar check, §3.2.2). An 11 x 11 window: the flow starts at the
  // position the host's depths predict and runs over 4 pyramid levels, so it needs no wide window to converge; 21
  // (OpenCV's default) cost 3x as much for no better accuracy over KITTI 00 x 5 BA tolerances, room and corridor
  // x 3 seeds, jam x 5 seeds (doc/experiments.md, 2026-12-04).
  int flowWindow = 11;
  int flowLevels = 3;
  double maxEpipolarDistance = 2.0;
  double maxForwardBackward = 1.0;
  double maxParallaxCos = 0.9998;   ///< rays closer than this are not triangulated (ORB-SLAM's)
  double maxReprojection = 2.0;     ///< pixels, in both views
  double minPartnerBaseline = 0.02; ///< partner keyframe: baseline / median scene depth at least this
  // Measurement in tracked frames
  int measureWindow = 9;
  int measureLevels = 1;
  double maxMeasureShift = 20.0;    ///< pixels between the projection and the flow: farther = no measurement
  // Culling
  int cullMinVisible = 5;           ///< pose optimizations before the found ratio is checked
  double cullMinFoundRatio = 0.25;  ///< inliers / entries of pose optimization below this: culled
  // Local BA
  bool localBundleAdjustment = true;
  int maxBaPoints = 300;            ///< active points of the window in local BA (evenly thinned beyond)
  int maxBaTargets = 2;             ///< other window keyframes in which one point is a residual
  int keepImages = 25;              ///< keyframe images kept for measurements and BA (the most recent)
  optimize::PhotometricParams photometric;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, enabled, anyValue, "direct points in tracking and local BA (§3.2.2, Table 3.2)");
    v.flat(selector);
    PSLAM_FIELD(v, selectionLevels, inClosed(1, 6), "pyramid levels of the selection (multi-resolution)");
    PSLAM_FIELD(v, pyramidLevels, inClosed(1, 8), "levels of the photometric pyramids");
    PSLAM_FIELD(v, coarsestLevel, satisfies([this](int l) { return l >= 0 && l < pyramidLevels; }, "must be in [0, pyramidLevels)"),
                "first level of the coarse-to-fine pose optimization");
    PSLAM_FIELD(v, hostKeyFrames, atLeast(1), "keyframes whose points track a frame");
    PSLAM_FIELD(v, maxTrackingPoints, atLeast(1), "active direct points per pose optimization");
    PSLAM_FIELD(v, maxMeasuredPoints, atLeast(0), "direct points measured per frame (model updates)");
    PSLAM_FIELD(v, minTrackingInliers, atLeast(1), "direct inliers that carry a pose alone");
    PSLAM_FIELD(v, estimateAffine, anyValue, "estimate each frame's affine brightness");
    PSLAM_FIELD(v, flowWindow, satisfies([](int w) { return w >= 3 && w % 2 == 1; }, "must be odd and >= 3"),
                "optical-flow window of new points (px)");
    PSLAM_FIELD(v, flowLevels, inClosed(0, 6), "optical-flow pyramid levels of new points");
    PSLAM_FIELD(v, maxEpipolarDistance, greaterThan(0), "epipolar check of new points (px)");
    PSLAM_FIELD(v, maxForwardBackward, greaterThan(0), "forward-backward check of new points (px)");
    PSLAM_FIELD(v, maxParallaxCos, inOpen(0, 1), "new points need rays less parallel than this");
    PSLAM_FIELD(v, maxReprojection, greaterThan(0), "reprojection error of new points in both views (px)");
    PSLAM_FIELD(v, minPartnerBaseline, atLeast(0), "partner keyframe: baseline / median depth at least this");
    PSLAM_FIELD(v, measureWindow, satisfies([](int w) { return w >= 3 && w % 2 == 1; }, "must be odd and >= 3"),
                "optical-flow window of the per-frame measurements (px)");
    PSLAM_FIELD(v, measureLevels, inClosed(0, 6), "optical-flow pyramid levels of the measurements");
    PSLAM_FIELD(v, maxMeasureShift, greaterThan(0), "flow farther than this from the projection is no measurement");
    PSLAM_FIELD(v, cullMinVisible, atLeast(1), "pose optimizations before the found ratio is checked");
    PSLAM_FIELD(v, cullMinFoundRatio, inClosed(0, 1), "cull below this ratio of pose inliers");
    PSLAM_FIELD(v, localBundleAdjustment, anyValue, "direct points in local BA (§3.4.3)");
    PSLAM_FIELD(v, maxBaPoints, atLeast(0), "direct points in one local BA");
    PSLAM_FIELD(v, maxBaTargets, atLeast(1), "window keyframes one point is a residual in");
    PSLAM_FIELD(v, keepImages, atLeast(2), "keyframe images kept (most recent)");
    v.flat(photometric);
  }
  PSLAM_PARAMS("DirectFeatures")
};

/// What the direct points did in one frame (report.json "frames": direct_factors, direct_inliers, ...).
struct DirectFrameCounts {
  int factors = 0;    ///< active direct points that entered the frame's last pose optimization
  int inliers = 0;    ///< ... that passed its chi-square test (Table 3.2, chi2_P)
  int active = 0;     ///< direct points of the tracked hosts in view that the policy lets tracking use
  int inactive = 0;   ///< ... that it does not (measured only)
  int measured = 0;   ///< model updates applied in this frame (depth from optical flow + triangulation)
  int referenceInView = 0;  ///< active points hosted in the reference keyframe that the frame sees
  int referenceActive = 0;  ///< active points hosted in the reference keyframe
  nlohmann::json toJson() const;
};

/// One direct map point: the photometric landmark (host pixel, bearing, inverse depth, host intensities) and its
/// keypoint-model state (mu = inverse depth along the host's z axis, eq. 3.1) with the pose-optimization counters.
struct DirectMapPoint {
  std::shared_ptr<optimize::DirectLandmark> landmark;
  landmarks::KeypointState state;
  std::uint32_t visible = 0;  ///< pose optimizations it entered
  std::uint32_t found = 0;    ///< ... as an inlier
  std::uint32_t updates = 0;  ///< depth measurements applied
  bool bad = false;
};

/// A keyframe that hosts direct points: its images (kept for the most recent keyframes) and affine brightness.
struct DirectHost {
  cv::Mat grey;      ///< undistorted CV_8UC1 (empty once dropped)
  cv::Mat semantic;  ///< undistorted SEMANTIC (CV_8UC3) or empty
  std::shared_ptr<optimize::ImagePyramid> pyramid;  ///< built on demand from grey
  /// Optical-flow pyramid of grey with its gradients for the per-frame measurements (measureWindow /
  /// measureLevels), built on demand and kept only while the host is measured frame after frame.
  std::vector<cv::Mat> flowPyramid;
  optimize::AffineBrightness affine;
  std::vector<DirectMapPoint> points;
};

/// What createPoints() did for one keyframe (mapping log).
struct DirectCreationReport {
  int selected = 0, tracked = 0, created = 0;
  map::KeyFrameId partner = map::kNoKeyFrame;
  double ms = 0.0;  ///< the whole call; its steps (0 when the call ended before them):
  double selectionMs = 0.0;  ///< the multi-resolution selection
  double flowMs = 0.0;       ///< the optical flow into the partner (both passes, epipolar check)
  double pointsMs = 0.0;     ///< triangulation, host intensities and the keypoint models of the new points
};

class DirectFrontEnd : public tracking::LandmarkModule {
 public:
  /// Checks `params` and `pointModel` (pslam::Error naming the key).
  DirectFrontEnd(const DirectFeaturesParams& params, const landmarks::PointModelParams& pointModel,
                 const geometry::PinholeCamera& camera, double depthPixelNoise);

  // ---- tracking::LandmarkModule ----
  std::string name() const override { return "direct"; }
  /// The final (local-map) optimization of every frame; the earlier ones (motion model, reference keyframe) only
  /// when the keypoints alone are too few to carry them, which saves most of their cost.
  bool joins(const tracking::PoseAttempt& attempt) const override;
  tracking::ModulePoseFactors poseFactors(const tracking::Frame& frame, const map::Map& map,
                                          map::KeyFrameId reference) override;
  int coarsestLevel() const override { return params_.coarsestLevel; }
  int minInliers() const override { return params_.minTrackingInliers; }
  /// The photometric alignment can carry a frame whose keypoint matches are too few (§3.4.2).
  bool tracksWithoutKeypoints() const override { return true; }
  tracking::ModuleFrameReport afterTracking(const tracking::Frame& frame, const map::Map& map,
                                            const std::vector<bool>& factorOutliers, bool learn) override;
  void addKeyFrame(const tracking::KeyFrameImages& keyFrame) override;
  /// New points of the keyframe at its refined pose (createPoints), then prune.
  void afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings& timings, nlohmann::json& log) override;
  /// Photometric factors of the active points hosted in local-BA window keyframes (§3.4.3); the window's fixed
  /// keyframes keep their affine brightness fixed.
  std::vector<std::shared_ptr<optimize::BAFactor>> bundleAdjustmentFactors(const map::Map& map,
                                                                          const optimize::BAProblem& problem) override;
  void afterBundleAdjustment(const std::vector<bool>& factorOutliers) override {
    applyBundleAdjustment(factorOutliers);
  }
  void reset() override;
  std::map<std::string, std::size_t> counts() const override;
  std::string mapExtensionName() const override { return kMapExtension; }
  std::optional<std::string> mapExtension() const override;
  std::function<void()> prepareLoad(const std::string& bytes, const map::Map& loaded) override;

  // ---- tracking, as the module's stages call it ----
  /// Photometric factors of the active direct points that `frame` sees at its current pose estimate
  /// (frame.T_cam_world), hosted in `reference` and the most recent keyframes of `map`. Empty when there are none.
  std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> photometricFactors(const tracking::Frame& frame,
                                                                                        const map::Map& map,
                                                                                        map::KeyFrameId reference);
  /// The view counts of the last photometricFactors() call (active, inactive, referenceInView, referenceActive;
  /// the other fields 0), without changing any point: what a localization-only frame reports.
  DirectFrameCounts viewCounts() const;
  /// The frame was tracked (final pose in frame.T_cam_world; `factorOutliers` of the last optimization, per
  /// factor of the last photometricFactors() call): updates the models of the points the frame measured. Returns
  /// the frame's counts.
  DirectFrameCounts afterTracking(const tracking::Frame& frame, const map::Map& map,
                                  const std::vector<bool>& factorOutliers);

  // ---- mapping ----
  /// Registers keyframe `kf` with its (distorted, as in the rawlog) grey and SEMANTIC images; its affine
  /// brightness is that of the last frame poseFactors() prepared when `fromLastFrame`, else (0, 0).
  void addKeyFrame(map::KeyFrameId kf, const cv::Mat& grey, const cv::Mat& semantic, bool fromLastFrame);
  /// Selects direct points in keyframe `kf`, matches them into its best covisible keyframe with an image and
  /// creates the points that triangulate (§3.2.2, §3.4.1, §3.4.3).
  DirectCreationReport createPoints(const map::Map& map, map::KeyFrameId kf);
  /// After local BA: the refined inverse depths become the filter means (§3.4.3); factors flagged as outliers
  /// count as misses of their points. Returns the points updated.
  int applyBundleAdjustment(const std::vector<bool>& factorOutliers);
  /// Drops hosts whose keyframe left the map and images beyond keepImages.
  void prune(const map::Map& map);

  /// The map extension that carries the direct points in map.slammap (map::Map::setExtension).
  static constexpr const char* kMapExtension = "direct_points";
  /// The points that are not culled, with their hosts' affine brightness (not their images), as bytes.
  std::string serialize() const;
  /// Replaces the store by `bytes` (serialize()) after checking every value and that each host is a keyframe of
  /// `map`; pslam::Error "direct points: ..." and the store unchanged when they are damaged. The hosts come back
  /// without images: their points track (host intensities) but are not measured again.
  void restore(const std::string& bytes, const map::Map& map);
  /// The hosts and points of `bytes`, checked as restore() checks them (for loading and for `slam-map info`).
  static std::map<map::KeyFrameId, DirectHost> parse(const std::string& bytes, const map::Map& map);
  /// Replaces the store by hosts parse() returned (their keyframes must be in the map the front end tracks in).
  void restore(std::map<map::KeyFrameId, DirectHost> hosts);

  /// May tracking / BA use the point (policy on its model and counters)?
  bool mayUse(const DirectMapPoint& point, map::KeyFrameId host) const;
  std::size_t numPoints() const;
  const std::map<map::KeyFrameId, DirectHost>& hosts() const { return hosts_; }
  const DirectFeaturesParams& params() const { return params_; }
  /// The world position of a point (its host must be in `map`).
  static Eigen::Vector3d worldPosition(const map::Map& map, const DirectMapPoint& point);

 private:
  struct PointRef {
    map::KeyFrameId host;
    std::size_t index;
  };
  cv::Mat undistort(const cv::Mat& image, bool nearest) const;
  void prepareTrackedFrame(const tracking::Frame& frame);
  std::shared_ptr<optimize::ImagePyramid> hostPyramid(DirectHost& host) const;
  /// As MapPointModelPolicy::classEvidence: the SEMANTIC channel's probabilities at the pixel, or none.
  std::optional<landmarks::ClassVector> classEvidenceAt(const cv::Mat& semantic, const Eigen::Vector2d& pixel) const;
  std::vector<map::KeyFrameId> trackingHosts(const map::Map& map, map::KeyFrameId reference) const;
  landmarks::MapPointRecord recordOf(const DirectMapPoint& point, map::KeyFrameId host) const;

  DirectFeaturesParams params_;
  landmarks::PointModelParams pointModel_;
  geometry::PinholeCamera intrinsics_;
  double depthPixelNoise_ = 1.0;
  bool distorted_ = false;
  cv::Mat undistortX_, undistortY_;
  landmarks::KeypointModel keypointModel_;
  std::unique_ptr<landmarks::MapPointPolicy> policy_;
  std::map<map::KeyFrameId, DirectHost> hosts_;

  // The frame last prepared (poseFactors): its undistorted grey, semantic, pyramid and affine brightness.
  std::size_t frameIndex_ = static_cast<std::size_t>(-1);
  double frameTimestamp_ = 0.0;
  cv::Mat frameGrey_, frameSemantic_;
  std::shared_ptr<optimize::ImagePyramid> framePyramid_;
  optimize::AffineBrightness frameAffine_;
  std::vector<PointRef> lastFactors_;  ///< points of the last poseFactors() factors, in order
  std::vector<PointRef> lastInView_;   ///< every point of the tracking hosts in view at the last call
  int lastActive_ = 0, lastInactive_ = 0, lastReferenceInView_ = 0, lastReferenceActive_ = 0;
  std::vector<PointRef> baPoints_;     ///< points of the last bundleAdjustmentFactors(), per factor
};

}  // namespace pslam::direct
