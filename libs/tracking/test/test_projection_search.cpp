// Projection search on a synthetic frame with known correspondences: every point projected with a slightly wrong
// pose must find its own keypoint (and only it), inconsistent keypoint rotations are rejected, matched keypoints
// are left alone.
#include <random>

#include <gtest/gtest.h>

#include "pslam/tracking/ProjectionSearch.h"

using namespace pslam;

namespace {
struct Scene {
  geometry::PinholeCamera camera{500, 500, 319.5, 239.5, 640, 480};
  std::vector<Eigen::Vector3d> points;
  cv::Mat pointDescriptors;
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
};

cv::Mat randomDescriptors(int n, std::mt19937& rng) {
  cv::Mat d(n, 32, CV_8U);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 32; ++j) d.at<uint8_t>(i, j) = static_cast<uint8_t>(byte(rng));
  return d;
}

// Flips `bits` random bits of a descriptor row (appearance change between views).
void perturb(cv::Mat row, int bits, std::mt19937& rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int k = 0; k < bits; ++k) {
    const int b = bit(rng);
    row.at<uint8_t>(0, b / 8) ^= static_cast<uint8_t>(1u << (b % 8));
  }
}

// Frame observing all scene points (keypoint i = point i, angle = 40 + rotation[i] deg) plus distractors.
tracking::Frame makeObservedFrame(const Scene& s, const std::vector<float>& rotation, int distractors, std::mt19937& rng) {
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc(0, 32, CV_8U);
  std::normal_distribution<double> noise(0, 0.5);
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const Eigen::Vector2d uv = s.camera.project(s.T_cam_world * s.points[i]);
    cv::KeyPoint kp(cv::Point2f(static_cast<float>(uv.x() + noise(rng)), static_cast<float>(uv.y() + noise(rng))), 31.f,
                    std::fmod(40.f + rotation[i] + 360.f, 360.f), 10.f, 0);
    kps.push_back(kp);
    cv::Mat row = s.pointDescriptors.row(static_cast<int>(i)).clone();
    perturb(row, 10, rng);
    desc.push_back(row);
  }
  std::uniform_real_distribution<float> ux(0, 639), uy(0, 479);
  const cv::Mat dd = randomDescriptors(distractors, rng);
  for (int k = 0; k < distractors; ++k) {
    kps.emplace_back(cv::Point2f(ux(rng), uy(rng)), 31.f, 40.f, 10.f, 0);
    desc.push_back(dd.row(k));
  }
  return tracking::makeFrameFromFeatures(1, 0.1, s.camera, kps, desc, 8, 1.2);
}

Scene makeScene(int n, std::mt19937& rng) {
  Scene s;
  std::uniform_real_distribution<double> x(-3, 3), y(-2, 2), z(4, 10);
  for (int i = 0; i < n; ++i) s.points.emplace_back(x(rng), y(rng), z(rng));
  s.pointDescriptors = randomDescriptors(n, rng);
  s.T_cam_world.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);
  s.T_cam_world.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  return s;
}

std::vector<tracking::ProjectionCandidate> candidates(const Scene& s, float radius, float refAngle) {
  std::vector<tracking::ProjectionCandidate> c;
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    tracking::ProjectionCandidate p;
    p.id = i;
    p.p_world = s.points[i];
    p.descriptor = s.pointDescriptors.row(static_cast<int>(i));
    p.minLevel = 0;
    p.maxLevel = 1;
    p.radius = radius;
    p.referenceAngle = refAngle;
    c.push_back(p);
  }
  return c;
}

// Predicted pose: the true one moved by 2 cm and 0.3 deg (a constant-velocity prediction error).
Eigen::Isometry3d predicted(const Scene& s) {
  Eigen::Isometry3d T = s.T_cam_world;
  T.translation() += Eigen::Vector3d(0.02, 0.0, -0.01);
  T.linear() = Eigen::AngleAxisd(0.3 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() * T.linear();
  return T;
}
}  // namespace

TEST(ProjectionSearch, FindsTheTrueKeypointOfEveryVisiblePoint) {
  std::mt19937 rng(7);
  Scene s = makeScene(300, rng);
  std::vector<float> rot(300, 0.f);
  tracking::Frame f = makeObservedFrame(s, rot, 500, rng);
  const int n = tracking::searchByProjection(f, predicted(s), candidates(s, 15.f, 40.f), {});
  int correct = 0, wrong = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    if (f.mapPointIds[k] == map::kNoMapPoint) continue;
    (f.mapPointIds[k] == k ? correct : wrong)++;
  }
  EXPECT_EQ(n, correct + wrong);
  EXPECT_EQ(wrong, 0);
  EXPECT_GE(correct, 290);  // a few may project outside the image bounds or lose to a distractor
}

