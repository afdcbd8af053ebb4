#pragma once
// The seam through which line segments join tracking (thesis §2.4.4 PL-SLAM, §4.4.3: "we use both point and
// line features optimizing their alignment to the current 2d observations via re-projection errors", the
// point-to-line error of eq. 2.59). Before each pose optimization that starts from a pose guess the tracker asks a
// LineSource for the pose factors of the map lines the frame matches at its current estimate
// (frame.T_cam_world); they join the keypoints (and the direct points) in PoseSolveRequest::factors. After the
// frame is tracked the source gets the outlier flags of its factors in the last optimization. The implementation
// (line store, LSD/LBD extraction, matching, triangulation) is pslam::lines::LineFrontEnd; the tracker knows only
// this interface.
#include <memory>
#include <vector>

#include "pslam/map/Map.h"
#include "pslam/optimize/PoseFactor.h"
#include "pslam/tracking/Frame.h"

namespace pslam::tracking {

/// What the lines did in one frame (report.json).
struct LineFrameCounts {
  int detected = 0;  ///< segments extracted from the frame
  int visible = 0;   ///< map lines projected into the frame at the last poseFactors() call
  int factors = 0;   ///< matched lines that entered the frame's last pose optimization
  int inliers = 0;   ///< ... that passed its chi-square test (5.991)
};

class LineSource {
 public:
  virtual ~LineSource() = default;
  /// Point-to-line factors (eq. 2.59) of the map lines matched in `frame` at its current pose estimate; empty when
  /// there are none. `reference` is the tracker's reference keyframe.
  virtual std::vector<std::shared_ptr<const optimize::PoseFactor>> poseFactors(const Frame& frame,
                                                                               const map::Map& map,
                                                                               map::KeyFrameId reference) = 0;
  /// Line inliers with which the lines alone would carry a pose (their share in Tracker::poseSupported).
  virtual int minInliers() const = 0;
  /// The frame was tracked (final pose in frame.T_cam_world); `factorOutliers` per factor of the last
  /// poseFactors() call in the last pose optimization (empty when the lines did not take part). Returns the
  /// frame's counts. Not called in localization-only mode.
  virtual LineFrameCounts afterTracking(const Frame& frame, const map::Map& map,
                                        const std::vector<bool>& factorOutliers) = 0;
};

}  // namespace pslam::tracking
