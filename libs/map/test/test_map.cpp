// Map bookkeeping invariants: symmetric observations, exact covisibility weights after add / erase / fuse,
// re-anchoring that keeps world positions, spanning tree repair, local windows, appearance helpers.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "SyntheticMap.h"
#include "pslam/core/Error.h"

using namespace pslam::map;
using namespace pslam::map::testing;

namespace {

// Brute-force covisibility from the points' observation lists.
int bruteForceShared(const Map& map, KeyFrameId a, KeyFrameId b) {
  int n = 0;
  for (const auto& [id, p] : map.mapPoints()) n += (p.isObservedBy(a) && p.isObservedBy(b)) ? 1 : 0;
  return n;
}

void expectWeightsExact(const Map& map) {
  for (const auto& [a, kfa] : map.keyFrames())
    for (const auto& [b, kfb] : map.keyFrames()) {
      if (a == b) continue;
      ASSERT_EQ(map.covisibilityWeight(a, b), bruteForceShared(map, a, b)) << a << " " << b;
    }
}

std::map<MapPointId, Eigen::Vector3d> worldPositions(const Map& map) {
  std::map<MapPointId, Eigen::Vector3d> out;
  for (const auto& [id, p] : map.mapPoints()) out[id] = map.worldPosition(id);
  return out;
}

}  // namespace

TEST(Map, BuildKeepsInvariantsAndExactPositions) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(6, 300, scene);
  ASSERT_NO_THROW(map.checkInvariants());
  EXPECT_EQ(map.numKeyFrames(), 6u);
  EXPECT_GT(map.numMapPoints(), 200u);
  expectWeightsExact(map);
  for (std::size_t i = 0; i < scene.points.size(); ++i) {
    if (scene.mapPointOfScene[i] == kNoMapPoint) continue;
    const MapPoint& p = map.mapPoint(scene.mapPointOfScene[i]);
    EXPECT_NEAR((map.worldPosition(p.id) - scene.points[i]).norm(), 0.0, 1e-9);
    EXPECT_NEAR(p.bearing.norm(), 1.0, 1e-12);
    // The inverse depth along z of eq. 3.1 is 1/z of the point in the anchor camera.
    const Eigen::Vector3d pc = map.keyFrame(p.anchorKeyFrame).T_cam_world * scene.points[i];
    EXPECT_NEAR(p.inverseDepthAlongZ(), 1.0 / pc.z(), 1e-12);
  }
  // Every keyframe but the root hangs in the spanning tree.
  for (const auto& [id, kf] : map.keyFrames()) {
    if (id != map.rootKeyFrame()) {
      EXPECT_NE(kf.parent, kNoKeyFrame) << id;
    }
  }
}

TEST(Map, EraseObservationAndKeyFrameKeepWeightsAndReanchor) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(6, 300, scene);
  const auto before = worldPositions(map);

  // Erase a few single observations, including anchor ones.
  int anchorsMoved = 0;
  std::vector<MapPointId> ids;
  for (const auto& [id, p] : map.mapPoints()) ids.push_back(id);
  for (std::size_t i = 0; i < ids.size(); i += 7) {
    const MapPoint& p = map.mapPoint(ids[i]);
    if (p.numObservations() < 2) continue;
    const KeyFrameId anchor = p.anchorKeyFrame;
    EXPECT_FALSE(map.eraseObservation(ids[i], anchor));
    const MapPoint& q = map.mapPoint(ids[i]);
    EXPECT_NE(q.anchorKeyFrame, anchor);
    EXPECT_EQ(q.observations.at(q.anchorKeyFrame), q.anchorKeypoint);
    ++anchorsMoved;
  }
  EXPECT_GT(anchorsMoved, 10);
  ASSERT_NO_THROW(map.checkInvariants());
  expectWeightsExact(map);

  // Erase a middle keyframe: its points re-anchor, the spanning tree is repaired.
  const KeyFrameId victim = scene.keyframeIds[2];
  int anchoredInVictim = 0;
  for (const auto& [id, p] : map.mapPoints()) anchoredInVictim += p.anchorKeyFrame == victim ? 1 : 0;
  EXPECT_GT(anchoredInVictim, 0);
  map.eraseKeyFrame(victim);
  EXPECT_FALSE(map.hasKeyFrame(victim));
  ASSERT_NO_THROW(map.checkInvariants());
  expectWeightsExact(map);
  for (const auto& [id, p] : map.mapPoints()) {
    EXPECT_NE(p.anchorKeyFrame, victim);
    EXPECT_FALSE(p.isObservedBy(victim));
    EXPECT_NEAR((map.worldPosition(id) - before.at(id)).norm(), 0.0, 1e-9) << "point " << id;
  }
  for (const auto& [id, kf] : map.keyFrames()) {
    if (id == map.rootKeyFrame()) continue;
    EXPECT_NE(kf.parent, kNoKeyFrame) << "keyframe " << id << " left out of the spanning tree";
    EXPECT_NE(kf.parent, victim);
  }
  EXPECT_THROW(map.eraseKeyFrame(map.rootKeyFrame()), pslam::Error);
}