TEST(ProjectionSearch, TooSmallRadiusFindsNothingFarAway) {
  std::mt19937 rng(8);
  Scene s = makeScene(100, rng);
  tracking::Frame f = makeObservedFrame(s, std::vector<float>(100, 0.f), 0, rng);
  Eigen::Isometry3d far = s.T_cam_world;
  far.translation() += Eigen::Vector3d(0.5, 0, 0);  // ~25-60 px shift at 4-10 m
  EXPECT_EQ(tracking::searchByProjection(f, far, candidates(s, 3.f, -1.f), {}), 0);
}

TEST(ProjectionSearch, RotationHistogramRejectsInconsistentAngles) {
  std::mt19937 rng(9);
  Scene s = makeScene(200, rng);
  // 80 % of the keypoints keep their angle; every 5th is rotated by a different angle (15 distinct bins, each
  // far below 10 % of the dominant bin), which ORB-SLAM's three-maxima histogram discards.
  std::vector<float> rot(200, 0.f);
  for (std::size_t i = 0; i < rot.size(); i += 5) rot[i] = static_cast<float>(20 * ((i / 5) % 15) + 15);
  tracking::Frame f = makeObservedFrame(s, rot, 0, rng);
  tracking::searchByProjection(f, predicted(s), candidates(s, 15.f, 40.f), {});
  int scatteredKept = 0, consistentKept = 0;
  for (std::size_t i = 0; i < rot.size(); ++i) {
    if (f.mapPointIds[i] == map::kNoMapPoint) continue;
    (rot[i] != 0.f ? scatteredKept : consistentKept)++;
  }
  EXPECT_GT(consistentKept, 150);
  EXPECT_EQ(scatteredKept, 0);
  // Without the check they are matched.
  tracking::Frame g = makeObservedFrame(s, rot, 0, rng);
  tracking::ProjectionSearchParams noCheck;
  noCheck.checkOrientation = false;
  tracking::searchByProjection(g, predicted(s), candidates(s, 15.f, 40.f), noCheck);
  int scatteredMatched = 0;
  for (std::size_t i = 0; i < rot.size(); ++i)
    if (rot[i] != 0.f && g.mapPointIds[i] != map::kNoMapPoint) ++scatteredMatched;
  EXPECT_GT(scatteredMatched, 30);
}

TEST(ProjectionSearch, KeepsExistingMatchesAndRespectsOctaves) {
  std::mt19937 rng(10);
  Scene s = makeScene(50, rng);
  tracking::Frame f = makeObservedFrame(s, std::vector<float>(50, 0.f), 0, rng);
  f.mapPointIds[0] = 1000;  // matched earlier (e.g. by the motion-model search)
  auto c = candidates(s, 15.f, -1.f);
  tracking::searchByProjection(f, predicted(s), c, {});
  EXPECT_EQ(f.mapPointIds[0], 1000u);
  // Octave window that excludes level 0: no keypoint qualifies.
  tracking::Frame g = makeObservedFrame(s, std::vector<float>(50, 0.f), 0, rng);
  for (auto& x : c) x.minLevel = x.maxLevel = 2;
  EXPECT_EQ(tracking::searchByProjection(g, predicted(s), c, {}), 0);
}

TEST(ProjectionSearch, PredictLevelFollowsOrbSlam) {
  // maxDistance = 1.2^7 * minDistance; at maxDistance level 0, each factor 1.2 closer one level more.
  EXPECT_EQ(tracking::predictLevel(10.0, 10.0, 1.2, 8), 0);
  EXPECT_EQ(tracking::predictLevel(10.0 / 1.2, 10.0, 1.2, 8), 1);
  EXPECT_EQ(tracking::predictLevel(10.0 / std::pow(1.2, 3) * 0.99, 10.0, 1.2, 8), 4);  // ceil
  EXPECT_EQ(tracking::predictLevel(0.01, 10.0, 1.2, 8), 7);
  EXPECT_EQ(tracking::predictLevel(100.0, 10.0, 1.2, 8), 0);
  EXPECT_FLOAT_EQ(tracking::radiusByViewingCos(0.999), 2.5f);
  EXPECT_FLOAT_EQ(tracking::radiusByViewingCos(0.9), 4.0f);
}
