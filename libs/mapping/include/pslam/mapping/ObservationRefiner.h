#pragma once
// Sub-pixel refinement of keyframe observations against their map point's anchor observation (SVO's feature
// alignment, features::alignPatch). Every map point hangs on one keypoint of its anchor keyframe (eq. 3.1); the
// other keyframes observe it through keypoints detected on their own pixel grids, whose positions scatter by about
// 0.8 level pixels RMS around where that same scene point appears (doc/features.md). Local mapping hands each new
// keyframe here after triangulation and fusion, before local BA: for every point the keyframe sees, each of its
// observations in a keyframe whose image is kept is moved to where the anchor's patch aligns, with the affine warp
// that the current poses and the point's depth predict. Bundle adjustment then fits measurements of one scene point
// rather than of several nearby ones.
//
// The images: each keyframe's grey image as a pyramid with the ORB scale factors, the last `cachedKeyFrames` of them
// (an observation in an older keyframe, or against an anchor whose image is gone, stays as detected). With lens
// distortion the images are undistorted to the ideal pinhole camera of the keypoints first.
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/features/PatchAlignment.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"

namespace pslam::mapping {

/// [LocalMapping] refinement.* keys.
struct ObservationRefinementParams {
  bool enabled = false;
  int cachedKeyFrames = 40;  ///< keyframe images kept (the most recent ones)
  features::PatchAlignmentParams alignment;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, enabled, anyValue, "align keyframe observations to their point's anchor patch (doc/mapping.md)");
    PSLAM_FIELD(v, cachedKeyFrames, atLeast(2), "keyframe images kept for the alignment (most recent)");
    v.flat(alignment);
  }
};

/// What one refine() call did.
struct RefinementCounts {
  int tried = 0;           ///< observations aligned (not aligned before against the same anchor observation)
  int refined = 0;         ///< ... whose alignment was accepted and moved the keypoint
  double sumShift = 0.0;   ///< sum of the accepted moves (level pixels)
};

class ObservationRefiner {
 public:
  /// `camera`: the rawlog's camera (its distortion says whether the images need undistorting). Calls params.check
  /// through the caller's LocalMappingParams.
  ObservationRefiner(const ObservationRefinementParams& params, const geometry::PinholeCamera& camera);

  /// Keeps keyframe `id`'s image (the raw CV_8UC1 image its keypoints were extracted from) as a pyramid with the
  /// keyframe's scale factors. Thread-safe (the tracking thread adds, local mapping refines). Throws pslam::Error on
  /// an empty image or one of another size than the camera.
  void addKeyFrame(map::KeyFrameId id, const cv::Mat& grey, const std::vector<double>& scaleFactors);

  /// Refines the observations of the points keyframe `kf` sees (see the file comment). Changes only keypoint
  /// positions (KeyFrame::keypoints[i].pt) of kept keyframes. refine() and reset() run under the caller's map lock
  /// (local mapping; the tracker's map reset), never at the same time.
  RefinementCounts refine(map::Map& map, map::KeyFrameId kf);

  /// Forgets every image and alignment (after the map was reset).
  void reset();

  /// Keyframe images kept and their bytes (memory reports).
  std::size_t keptKeyFrames() const;
  std::size_t keptBytes() const;

 private:
  using Pyramid = std::shared_ptr<const features::ScalePyramid>;
  ObservationRefinementParams params_;
  geometry::PinholeCamera camera_;
  cv::Mat undistortMapX_, undistortMapY_;  ///< empty without distortion
  mutable std::mutex mutex_;               ///< guards images_
  std::map<map::KeyFrameId, Pyramid> images_;
  /// Per kept keyframe: keypoint -> the anchor observation (keyframe, keypoint) it was last aligned to.
  std::map<map::KeyFrameId, std::map<std::size_t, std::pair<map::KeyFrameId, std::size_t>>> alignedTo_;
};

}  // namespace pslam::mapping