TEST(Map, ErasedKeyFramePoseFollowsItsParentChain) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(6, 300, scene);
  const KeyFrameId a = scene.keyframeIds[2], b = scene.keyframeIds[3];
  const Eigen::Isometry3d Ta = map.keyFrame(a).T_cam_world, Tb = map.keyFrame(b).T_cam_world;
  ASSERT_TRUE(map.keyFramePoseIncludingErased(a).has_value());
  EXPECT_TRUE(map.keyFramePoseIncludingErased(a)->isApprox(Ta));
  EXPECT_FALSE(map.keyFramePoseIncludingErased(999).has_value());

  map.eraseKeyFrame(a);
  map.eraseKeyFrame(b);  // b's parent may have been a: the chain then has two erased links
  ASSERT_TRUE(map.keyFramePoseIncludingErased(a).has_value());
  EXPECT_NEAR((map.keyFramePoseIncludingErased(a)->matrix() - Ta.matrix()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((map.keyFramePoseIncludingErased(b)->matrix() - Tb.matrix()).norm(), 0.0, 1e-12);

  // Moving every living keyframe by one rigid motion (what a bundle adjustment's gauge change does) moves the
  // erased ones with it: their poses are kept relative to the spanning tree.
  Eigen::Isometry3d G = Eigen::Isometry3d::Identity();
  G.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.4).normalized()).toRotationMatrix();
  G.translation() = Eigen::Vector3d(0.5, -1.0, 2.0);
  std::vector<KeyFrameId> living;
  for (const auto& [id, kf] : map.keyFrames()) living.push_back(id);
  for (KeyFrameId id : living) map.setKeyFramePose(id, map.keyFrame(id).T_cam_world * G);
  EXPECT_NEAR((map.keyFramePoseIncludingErased(a)->matrix() - (Ta * G).matrix()).norm(), 0.0, 1e-9);
  EXPECT_NEAR((map.keyFramePoseIncludingErased(b)->matrix() - (Tb * G).matrix()).norm(), 0.0, 1e-9);
}

TEST(Map, ErasedKeyFrameLinksFollowASimilarityCorrection) {
  // A scale correction of the whole map: the erased keyframes, their links rescaled, sit where it puts them.
  SyntheticScene scene;
  Map map = buildSyntheticMap(6, 300, scene);
  const KeyFrameId a = scene.keyframeIds[2], b = scene.keyframeIds[3];
  const Eigen::Isometry3d Ta = map.keyFrame(a).T_cam_world, Tb = map.keyFrame(b).T_cam_world;
  map.eraseKeyFrame(a);
  map.eraseKeyFrame(b);
  // World points move by x' = s x (a pure scale of the world): T_cw' = [R | s t], i.e. camera-frame lengths grow
  // by s, the scale of the correction is 1 / s.
  const double s = 1.7;
  std::map<KeyFrameId, double> scales;
  for (const auto& [id, kf] : map.keyFrames()) scales[id] = 1.0 / s;
  std::vector<KeyFrameId> living;
  for (const auto& [id, kf] : map.keyFrames()) living.push_back(id);
  for (KeyFrameId id : living) {
    Eigen::Isometry3d T = map.keyFrame(id).T_cam_world;
    T.translation() *= s;
    map.setKeyFramePose(id, T);
  }
  map.rescaleErasedKeyFrameLinks(scales);
  Eigen::Isometry3d Ta2 = Ta, Tb2 = Tb;
  Ta2.translation() *= s;
  Tb2.translation() *= s;
  EXPECT_NEAR((map.keyFramePoseIncludingErased(a)->matrix() - Ta2.matrix()).norm(), 0.0, 1e-9);
  EXPECT_NEAR((map.keyFramePoseIncludingErased(b)->matrix() - Tb2.matrix()).norm(), 0.0, 1e-9);
}

