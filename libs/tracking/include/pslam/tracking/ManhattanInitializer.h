#pragma once
// The decoupled map initializer of thesis §4.4.1 ([System] initializer = manhattan): the rotation between the
// reference frame and the current frame comes from their Manhattan frames (Frame::R_cam_mf, set from the NORMALS
// channel by the mean-shift tracker), the translation direction from eq. 4.1 over the ORB point pairs (linear, SVD,
// inside RANSAC), then the inlier pairs are triangulated and the initial map is built as by the H/F initializer
// (two keyframes, global BA, median depth 1). With the rotation known, matching searches around the rotated
// reference keypoints and a handful of pairs fix the translation, so the map starts under rotation-dominated motion
// and small parallax where the H/F model selection gives up. Verification: a frame with too few translation inliers
// or triangulated points is skipped; a reference that too many frames skipped is replaced. A frame without a
// Manhattan frame goes to the H/F initializer (the fallback of §4.4.2 at initialization).
#include <optional>
#include <string>
#include <vector>

#include "pslam/tracking/MonocularInitializer.h"

namespace pslam::tracking {

/// Per frame, what the Manhattan path of the initializer did (for reports and tests).
struct ManhattanInitDiagnostics {
  int matches = 0;                 ///< SearchForInitialization pairs around the rotated reference keypoints
  int translationInliers = 0;      ///< eq. 4.1 RANSAC inliers
  int triangulated = 0;            ///< inlier pairs triangulated with enough parallax
  double rotationDeg = 0.0;        ///< angle of R_cur_ref from the Manhattan frames
  double medianParallaxDeg = 0.0;  ///< of the rotation-compensated bearings of the pairs
  Eigen::Matrix3d R_cur_ref = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_cur_ref = Eigen::Vector3d::Zero();  ///< unit direction
};

/// The "manhattan" MapInitializer.
class ManhattanInitializer : public MapInitializer {
 public:
  ManhattanInitializer(const geometry::PinholeCamera& camera, InitializerParams params,
                       optimize::BundleAdjustmentParams baParams);
  std::string name() const override { return "manhattan"; }
  InitializationOutcome process(Frame& current, map::Map& map, std::mt19937& rng,
                                Frame* referenceOut = nullptr) override;
  void reset() override;
  bool hasReference() const override { return reference_.has_value() || fallback_.hasReference(); }
  /// The Manhattan path's numbers of the last process() call (zero when it took the H/F path).
  const ManhattanInitDiagnostics& lastDiagnostics() const { return diag_; }

 private:
  InitializationOutcome takeAsReference(Frame& current, const std::string& why);
  InitializationOutcome skip(Frame& current, const std::string& why);

  geometry::PinholeCamera camera_;
  InitializerParams params_;
  optimize::BundleAdjustmentParams baParams_;
  MonocularInitializer fallback_;
  std::optional<Frame> reference_;
  int skipped_ = 0;
  ManhattanInitDiagnostics diag_;
};

}  // namespace pslam::tracking
