#include "pslam/tracking/KeyFrameDecision.h"

namespace pslam::tracking {

namespace {
bool weakTracking(const KeyFrameDecisionInput& in) {
  return in.weakInliers > 0 && in.trackedInliers < in.weakInliers;
}
}  // namespace

bool needNewKeyFrame(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& p) {
  // Shortly after a relocalization the map is not trusted enough to extend it.
  if (in.relocalizedEver && in.frameIndex < in.lastRelocFrame + static_cast<std::size_t>(p.maxFrames) &&
      in.numKeyFrames > static_cast<std::size_t>(p.maxFrames))
    return false;
  const bool c1a = in.frameIndex >= in.lastKeyFrameFrame + static_cast<std::size_t>(p.maxFrames);
  const bool c1b = in.frameIndex >= in.lastKeyFrameFrame + static_cast<std::size_t>(p.minFrames) && in.localMappingIdle;
  // Weak tracking (threaded live mode only): a reference keyframe made on weak tracking has few points seen by
  // three keyframes, and frames that match more of the local map's older points than that never fall below the
  // ratio, so no keyframe follows until the camera is lost (KITTI 00 threaded: a keyframe at 40 inliers, then
  // 80 ... 41 inliers and lost six frames later, doc/performance.md).
  const bool c2 = (in.trackedInliers < p.refRatio * in.referenceTrackedPoints || weakTracking(in)) &&
                  in.trackedInliers > p.minInliers;
  // The same test on a landmark module's landmarks (the direct points): the frame still tracks with them but sees
  // too few of the reference keyframe's (a frame whose keypoints are too few to pass c2 is still mapped: the
  // module carries it).
  bool c2module = false;
  for (const KeyFrameDecisionInput::ModuleCoverage& m : in.modules)
    c2module = c2module || (m.carriedPose && m.referenceActive > 0 && m.referenceInView < p.directRatio * m.referenceActive);
  return (c1a || c1b) && (c2 || c2module);
}

bool keyFrameUrgent(const KeyFrameDecisionInput& in, const KeyFrameDecisionParams& p) {
  return in.trackedInliers < p.waitRatio * in.referenceTrackedPoints || weakTracking(in);
}

}  // namespace pslam::tracking