TEST(Map, ReanchorPointAtInfinityKeepsDirection) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(3, 50, scene);
  const KeyFrameId a = scene.keyframeIds[0], b = scene.keyframeIds[1];
  // A free keypoint pair: add one keypoint to each keyframe by re-adding frames is heavy; use a seen point.
  MapPointId pid = kNoMapPoint;
  for (const auto& [id, p] : map.mapPoints())
    if (p.anchorKeyFrame == a && p.isObservedBy(b)) {
      pid = id;
      break;
    }
  ASSERT_NE(pid, kNoMapPoint);
  map.setInverseDepth(pid, 0.0);
  const Eigen::Vector3d dirWorld =
      map.keyFrame(a).T_cam_world.linear().transpose() * map.mapPoint(pid).bearing;
  map.reanchor(pid, b);
  const Eigen::Vector3d dirWorldAfter =
      map.keyFrame(b).T_cam_world.linear().transpose() * map.mapPoint(pid).bearing;
  EXPECT_NEAR((dirWorld - dirWorldAfter).norm(), 0.0, 1e-12);
  EXPECT_EQ(map.mapPoint(pid).inverseDepth, 0.0);
  EXPECT_NO_THROW(map.checkInvariants());
}

TEST(Map, FuseDuplicatesMovesObservations) {
  // Two keyframes, each with two keypoints on the same world point: one point per keyframe pair
  // creates a duplicate situation in keyframe 1 and a disjoint one in keyframe 2.
  Map map;
  const pslam::geometry::PinholeCamera cam = testCamera();
  std::vector<KeyFrameId> kfs;
  for (int f = 0; f < 3; ++f) {
    KeyFrame kf;
    kf.T_cam_world = poseOnLine(f);
    kf.camera = cam;
    kf.setPyramid(8, 1.2);
    for (int k = 0; k < 4; ++k) kf.keypoints.emplace_back(cv::Point2f(100.f + 10 * k, 100.f), 31.f, 0.f, 1.f, k);
    kf.descriptors = cv::Mat(4, 32, CV_8UC1, cv::Scalar(f * 10));
    kfs.push_back(map.addKeyFrame(std::move(kf)));
  }
  const Eigen::Vector3d pw(0.1, 0.2, 5.0);
  const MapPointId kept = map.addMapPoint(kfs[0], 0, pw);
  map.addObservation(kept, kfs[1], 0);
  const MapPointId dropped = map.addMapPoint(kfs[1], 1, pw + Eigen::Vector3d(0.01, 0, 0));
  map.addObservation(dropped, kfs[2], 1);
  map.mutableMapPoint(dropped).visibleCount = 5;
  map.mutableMapPoint(dropped).foundCount = 3;
  EXPECT_EQ(map.covisibilityWeight(kfs[0], kfs[1]), 1);
  EXPECT_EQ(map.covisibilityWeight(kfs[1], kfs[2]), 1);
  EXPECT_EQ(map.covisibilityWeight(kfs[0], kfs[2]), 0);

  map.fuseMapPoints(kept, dropped);
  EXPECT_FALSE(map.hasMapPoint(dropped));
  const MapPoint& p = map.mapPoint(kept);
  EXPECT_EQ(p.numObservations(), 3u);
  EXPECT_EQ(p.observations.at(kfs[1]), 0u);  // kfs[1] already saw `kept`: its keypoint 1 is freed
  EXPECT_EQ(map.keyFrame(kfs[1]).mapPointIds[1], kNoMapPoint);
  EXPECT_EQ(p.observations.at(kfs[2]), 1u);
  EXPECT_EQ(p.visibleCount, 6);
  EXPECT_EQ(p.foundCount, 4);
  EXPECT_EQ(map.covisibilityWeight(kfs[0], kfs[2]), 1);
  EXPECT_EQ(map.covisibilityWeight(kfs[1], kfs[2]), 1);
  EXPECT_NO_THROW(map.checkInvariants());
  expectWeightsExact(map);
}

