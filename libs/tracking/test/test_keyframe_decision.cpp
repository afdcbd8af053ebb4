// ORB-SLAM's monocular keyframe decision, case by case.
#include <gtest/gtest.h>

#include "pslam/tracking/KeyFrameDecision.h"

using pslam::tracking::KeyFrameDecisionInput;
using pslam::tracking::KeyFrameDecisionParams;
using pslam::tracking::keyFrameUrgent;
using pslam::tracking::needNewKeyFrame;

namespace {
KeyFrameDecisionInput base() {
  KeyFrameDecisionInput in;
  in.frameIndex = 100;
  in.lastKeyFrameFrame = 95;
  in.numKeyFrames = 10;
  in.referenceTrackedPoints = 200;
  in.trackedInliers = 150;  // < 0.9 * 200
  in.localMappingIdle = true;
  return in;
}
}  // namespace

TEST(KeyFrameDecision, InsertsWhenTrackingWeakensAndMappingIsIdle) {
  KeyFrameDecisionParams p;
  EXPECT_TRUE(needNewKeyFrame(base(), p));
}

TEST(KeyFrameDecision, NotWhileStillTrackingNinetyPercentOfTheReference) {
  KeyFrameDecisionParams p;
  auto in = base();
  in.trackedInliers = 180;  // = 0.9 * 200: not below
  EXPECT_FALSE(needNewKeyFrame(in, p));
  in.trackedInliers = 179;
  EXPECT_TRUE(needNewKeyFrame(in, p));
}

TEST(KeyFrameDecision, NotWithTooFewInliers) {
  KeyFrameDecisionParams p;
  auto in = base();
  in.trackedInliers = 15;
  EXPECT_FALSE(needNewKeyFrame(in, p));
  in.trackedInliers = 16;
  EXPECT_TRUE(needNewKeyFrame(in, p));
}

TEST(KeyFrameDecision, BusyMappingWaitsUntilMaxFrames) {
  KeyFrameDecisionParams p;
  p.maxFrames = 10;
  auto in = base();
  in.localMappingIdle = false;
  EXPECT_FALSE(needNewKeyFrame(in, p));  // 5 frames since the last keyframe
  in.frameIndex = 105;
  EXPECT_TRUE(needNewKeyFrame(in, p));   // c1a: maxFrames passed
}

TEST(KeyFrameDecision, MinFramesAndRelocalizationBlock) {
  KeyFrameDecisionParams p;
  p.minFrames = 8;
  p.maxFrames = 30;
  auto in = base();
  EXPECT_FALSE(needNewKeyFrame(in, p));  // only 5 frames since the last keyframe
  in.frameIndex = 103;
  EXPECT_TRUE(needNewKeyFrame(in, p));
  in.relocalizedEver = true;
  in.lastRelocFrame = 90;
  in.numKeyFrames = 40;                  // map larger than maxFrames keyframes
  EXPECT_FALSE(needNewKeyFrame(in, p));  // within maxFrames of the relocalization
  in.numKeyFrames = 20;
  EXPECT_TRUE(needNewKeyFrame(in, p));
}

TEST(KeyFrameDecision, WeakTrackingNeedsAKeyFrameWhateverTheReferenceCount) {
  // A reference keyframe made on weak tracking: 35 of its points are seen by three keyframes, the frame matches
  // 41 local-map points. The ratio alone never asks for a keyframe (41 > 0.9 * 35) until the frame is lost.
  KeyFrameDecisionParams p;
  auto in = base();
  in.referenceTrackedPoints = 35;
  in.trackedInliers = 41;
  EXPECT_FALSE(needNewKeyFrame(in, p));  // ORB-SLAM's rule (weakInliers 0, the sequential mode)
  in.weakInliers = 60;
  EXPECT_TRUE(needNewKeyFrame(in, p));   // threaded live: fewer than 60 inliers
  in.trackedInliers = 60;
  EXPECT_FALSE(needNewKeyFrame(in, p));  // not below the threshold
  in.trackedInliers = 15;
  EXPECT_FALSE(needNewKeyFrame(in, p));  // too few to make a keyframe from, as in ORB-SLAM
  in.trackedInliers = 41;
  in.localMappingIdle = false;
  EXPECT_FALSE(needNewKeyFrame(in, p));  // mapping busy: c1 still rules (the tracker then waits, urgent)
  EXPECT_TRUE(keyFrameUrgent(in, p));    // weak: wait for mapping so that the next frame makes the keyframe
  in.weakInliers = 0;
  EXPECT_FALSE(keyFrameUrgent(in, p));   // 41 of 35 reference points: not urgent by waitRatio alone
  in.trackedInliers = 34;
  EXPECT_TRUE(keyFrameUrgent(in, p));    // below waitRatio (1) x 35
}
