#pragma once
// The seam through which direct (photometric) map points join tracking (thesis §3.4.2): "in addition to the
// descriptive features we also leverage the direct features in the current keyframe for the pose estimation"
// with the joint error of eq. 3.6 in a multi-resolution, iteratively re-weighted pose optimization. The tracker
// asks a DirectPointSource for the photometric factors of a frame before each pose optimization and hands it the
// final pose afterwards, so that the points' models learn from the frame (§3.4.2: "we use each measurement to
// update our probabilistic measurement model"). The implementation (point store, selection, optical-flow
// matching, model updates) is pslam::direct::DirectFrontEnd; the tracker knows only this interface.
#include <memory>
#include <vector>

#include "pslam/map/Map.h"
#include "pslam/optimize/PhotometricPoseFactor.h"
#include "pslam/tracking/Frame.h"

namespace pslam::tracking {

/// What the direct points did in one frame (report.json).
struct DirectFrameCounts {
  int factors = 0;    ///< active direct points that entered the frame's last pose optimization
  int inliers = 0;    ///< ... that passed its chi-square test (Table 3.2, chi2_P)
  int active = 0;     ///< direct points of the tracked hosts in view that the policy lets tracking use
  int inactive = 0;   ///< ... that it does not (measured only)
  int measured = 0;   ///< model updates applied in this frame (depth from optical flow + triangulation)
  int referenceInView = 0;  ///< active points hosted in the reference keyframe that the frame sees
  int referenceActive = 0;  ///< active points hosted in the reference keyframe
};

class DirectPointSource {
 public:
  virtual ~DirectPointSource() = default;
  /// Photometric factors of the active direct points that `frame` sees at its current pose estimate
  /// (frame.T_cam_world), hosted in `reference` and the most recent keyframes of `map`. Empty when there are none.
  virtual std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> poseFactors(
      const Frame& frame, const map::Map& map, map::KeyFrameId reference) = 0;
  /// Coarsest pyramid level of the coarse-to-fine pose optimization.
  virtual int coarsestLevel() const = 0;
  /// Minimum inlier factors with which the direct points alone let a pose optimization succeed.
  virtual int minInliers() const = 0;
  /// The view counts of the last poseFactors() call (active, inactive, referenceInView, referenceActive; the other
  /// fields 0), without changing any point: what a localization-only frame reports.
  virtual DirectFrameCounts viewCounts() const = 0;
  /// The frame was tracked (final pose in frame.T_cam_world; `factorOutliers` of the last optimization, per
  /// factor of the last poseFactors() call): updates the models of the points the frame measured. Returns the
  /// frame's counts. Not called in localization-only mode.
  virtual DirectFrameCounts afterTracking(const Frame& frame, const map::Map& map,
                                          const std::vector<bool>& factorOutliers) = 0;
};

}  // namespace pslam::tracking