TEST(Map, FuseInSyntheticMapKeepsWeightsExact) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(5, 200, scene);
  // Split points: move the observations of the last keyframe onto a fresh duplicate, then fuse back.
  const KeyFrameId last = scene.keyframeIds.back();
  std::vector<std::pair<MapPointId, MapPointId>> pairs;
  for (MapPointId pid : map.pointsOf(last)) {
    const MapPoint& p = map.mapPoint(pid);
    if (p.numObservations() < 3 || p.anchorKeyFrame == last) continue;
    const std::size_t k = p.observations.at(last);
    const Eigen::Vector3d pw = map.worldPosition(pid);
    map.eraseObservation(pid, last);
    pairs.emplace_back(pid, map.addMapPoint(last, k, pw));
  }
  ASSERT_GT(pairs.size(), 20u);
  expectWeightsExact(map);
  for (const auto& [kept, dropped] : pairs) map.fuseMapPoints(kept, dropped);
  ASSERT_NO_THROW(map.checkInvariants());
  expectWeightsExact(map);
  for (const auto& [kept, dropped] : pairs) EXPECT_TRUE(map.mapPoint(kept).isObservedBy(last));
}

TEST(Map, DistinctiveDescriptorIsLeastMedianDistance) {
  Map map;
  std::vector<KeyFrameId> kfs;
  // Descriptors: all zero, one bit set, 200 bits set: the median-distance choice is the one-bit one
  // (distances 1 / 1,199 / 199,200 -> medians (N=3, index 1): 1, 1, 199 -> first minimum = all-zero).
  std::vector<cv::Mat> descs(3, cv::Mat(1, 32, CV_8UC1, cv::Scalar(0)));
  descs[1] = cv::Mat(1, 32, CV_8UC1, cv::Scalar(0));
  descs[1].at<uchar>(0, 0) = 1;
  descs[2] = cv::Mat(1, 32, CV_8UC1, cv::Scalar(255));
  descs[2].colRange(25, 32) = cv::Scalar(0);  // 25 * 8 = 200 bits set
  for (int f = 0; f < 3; ++f) {
    KeyFrame kf;
    kf.T_cam_world = poseOnLine(f);
    kf.camera = testCamera();
    kf.setPyramid(8, 1.2);
    kf.keypoints.emplace_back(cv::Point2f(320.f, 240.f), 31.f, 0.f, 1.f, 0);
    kf.descriptors = descs[f].clone();
    kfs.push_back(map.addKeyFrame(std::move(kf)));
  }
  // Put the all-ones descriptor first so that "first" is not trivially the answer.
  const MapPointId p = map.addMapPoint(kfs[2], 0, map.keyFrame(kfs[2]).T_world_cam() * Eigen::Vector3d(0, 0, 5));
  map.addObservation(p, kfs[1], 0);
  map.addObservation(p, kfs[0], 0);
  map.computeDistinctiveDescriptor(p);
  // Observation order is by keyframe id: kf0 (zero), kf1 (one bit), kf2 (200 bits). Brute force:
  int bestMedian = 1 << 30;
  cv::Mat expected;
  for (int i = 0; i < 3; ++i) {
    std::vector<int> d;
    for (int j = 0; j < 3; ++j) d.push_back(int(cv::norm(descs[i], descs[j], cv::NORM_HAMMING)));
    std::sort(d.begin(), d.end());
    if (d[1] < bestMedian) bestMedian = d[1], expected = descs[i];
  }
  EXPECT_EQ(cv::norm(map.mapPoint(p).descriptor, expected, cv::NORM_HAMMING), 0.0);
  EXPECT_EQ(cv::norm(map.mapPoint(p).descriptor, descs[0], cv::NORM_HAMMING), 0.0);
}

