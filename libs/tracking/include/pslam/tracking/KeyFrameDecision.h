#pragma once
// ORB-SLAM's Tracking::NeedNewKeyFrame for a monocular camera (thesis §2.4.1).
#include <cstddef>

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
};

struct KeyFrameDecisionParams {
  int minFrames = 0;              ///< ORB-SLAM mMinFrames
  int maxFrames = 30;             ///< ORB-SLAM mMaxFrames = camera fps
  double refRatio = 0.9;          ///< monocular thRefRatio
  int minInliers = 15;            ///< the frame must still track more than this
};

/// true when a keyframe should be inserted now.
bool needNewKeyFrame(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& params);

}  // namespace pslam::tracking
