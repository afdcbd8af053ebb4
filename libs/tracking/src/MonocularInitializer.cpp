#include "pslam/tracking/MonocularInitializer.h"

#include <algorithm>

#include "pslam/core/Error.h"
#include "pslam/optimize/MapAdapter.h"

namespace pslam::tracking {

PSLAM_DEFINE_PARAMS(InitializerParams)

map::KeyFrame toKeyFrame(const Frame& frame) {
  map::KeyFrame kf;
  kf.timestamp = frame.timestamp;
  kf.T_cam_world = frame.T_cam_world;
  kf.camera = frame.camera;
  kf.keypoints = frame.keypoints;
  kf.descriptors = frame.descriptors.clone();
  kf.scaleFactors = frame.scaleFactors;
  kf.levelSigma2 = frame.levelSigma2;
  kf.semanticProbabilities = frame.semanticProbabilities;
  return kf;
}

void keepStaticMatches(const Frame& reference, const Frame& current, double minStaticProbability,
                       std::vector<features::IndexMatch>& matches) {
  // §3.4.1: potentially moving objects stay out of the initial map. A keypoint without semantics counts as static.
  if (minStaticProbability <= 0.0) return;
  auto isStatic = [&](const Frame& f, int k) {
    return f.semanticProbabilities.empty() ||
           f.semanticProbabilities[static_cast<std::size_t>(k)][0] >= minStaticProbability;
  };
  matches.erase(std::remove_if(matches.begin(), matches.end(),
                               [&](const auto& m) { return !isStatic(reference, m.i1) || !isStatic(current, m.i2); }),
                matches.end());
}

InitialMapOutcome buildInitialMap(Frame& reference, Frame& current, const Eigen::Isometry3d& T_cur_ref,
                                  const std::vector<std::pair<int, int>>& pairs,
                                  const std::vector<Eigen::Vector3d>& points_ref,
                                  const optimize::BundleAdjustmentParams& baParams, int minMapPoints, map::Map& map) {
  require(map.numKeyFrames() == 0, "initializer", "the map must be empty");
  require(pairs.size() == points_ref.size(), "initializer", "one triangulated point per keypoint pair");
  InitialMapOutcome out;
  // ---- initial map: reference = world frame
  Frame& ref = reference;
  ref.T_cam_world = Eigen::Isometry3d::Identity();
  ref.hasPose = true;
  current.T_cam_world = T_cur_ref;
  current.hasPose = true;
  const map::KeyFrameId kf1 = map.addKeyFrame(toKeyFrame(ref));
  const map::KeyFrameId kf2 = map.addKeyFrame(toKeyFrame(current));
  for (std::size_t m = 0; m < pairs.size(); ++m) {
    const map::MapPointId p = map.addMapPoint(kf1, static_cast<std::size_t>(pairs[m].first), points_ref[m]);
    map.addObservation(p, kf2, static_cast<std::size_t>(pairs[m].second));
    map.computeDistinctiveDescriptor(p);
    map.updateNormalAndDepth(p);
  }
  map.connectToSpanningTree(kf2);

  // Global BA of the two-view map (ORB-SLAM: 20 iterations), then drop points that became outliers.
  const optimize::BAProblem problem = optimize::makeGlobalProblem(map);
  const optimize::BAResult ba = optimize::globalBundleAdjustment(problem, baParams);
  optimize::applyResult(map, problem, ba, /*eraseOutliers=*/true);

  // Median depth of the points in the first keyframe; the map is scaled so that it becomes 1.
  std::vector<double> depths;
  const auto& k1 = map.keyFrame(kf1);
  for (map::MapPointId p : map.pointsOf(kf1)) depths.push_back((k1.T_cam_world * map.worldPosition(p)).z());
  std::sort(depths.begin(), depths.end());
  const double medianDepth = depths.empty() ? -1.0 : depths[depths.size() / 2];
  const int tracked = map.trackedMapPoints(kf2, 1);
  if (!(medianDepth > 0) || tracked < minMapPoints) {
    out.message = "initial map rejected: median depth " + std::to_string(medianDepth) + ", " +
                  std::to_string(tracked) + " points";
    map = map::Map();
    return out;
  }
  const double invMedian = 1.0 / medianDepth;
  Eigen::Isometry3d T2 = map.keyFrame(kf2).T_cam_world;
  T2.translation() *= invMedian;
  map.setKeyFramePose(kf2, T2);
  std::vector<map::MapPointId> ids;
  for (const auto& [id, p] : map.mapPoints()) ids.push_back(id);
  for (map::MapPointId id : ids) {
    map.setWorldPosition(id, map.worldPosition(id) * invMedian);
    map.updateNormalAndDepth(id);
  }

  // Associations of both frames with the surviving points.
  ref.resetMatches();
  current.resetMatches();
  ref.T_cam_world = map.keyFrame(kf1).T_cam_world;
  current.T_cam_world = T2;
  const auto& mk1 = map.keyFrame(kf1);
  const auto& mk2 = map.keyFrame(kf2);
  for (std::size_t i = 0; i < mk1.mapPointIds.size(); ++i) ref.mapPointIds[i] = mk1.mapPointIds[i];
  for (std::size_t i = 0; i < mk2.mapPointIds.size(); ++i) current.mapPointIds[i] = mk2.mapPointIds[i];

  out.accepted = true;
  out.kf1 = kf1;
  out.kf2 = kf2;
  out.message = std::to_string(map.numMapPoints()) + " points, median depth " + std::to_string(medianDepth);
  return out;
}

MonocularInitializer::MonocularInitializer(const geometry::PinholeCamera& camera, InitializerParams params,
                                           optimize::BundleAdjustmentParams baParams)
    : camera_(camera), params_(params), baParams_(baParams), twoView_(geometry::PinholeCamera(
                                                               camera.fx, camera.fy, camera.cx, camera.cy,
                                                               camera.width, camera.height),
                                                           params.twoView) {}

InitializationOutcome MonocularInitializer::process(Frame& current, map::Map& map, std::mt19937& rng,
                                                    Frame* referenceOut) {
  InitializationOutcome out;
  auto takeAsReference = [&](const std::string& why) {
    reference_.reset();
    if (static_cast<int>(current.size()) >= params_.minKeypoints) {
      reference_ = current;
      prevMatched_.clear();
      for (const auto& kp : current.keypoints) prevMatched_.push_back(kp.pt);
    }
    out.message = why;
    return out;
  };
  if (!reference_) return takeAsReference("new reference frame");
  if (static_cast<int>(current.size()) < params_.minKeypoints) return takeAsReference("too few keypoints");
  if (current.index > reference_->index + static_cast<std::size_t>(params_.maxReferenceAge))
    return takeAsReference("reference frame too old, replaced");

  features::InitMatchParams mp;
  mp.windowHalfSize = params_.windowHalfSize;
  mp.nnRatio = params_.nnRatio;
  mp.maxOctave1 = params_.maxOctave;
  mp.octaveSlack = params_.octaveSlack;
  std::vector<cv::Point2f> prevMatched = prevMatched_;
  auto matches = features::matchForInitialization(reference_->keypoints, reference_->descriptors,
                                                  current.keypoints, current.descriptors, current.grid,
                                                  prevMatched, mp);
  keepStaticMatches(*reference_, current, params_.minStaticProbability, matches);
  out.matches = static_cast<int>(matches.size());
  if (out.matches < params_.minMatches)
    return takeAsReference("too few initialization matches (" + std::to_string(out.matches) + ")");
  prevMatched_ = prevMatched;

  std::vector<cv::Point2f> ptsRef, ptsCur;
  for (const auto& kp : reference_->keypoints) ptsRef.push_back(kp.pt);
  for (const auto& kp : current.keypoints) ptsCur.push_back(kp.pt);
  std::vector<std::pair<int, int>> pairs;
  for (const auto& m : matches) pairs.emplace_back(m.i1, m.i2);
  const geometry::TwoViewResult tv = twoView_.initialize(ptsRef, ptsCur, pairs, rng);
  if (!tv.success) {
    out.message = std::string("two-view: ") + geometry::toString(tv.failure) + " " + tv.message;
    return out;  // keep the reference, try the next frame (ORB-SLAM)
  }

  std::vector<std::pair<int, int>> triangulatedPairs;
  std::vector<Eigen::Vector3d> points;
  for (std::size_t m = 0; m < matches.size(); ++m)
    if (tv.triangulated[m]) {
      triangulatedPairs.emplace_back(matches[m].i1, matches[m].i2);
      points.push_back(tv.points_ref[m]);
    }
  Frame& ref = *reference_;
  Eigen::Isometry3d T_cur_ref = Eigen::Isometry3d::Identity();
  T_cur_ref.linear() = tv.R_cur_ref;
  T_cur_ref.translation() = tv.t_cur_ref;
  const InitialMapOutcome built =
      buildInitialMap(ref, current, T_cur_ref, triangulatedPairs, points, baParams_, params_.minMapPoints, map);
  if (!built.accepted) {
    out.message = built.message;
    reference_.reset();
    return out;
  }
  out.initialized = true;
  out.kf1 = built.kf1;
  out.kf2 = built.kf2;
  out.message = std::string("initialized (") + geometry::toString(tv.model) + ", " + built.message + ")";
  if (referenceOut) *referenceOut = ref;
  reference_.reset();
  return out;
}

}  // namespace pslam::tracking