TEST(Map, NormalDistancesAndPredictScale) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(4, 100, scene);
  for (const auto& [id, p] : map.mapPoints()) {
    const KeyFrame& anchor = map.keyFrame(p.anchorKeyFrame);
    const double d = (map.worldPosition(id) - anchor.cameraCenter()).norm();
    const int level = anchor.keypoints[p.anchorKeypoint].octave;
    EXPECT_NEAR(p.maxDistance, d * anchor.scaleFactors[level], 1e-9);
    EXPECT_NEAR(p.minDistance, p.maxDistance / anchor.scaleFactors.back(), 1e-9);
    EXPECT_NEAR(p.normal.norm(), 1.0, 1e-12);
    // Seen from the anchor at its creation distance, the predicted level is the anchor keypoint level.
    EXPECT_EQ(map.predictScale(id, d, p.anchorKeyFrame), level);
  }
}

TEST(Map, CovisibilityOrderAndLocalWindow) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(8, 400, scene);
  const KeyFrameId centre = scene.keyframeIds[4];
  const auto cov = map.covisibleKeyFrames(centre);
  for (std::size_t i = 1; i < cov.size(); ++i) {
    const int w0 = map.covisibilityWeight(centre, cov[i - 1]), w1 = map.covisibilityWeight(centre, cov[i]);
    EXPECT_TRUE(w0 > w1 || (w0 == w1 && cov[i - 1] < cov[i]));
    EXPECT_GE(w1, Map::kCovisibilityThreshold);
  }
  const LocalWindow w = map.localWindow(centre, 3);
  ASSERT_EQ(w.localKeyFrames.size(), 3u);
  EXPECT_EQ(w.localKeyFrames[0], centre);
  const std::set<KeyFrameId> local(w.localKeyFrames.begin(), w.localKeyFrames.end());
  std::set<MapPointId> expectedPoints;
  for (KeyFrameId k : local)
    for (MapPointId p : map.pointsOf(k)) expectedPoints.insert(p);
  EXPECT_EQ(std::set<MapPointId>(w.points.begin(), w.points.end()), expectedPoints);
  std::set<KeyFrameId> expectedFixed;
  for (MapPointId p : expectedPoints)
    for (const auto& [k, idx] : map.mapPoint(p).observations)
      if (!local.count(k)) expectedFixed.insert(k);
  EXPECT_EQ(std::set<KeyFrameId>(w.fixedKeyFrames.begin(), w.fixedKeyFrames.end()), expectedFixed);
  EXPECT_FALSE(expectedFixed.empty());
}

TEST(Map, RejectsBadInput) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(2, 50, scene);
  const KeyFrameId kf0 = scene.keyframeIds[0];
  const MapPointId some = map.keyFrame(kf0).mapPointIds[0];
  EXPECT_THROW(map.keyFrame(999), pslam::Error);
  EXPECT_THROW(map.mapPoint(123456), pslam::Error);
  EXPECT_THROW(map.addMapPoint(kf0, 0, Eigen::Vector3d(0, 0, 5)), pslam::Error);  // keypoint already matched
  EXPECT_THROW(map.addMapPoint(kf0, 100000, Eigen::Vector3d(0, 0, 5)), pslam::Error);
  EXPECT_FALSE(map.addObservation(some, kf0, 0));  // already observed: no change
  KeyFrame bad;
  bad.camera = testCamera();
  bad.setPyramid(8, 1.2);
  bad.keypoints.emplace_back(cv::Point2f(1.f, 1.f), 31.f);
  bad.descriptors = cv::Mat(2, 32, CV_8UC1);
  EXPECT_THROW(map.addKeyFrame(bad), pslam::Error);
  bad.descriptors = cv::Mat(1, 32, CV_8UC1);
  bad.keypoints[0].octave = 9;
  EXPECT_THROW(map.addKeyFrame(bad), pslam::Error);
  bad.keypoints[0].octave = 0;
  bad.T_cam_world.translation().x() = std::nan("");
  EXPECT_THROW(map.addKeyFrame(bad), pslam::Error);
  EXPECT_NO_THROW(map.checkInvariants());
}
