// ObservationRefiner on a textured plane seen by two keyframes (the second image is the exact affine image of the
// first that the plane and the poses give): observations detected up to 0.8 level px off move to within a tenth of a
// pixel of where their anchor keypoint's scene point appears, at pyramid levels 0-2; anchors are never moved; an
// observation is aligned once per anchor; without the anchor's image nothing changes; bad images are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include <opencv2/imgproc.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/DirectPointSelector.h"
#include "pslam/mapping/ObservationRefiner.h"

namespace pslam::mapping {
namespace {

constexpr double kF = 400, kCx = 320, kCy = 240, kDepth = 4.0;
const Eigen::Vector3d kCentre2(0.3, 0.05, 0.4);  // second camera centre (no rotation), 0.4 m forward

struct PlaneScene {
  geometry::PinholeCamera camera{kF, kF, kCx, kCy, 640, 480};
  cv::Mat image1, image2;
  map::Map map;
  map::KeyFrameId kf1 = map::kNoKeyFrame, kf2 = map::kNoKeyFrame;
  std::vector<Eigen::Vector2d> truth2;  ///< level-0 pixel of each point in the second view
};

Eigen::Vector2d project2(const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d c = p_world - kCentre2;
  return {kF * c.x() / c.z() + kCx, kF * c.y() / c.z() + kCy};
}

map::KeyFrame keyFrame(const Eigen::Vector3d& centre, const std::vector<cv::KeyPoint>& keypoints) {
  map::KeyFrame kf;
  kf.camera = {kF, kF, kCx, kCy, 640, 480};
  kf.T_cam_world = Eigen::Isometry3d::Identity();
  kf.T_cam_world.translation() = -centre;
  kf.keypoints = keypoints;
  kf.descriptors = cv::Mat::zeros(static_cast<int>(keypoints.size()), 32, CV_8U);
  kf.setPyramid(8, 1.2);
  return kf;
}

/// `noise`: the second view's keypoints are off their true position by up to this (level px, uniform per axis).
PlaneScene planeScene(double noise) {
  PlaneScene s;
  s.image1 = features::test::texturedImage(640, 480, 11);
  // The plane z = kDepth: u2 - c = (u1 - c) z / (z - tz) - f t / (z - tz), per axis.
  const double zoom = kDepth / (kDepth - kCentre2.z());
  const cv::Matx23d M(zoom, 0, kCx * (1 - zoom) - kF * kCentre2.x() / (kDepth - kCentre2.z()), 0, zoom,
                      kCy * (1 - zoom) - kF * kCentre2.y() / (kDepth - kCentre2.z()));
  cv::warpAffine(s.image1, s.image2, M, s.image1.size(), cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  features::DirectSelectorParams sp;
  sp.targetPoints = 300;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> off(-noise, noise);
  std::vector<cv::KeyPoint> k1, k2;
  std::vector<Eigen::Vector3d> points;
  const std::vector<double> scales{1.0, 1.2, 1.44};
  for (const auto& d : features::DirectPointSelector(sp).select(s.image1)) {
    const Eigen::Vector3d X((d.pixel.x - kCx) / kF * kDepth, (d.pixel.y - kCy) / kF * kDepth, kDepth);
    const Eigen::Vector2d u2 = project2(X);
    if (std::min(d.pixel.x, d.pixel.y) < 30 || d.pixel.x > 610 || d.pixel.y > 450 || u2.minCoeff() < 30 ||
        u2.x() > 610 || u2.y() > 450)
      continue;
    const int octave = static_cast<int>(points.size() % 3);
    k1.emplace_back(cv::Point2f(d.pixel.x, d.pixel.y), 31.f, -1.f, 0.f, octave);
    const Eigen::Vector2d detected = u2 + scales[octave] * Eigen::Vector2d(off(rng), off(rng));
    k2.emplace_back(cv::Point2f(float(detected.x()), float(detected.y())), 31.f, -1.f, 0.f, octave);
    points.push_back(X);
    s.truth2.push_back(u2);
  }
  s.kf1 = s.map.addKeyFrame(keyFrame(Eigen::Vector3d::Zero(), k1));
  s.kf2 = s.map.addKeyFrame(keyFrame(kCentre2, k2));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const map::MapPointId p = s.map.addMapPoint(s.kf1, i, points[i]);
    s.map.addObservation(p, s.kf2, i);
  }
  return s;
}

/// Per-keypoint distance of the second keyframe's keypoints to the truth, in level pixels.
std::vector<double> errors2(const PlaneScene& s) {
  const map::KeyFrame& kf = s.map.keyFrame(s.kf2);
  std::vector<double> e;
  for (std::size_t i = 0; i < kf.keypoints.size(); ++i)
    e.push_back((kf.pixel(i) - s.truth2[i]).norm() / kf.scaleFactors[kf.keypoints[i].octave]);
  return e;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

TEST(ObservationRefiner, MovesObservationsOntoTheAnchorsScenePointAndNeverTheAnchor) {
  PlaneScene s = planeScene(0.8);
  ASSERT_GT(s.truth2.size(), 120u);
  const std::vector<cv::KeyPoint> anchors = s.map.keyFrame(s.kf1).keypoints;
  ObservationRefinementParams params;
  params.enabled = true;
  ObservationRefiner refiner(params, s.camera);
  refiner.addKeyFrame(s.kf1, s.image1, s.map.keyFrame(s.kf1).scaleFactors);
  refiner.addKeyFrame(s.kf2, s.image2, s.map.keyFrame(s.kf2).scaleFactors);
  EXPECT_EQ(refiner.keptKeyFrames(), 2u);
  const double before = median(errors2(s));
  const RefinementCounts c = refiner.refine(s.map, s.kf2);
  EXPECT_EQ(c.tried, static_cast<int>(s.truth2.size()));
  EXPECT_GE(c.refined, 0.8 * c.tried);
  const double after = median(errors2(s));
  EXPECT_GT(before, 0.4);
  EXPECT_LT(after, 0.1);
  for (int level = 0; level < 3; ++level) {  // every level used, not only the finest
    std::vector<double> e;
    const std::vector<double> all = errors2(s);
    for (std::size_t i = 0; i < all.size(); ++i)
      if (static_cast<int>(i % 3) == level) e.push_back(all[i]);
    EXPECT_LT(median(e), 0.15) << "level " << level;
  }
  const map::KeyFrame& kf1 = s.map.keyFrame(s.kf1);
  for (std::size_t i = 0; i < anchors.size(); ++i) EXPECT_EQ(kf1.keypoints[i].pt, anchors[i].pt);
  // Aligned once per anchor observation: asking again (the next keyframe sees the same points) tries nothing.
  EXPECT_EQ(refiner.refine(s.map, s.kf1).tried, 0);
}

TEST(ObservationRefiner, LeavesObservationsAsDetectedWithoutTheAnchorsImage) {
  PlaneScene s = planeScene(0.8);
  ObservationRefinementParams params;
  params.enabled = true;
  ObservationRefiner refiner(params, s.camera);
  refiner.addKeyFrame(s.kf2, s.image2, s.map.keyFrame(s.kf2).scaleFactors);
  const std::vector<double> before = errors2(s);
  EXPECT_EQ(refiner.refine(s.map, s.kf2).tried, 0);
  EXPECT_EQ(errors2(s), before);
  // The oldest image leaves when more than cachedKeyFrames are kept; erased keyframes' images leave at refine().
  params.cachedKeyFrames = 2;
  ObservationRefiner small(params, s.camera);
  for (map::KeyFrameId id : {s.kf1, s.kf2, map::KeyFrameId{7}})
    small.addKeyFrame(id, s.image1, s.map.keyFrame(s.kf1).scaleFactors);
  EXPECT_EQ(small.keptKeyFrames(), 2u);
  small.refine(s.map, s.kf2);  // keyframe 7 is not in the map
  EXPECT_EQ(small.keptKeyFrames(), 1u);
  EXPECT_GT(small.keptBytes(), 640u * 480u);
  small.reset();
  EXPECT_EQ(small.keptKeyFrames(), 0u);
}

TEST(ObservationRefiner, RefusesAnImageThatDoesNotFitTheCamera) {
  PlaneScene s = planeScene(0.0);
  ObservationRefiner refiner({}, s.camera);
  const std::vector<double> scales = s.map.keyFrame(s.kf1).scaleFactors;
  try {
    refiner.addKeyFrame(5, cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)), scales);
    FAIL() << "a 320x240 image was accepted for a 640x480 camera";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "ObservationRefiner: keyframe 5: the image is 320x240, the camera 640x480");
  }
  EXPECT_THROW(refiner.addKeyFrame(5, cv::Mat(), scales), Error);
  EXPECT_THROW(refiner.addKeyFrame(5, cv::Mat(480, 640, CV_8UC3), scales), Error);
}

}  // namespace
}  // namespace pslam::mapping
