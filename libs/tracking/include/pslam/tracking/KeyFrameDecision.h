#pragma once
// ORB-SLAM's Tracking::NeedNewKeyFrame for a monocular camera (thesis §2.4.1).
#include <cstddef>
#include <vector>

#include "pslam/core/Params.h"

namespace pslam::tracking {

struct KeyFrameDecisionInput {
  std::size_t frameIndex = 0;         ///< current frame
  std::size_t lastKeyFrameFrame = 0;  ///< frame index of the last inserted keyframe
  std::size_t lastRelocFrame = 0;     ///< frame index of the last relocalization
  bool relocalizedEver = false;
  std::size_t numKeyFrames = 0;       ///< keyframes in the map
  int referenceTrackedPoints = 0;     ///< points of the reference keyframe seen by >= nMinObs keyframes
  int trackedInliers = 0;             ///< inlier matches of the current frame after local-map tracking
  bool localMappingIdle = true;       ///< always true in the sequential mode
  /// Threaded live mode ([System] weakKeyFrameInliers; 0 in the sequential mode = ORB-SLAM's rule): a frame with
  /// fewer inliers than this needs a keyframe whatever the reference keyframe's count (see needNewKeyFrame).
  int weakInliers = 0;
  /// Each landmark module that hosts landmarks in keyframes (the direct points; §3.4.3: "we only consider active
  /// points ... in the decision"); empty without modules.
  struct ModuleCoverage {
    bool carriedPose = false;  ///< the module's inliers alone would carry the pose (LandmarkModule::minInliers)
    int referenceInView = 0;   ///< active landmarks hosted in the reference keyframe that the frame sees
    int referenceActive = 0;   ///< active landmarks hosted in the reference keyframe
  };
  std::vector<ModuleCoverage> modules;
};

struct KeyFrameDecisionParams {
  int minFrames = 0;
  int maxFrames = 30;
  double refRatio = 0.9;
  int minInliers = 15;
  double directRatio = 0.5;
  /// Threaded mode: a frame that needs a keyframe local mapping cannot take yet, and tracks fewer than this share
  /// of its reference keyframe's points, makes tracking wait until mapping is idle (its BA is asked to stop) so
  /// the next frame makes the keyframe. 1 (default): whenever a needed keyframe waits; 0: never (ORB-SLAM2 skips
  /// the keyframe). A map that falls behind the camera loses it: KITTI 00 unpaced with frames read ahead was lost
  /// within 35-120 frames in 8 of 11 runs with 0 or 0.5; 0.8 kept it, with ATE up to 4 m (doc/performance.md).
  /// The sequential mode never waits (mapping is done before the next frame).
  double waitRatio = 1.0;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minFrames, atLeast(0), "ORB-SLAM mMinFrames");
    PSLAM_FIELD(v, maxFrames, satisfies([this](int m) { return m >= 1 && m >= minFrames; }, "must be >= max(1, minFrames)"),
                "ORB-SLAM mMaxFrames = camera fps");
    PSLAM_FIELD(v, refRatio, inLeftOpen(0, 1), "monocular thRefRatio");
    PSLAM_FIELD(v, minInliers, atLeast(0), "the frame must still track more than this");
    PSLAM_FIELD(v, directRatio, inClosed(0, 1),
                "landmark modules (direct points): a keyframe when the frame sees fewer than this share of the reference "
                "keyframe's active ones");
    PSLAM_FIELD(v, waitRatio, inClosed(0, 1),
                "threaded: wait for mapping when a needed keyframe waits and the frame tracks fewer than this share "
                "of the reference keyframe's points (0 = never)");
  }
};

/// true when a keyframe should be inserted now.
bool needNewKeyFrame(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& params);

/// Threaded mode, for a frame whose needed keyframe mapping is too busy to take: true when tracking should wait
/// for mapping so that the next frame makes it (fewer than waitRatio of the reference keyframe's points, or weak
/// tracking, KeyFrameDecisionInput::weakInliers).
bool keyFrameUrgent(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& params);

}  // namespace pslam::tracking
