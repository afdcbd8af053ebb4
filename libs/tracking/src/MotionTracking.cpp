#include "pslam/tracking/MotionTracking.h"

#include <algorithm>

#include "pslam/features/Matching.h"
#include "pslam/places/BowMatching.h"
#include "pslam/tracking/ProjectionSearch.h"

namespace pslam::tracking {

int MotionTracking::searchLastFrame(Frame& frame, const Frame& last, float widestFactor) {
  std::vector<ProjectionCandidate> cands;
  for (std::size_t i = 0; i < last.size(); ++i) {
    const map::MapPointId id = last.mapPointIds[i];
    if (last.outlier[i] || !ctx_.measurable(id)) continue;
    const map::MapPoint& p = ctx_.map.mapPoint(id);
    ProjectionCandidate c;
    c.id = id;
    c.p_world = ctx_.map.worldPosition(id);
    c.descriptor = p.descriptor;
    const int oct = last.keypoints[i].octave;
    c.predictedLevel = oct;
    c.minLevel = std::max(0, oct - 1);
    c.maxLevel = oct + 1;
    c.referenceAngle = last.keypoints[i].angle;
    cands.push_back(c);
  }
  ProjectionSearchParams sp;
  auto search = [&](float th) {
    for (auto& c : cands)
      c.radius = th * static_cast<float>(frame.scaleFactors[std::min<int>(c.predictedLevel, frame.numLevels() - 1)]);
    return searchByProjection(frame, frame.T_cam_world, cands, sp);
  };
  int n = search(ctx_.params.motionModelRadius);
  // ORB-SLAM widens the window once (2x); the Manhattan path, whose rotation is known, further.
  for (float factor = 2.f; n < ctx_.params.minMotionMatches && factor <= widestFactor; factor *= 2.f) {
    frame.resetMatches();
    n = search(factor * ctx_.params.motionModelRadius);
  }
  return n;
}

bool MotionTracking::trackWithMotionModel(Frame& frame, const Frame& last, const Eigen::Isometry3d& predicted) {
  frame.resetMatches();
  optimizer_.clearMeasurements();  // only the matches of the attempt that succeeds are measurements
  frame.T_cam_world = predicted;
  const int n = searchLastFrame(frame, last);
  // A module that carries frames alone (the direct points' photometric alignment, §3.4.2) may carry a frame whose
  // keypoint matches are too few.
  if (n < ctx_.params.minMotionMatches && !ctx_.moduleTracksWithoutKeypoints()) return false;
  return optimizer_.poseSupported(optimizer_.optimize(frame, {/*withModules=*/true}), optimizer_.minPoseInliersFor(frame));
}

bool MotionTracking::trackReferenceKeyFrame(Frame& frame, const Frame& last) {
  frame.resetMatches();
  optimizer_.clearMeasurements();
  const map::KeyFrameId ref = ctx_.referenceKeyFrame;
  if (!ctx_.map.hasKeyFrame(ref)) return false;
  const map::KeyFrame& kf = ctx_.map.keyFrame(ref);
  const bool alone = ctx_.moduleTracksWithoutKeypoints();
  const OptimizationMode mode{/*withModules=*/true};
  if (places_.vocabulary() && places_.placesParams().referenceTracking) {
    // ORB-SLAM's SearchByBoW: the keyframe's points against the frame keypoints of the same vocabulary node.
    places_.computeKeyFrameBow(ref);
    places_.computeFrameBow(frame);
    places::NodeMatchParams np;
    np.ratio = ctx_.params.referenceRatio;
    np.maxDistance = ctx_.params.referenceMaxDistance;
    const auto matches = places::matchByVocabularyNode(
        kf.bowFeatures, kf.descriptors, kf.keypoints, frame.bowFeatures, frame.descriptors, frame.keypoints, np,
        [&](std::size_t i) { return ctx_.measurable(kf.mapPointIds[i]); });
    for (const auto& m : matches)
      frame.mapPointIds[static_cast<std::size_t>(m.i2)] = kf.mapPointIds[static_cast<std::size_t>(m.i1)];
    if (static_cast<int>(matches.size()) < ctx_.params.minReferenceMatches && !alone) return false;
    frame.T_cam_world = last.hasPose ? last.T_cam_world : kf.T_cam_world;
    return optimizer_.poseSupported(optimizer_.optimize(frame, mode), optimizer_.minPoseInliersFor(frame));
  }
  // Without a vocabulary: descriptor matching of the keyframe's map points against all frame keypoints (same
  // TH_LOW and ratio as SearchByBoW, exhaustive instead of vocabulary-node restricted).
  std::vector<int> rows;
  for (std::size_t i = 0; i < kf.mapPointIds.size(); ++i)
    if (ctx_.measurable(kf.mapPointIds[i])) rows.push_back(static_cast<int>(i));
  if (static_cast<int>(rows.size()) < ctx_.params.minReferenceMatches && !alone) return false;
  cv::Mat query(static_cast<int>(rows.size()), 32, CV_8U);
  for (std::size_t r = 0; r < rows.size(); ++r) kf.descriptors.row(rows[r]).copyTo(query.row(static_cast<int>(r)));
  features::BruteForceParams bp;
  bp.ratio = ctx_.params.referenceRatio;
  bp.maxDistance = ctx_.params.referenceMaxDistance;
  bp.crossCheck = true;
  const auto matches = rows.empty() || frame.descriptors.empty()
                           ? std::vector<features::IndexMatch>{}
                           : features::matchBruteForce(query, frame.descriptors, bp);
  for (const auto& m : matches) frame.mapPointIds[m.i2] = kf.mapPointIds[rows[m.i1]];
  if (static_cast<int>(matches.size()) < ctx_.params.minReferenceMatches && !alone) return false;
  frame.T_cam_world = last.hasPose ? last.T_cam_world : kf.T_cam_world;
  return optimizer_.poseSupported(optimizer_.optimize(frame, mode), optimizer_.minPoseInliersFor(frame));
}

}  // namespace pslam::tracking
