#pragma once
// ORB-SLAM's Tracking::NeedNewKeyFrame for a monocular camera (thesis §2.4.1).
#include <cstddef>

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
  // Direct points (§3.4.3: "we only consider active points ... in the decision"); all 0 without them.
  bool directSupported = false;       ///< the direct points alone carried the pose (enough inliers)
  int directReferenceInView = 0;      ///< active points hosted in the reference keyframe that the frame sees
  int directReferenceActive = 0;      ///< active points hosted in the reference keyframe
};

struct KeyFrameDecisionParams {
  int minFrames = 0;
  int maxFrames = 30;
  double refRatio = 0.9;
  int minInliers = 15;
  double directRatio = 0.5;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minFrames, atLeast(0), "ORB-SLAM mMinFrames");
    PSLAM_FIELD(v, maxFrames, satisfies([this](int m) { return m >= 1 && m >= minFrames; }, "must be >= max(1, minFrames)"),
                "ORB-SLAM mMaxFrames = camera fps");
    PSLAM_FIELD(v, refRatio, inLeftOpen(0, 1), "monocular thRefRatio");
    PSLAM_FIELD(v, minInliers, atLeast(0), "the frame must still track more than this");
    PSLAM_FIELD(v, directRatio, inClosed(0, 1),
                "direct points: a keyframe when the frame sees fewer than this share of the reference's active ones");
  }
};

/// true when a keyframe should be inserted now.
bool needNewKeyFrame(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& params);

}  // namespace pslam::tracking
