// The guided triangulation search (epipolar-band grid) returns exactly the exhaustive search's matches: on
// synthetic keyframe pairs with lateral, forward (epipole inside the image), vertical and rotating motion,
// keypoints on every pyramid level (band widths up to 7 px), pixel noise, repeated descriptors (ambiguity) and
// keypoints that already have a map point.
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "pslam/geometry/Epipolar.h"
#include "pslam/mapping/LocalMapper.h"

using namespace pslam;
using namespace pslam::mapping;

namespace {

map::KeyFrame keyFrameAt(const Eigen::Isometry3d& T_cam_world, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<cv::Mat>& descriptors, const std::vector<float>& angles,
                         std::mt19937& rng, int flippedBits = 3) {
  map::KeyFrame kf;
  kf.T_cam_world = T_cam_world;
  kf.camera = {700.0, 700.0, 620.0, 188.0, 1241, 376};  // KITTI-like: wide image, epipole may be inside
  kf.setPyramid(8, 1.2);
  std::normal_distribution<double> noise(0.0, 0.7);
  std::uniform_int_distribution<int> octave(0, 7), bit(0, 255);
  std::normal_distribution<float> angleNoise(0.f, 3.f);
  std::vector<cv::Mat> rows;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d pc = T_cam_world * points[i];
    if (pc.z() <= 0.5) continue;
    const int level = octave(rng);
    const Eigen::Vector2d px = kf.camera.project(pc) + kf.scaleFactors[level] * Eigen::Vector2d(noise(rng), noise(rng));
    if (!kf.camera.inImage(px)) continue;
    kf.keypoints.emplace_back(cv::Point2f(float(px.x()), float(px.y())), 31.f, angles[i] + angleNoise(rng), 1.f, level);
    cv::Mat d = descriptors[i].clone();
    for (int f = 0; f < flippedBits; ++f) {
      const int b = bit(rng);
      d.at<uchar>(0, b / 8) ^= static_cast<uchar>(1 << (b % 8));
    }
    rows.push_back(d);
  }
  cv::vconcat(rows, kf.descriptors);
  kf.mapPointIds.assign(kf.keypoints.size(), map::kNoMapPoint);
  // Every 7th keypoint already has a map point: not a candidate.
  for (std::size_t k = 0; k < kf.mapPointIds.size(); k += 7) kf.mapPointIds[k] = static_cast<map::MapPointId>(k + 1);
  return kf;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& centre, const Eigen::Vector3d& axisAngle) {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  T_world_cam.translation() = centre;
  if (axisAngle.norm() > 0) T_world_cam.linear() = Eigen::AngleAxisd(axisAngle.norm(), axisAngle.normalized()).toRotationMatrix();
  return T_world_cam.inverse();
}

cv::Mat randomDescriptor(std::mt19937& rng) {
  std::uniform_int_distribution<int> byte(0, 255);
  cv::Mat d(1, 32, CV_8UC1);
  for (int b = 0; b < 32; ++b) d.at<uchar>(0, b) = static_cast<uchar>(byte(rng));
  return d;
}

struct RandomScene {
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Mat> descriptors;
  std::vector<float> angles;
};

/// n points, each with a random keypoint angle, position and descriptor (drawn in that order);
/// descriptor(i, earlier) gives the i-th descriptor.
template <class Descriptor>
RandomScene randomScene(std::mt19937& rng, int n, Descriptor&& descriptor) {
  std::uniform_real_distribution<double> ux(-15, 15), uy(-3, 3), uz(3, 60);
  std::uniform_real_distribution<float> angle(10.f, 350.f);
  RandomScene s;
  for (int i = 0; i < n; ++i) {
    s.angles.push_back(angle(rng));
    s.points.emplace_back(ux(rng), uy(rng), uz(rng));
    s.descriptors.push_back(descriptor(i, s.descriptors));
  }
  return s;
}

/// 2000 points carrying only 40 distinct descriptors, copied exactly: many candidates at the same best distance.
RandomScene exactTiesScene(std::mt19937& rng) {
  std::vector<cv::Mat> pool;
  for (int k = 0; k < 40; ++k) pool.push_back(randomDescriptor(rng));
  return randomScene(
      rng, 2000, [&](int i, const std::vector<cv::Mat>&) { return pool[static_cast<std::size_t>(i) % pool.size()]; });
}

}  // namespace

TEST(TriangulationSearch, GuidedFindsExactlyTheExhaustiveMatches) {
  std::mt19937 rng(7);
  const RandomScene scene = randomScene(rng, 2500, [&](int i, const std::vector<cv::Mat>& earlier) {
    // One descriptor in five repeats an earlier one: ambiguous candidates along the band.
    return i > 10 && i % 5 == 0 ? earlier[static_cast<std::size_t>(i / 2)].clone() : randomDescriptor(rng);
  });
  const auto& [points, descriptors, angles] = scene;
  struct Motion {
    const char* name;
    Eigen::Vector3d centre, axisAngle;
  };
  const std::vector<Motion> motions = {
      {"forward (epipole in the image)", {0.1, 0.0, 1.5}, {0, 0.02, 0}},
      {"lateral", {1.0, 0.05, 0.1}, {0, 0.03, 0}},
      {"vertical (steep lines)", {0.05, 0.8, 0.2}, {0.02, 0, 0}},
      {"diagonal with roll", {0.6, 0.5, 0.8}, {0.01, 0.05, 0.08}},
  };
  LocalMappingParams params;
  params.nnRatio = 0.9;  // exercises the second-best bookkeeping too
  const map::KeyFrame kf1 = keyFrameAt(pose({0, 0, 0}, {0, 0, 0}), points, descriptors, angles, rng);
  ASSERT_GT(kf1.numKeypoints(), 1000u);
  for (const Motion& m : motions) {
    const map::KeyFrame kf2 = keyFrameAt(pose(m.centre, m.axisAngle), points, descriptors, angles, rng);
    const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(
        kf1.camera.K(), kf1.T_cam_world.linear(), kf1.T_cam_world.translation(), kf2.camera.K(),
        kf2.T_cam_world.linear(), kf2.T_cam_world.translation());
    for (bool orientation : {true, false}) {
      params.checkOrientation = orientation;
      const auto exhaustive = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::Exhaustive);
      const auto guided = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::Guided);
      EXPECT_GT(exhaustive.size(), 500u) << m.name;
      ASSERT_EQ(guided.size(), exhaustive.size()) << m.name;
      for (std::size_t k = 0; k < guided.size(); ++k) {
        EXPECT_EQ(guided[k].i1, exhaustive[k].i1) << m.name << " match " << k;
        EXPECT_EQ(guided[k].i2, exhaustive[k].i2) << m.name << " match " << k;
      }
    }
  }
}

TEST(TriangulationSearch, GuidedFindsTheExhaustiveMatchesAmongExactTies) {
  // 40 distinct descriptors over 2000 points, copied exactly: most keypoints have several candidates in their band
  // at the same best distance, in cells the guided search visits out of index order. The exhaustive scan keeps the
  // lowest index; the guided one must too, also when a third tie comes after the second-best equals the best.
  std::mt19937 rng(11);
  const RandomScene scene = exactTiesScene(rng);
  const auto& [points, descriptors, angles] = scene;
  LocalMappingParams params;
  params.checkOrientation = false;
  const map::KeyFrame kf1 = keyFrameAt(pose({0, 0, 0}, {0, 0, 0}), points, descriptors, angles, rng, 0);
  for (const Eigen::Vector3d& centre : {Eigen::Vector3d(1.0, 0.05, 0.1), Eigen::Vector3d(0.05, 0.8, 0.2),
                                        Eigen::Vector3d(0.1, 0.0, 1.5)}) {
    const map::KeyFrame kf2 = keyFrameAt(pose(centre, {0, 0.02, 0}), points, descriptors, angles, rng, 0);
    const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(
        kf1.camera.K(), kf1.T_cam_world.linear(), kf1.T_cam_world.translation(), kf2.camera.K(),
        kf2.T_cam_world.linear(), kf2.T_cam_world.translation());
    const auto exhaustive = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::Exhaustive);
    const auto guided = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::Guided);
    EXPECT_GT(exhaustive.size(), 300u);
    ASSERT_EQ(guided.size(), exhaustive.size());
    int differing = 0;
    for (std::size_t k = 0; k < guided.size(); ++k)
      differing += guided[k].i1 != exhaustive[k].i1 || guided[k].i2 != exhaustive[k].i2 ? 1 : 0;
    EXPECT_EQ(differing, 0) << "of " << guided.size() << " matches";
  }
}

TEST(TriangulationSearch, VocabularyNodeSearchesOnlyWithinTheKeypointsNode) {
  std::mt19937 rng(3);
  const RandomScene scene =
      randomScene(rng, 1500, [&](int, const std::vector<cv::Mat>&) { return randomDescriptor(rng); });
  const auto& [points, descriptors, angles] = scene;
  map::KeyFrame kf1 = keyFrameAt(pose({0, 0, 0}, {0, 0, 0}), points, descriptors, angles, rng);
  map::KeyFrame kf2 = keyFrameAt(pose({1.0, 0.05, 0.1}, {0, 0.03, 0}), points, descriptors, angles, rng);
  const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(kf1.camera.K(), kf1.T_cam_world.linear(),
                                                             kf1.T_cam_world.translation(), kf2.camera.K(),
                                                             kf2.T_cam_world.linear(), kf2.T_cam_world.translation());
  LocalMappingParams params;
  const auto guided = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::Guided);
  ASSERT_GT(guided.size(), 300u);
  // Without a direct index the vocabulary search is the guided one.
  EXPECT_EQ(searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::VocabularyNode).size(), guided.size());
  auto allInOneNode = [](map::KeyFrame& kf) {
    kf.bowFeatures.nodes = {{5, {}}};
    for (std::uint32_t i = 0; i < kf.numKeypoints(); ++i) kf.bowFeatures.nodes[0].second.push_back(i);
  };
  // Every keypoint in one node: the same candidates as the exhaustive search, so the same matches.
  allInOneNode(kf1);
  allInOneNode(kf2);
  const auto oneNode = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::VocabularyNode);
  ASSERT_EQ(oneNode.size(), guided.size());
  for (std::size_t k = 0; k < guided.size(); ++k) {
    EXPECT_EQ(oneNode[k].i1, guided[k].i1);
    EXPECT_EQ(oneNode[k].i2, guided[k].i2);
  }
  // Nodes by keypoint parity in kf1, and the opposite parity of the guided partner in kf2: no pair shares a node.
  std::map<std::size_t, std::size_t> partner;
  for (const auto& m : guided) partner[m.i2] = m.i1;
  kf1.bowFeatures.nodes = {{1, {}}, {2, {}}};
  for (std::uint32_t i = 0; i < kf1.numKeypoints(); ++i) kf1.bowFeatures.nodes[i % 2].second.push_back(i);
  kf2.bowFeatures.nodes = {{1, {}}, {2, {}}};
  for (std::uint32_t j = 0; j < kf2.numKeypoints(); ++j) {
    const auto it = partner.find(j);
    const std::size_t node = it == partner.end() ? 0 : (it->second + 1) % 2;
    kf2.bowFeatures.nodes[node].second.push_back(j);
  }
  const auto split = searchForTriangulation(kf1, kf2, F12, params, TriangulationSearch::VocabularyNode);
  for (const auto& m : split) {
    const auto it = partner.find(m.i2);
    if (it != partner.end()) {
      EXPECT_NE(it->second, m.i1) << "matched across nodes";
    }
    EXPECT_EQ(m.i1 % 2, (it == partner.end() ? 0u : (it->second + 1) % 2)) << "a candidate outside the keypoint's node";
  }
  EXPECT_LT(split.size(), guided.size() / 4);
}

TEST(TriangulationSearch, ThreadsSplitTheSearchWithoutChangingItsMatches) {
  // Exact ties (40 descriptors over 2000 points): a kf2 keypoint is the best candidate of several kf1 keypoints,
  // often in different threads' runs, and only the first in ascending kf1 order may take it.
  std::mt19937 rng(19);
  const RandomScene scene = exactTiesScene(rng);
  const auto& [points, descriptors, angles] = scene;
  const map::KeyFrame kf1 = keyFrameAt(pose({0, 0, 0}, {0, 0, 0}), points, descriptors, angles, rng);
  const map::KeyFrame kf2 = keyFrameAt(pose({0.6, 0.5, 0.8}, {0.01, 0.05, 0.08}), points, descriptors, angles, rng);
  const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(kf1.camera.K(), kf1.T_cam_world.linear(),
                                                             kf1.T_cam_world.translation(), kf2.camera.K(),
                                                             kf2.T_cam_world.linear(), kf2.T_cam_world.translation());
  LocalMappingParams params;
  for (double nnRatio : {1.0, 0.9}) {
    params.nnRatio = nnRatio;
    for (TriangulationSearch mode : {TriangulationSearch::Exhaustive, TriangulationSearch::Guided}) {
      const auto one = searchForTriangulation(kf1, kf2, F12, params, mode, 1);
      if (nnRatio == 1.0) {
        EXPECT_GT(one.size(), 200u);
      }
      for (int threads : {2, 3, 7}) {
        const auto many = searchForTriangulation(kf1, kf2, F12, params, mode, threads);
        ASSERT_EQ(many.size(), one.size()) << threads << " threads, nnRatio " << nnRatio;
        int differing = 0;
        for (std::size_t k = 0; k < one.size(); ++k)
          differing += many[k].i1 != one[k].i1 || many[k].i2 != one[k].i2 ? 1 : 0;
        EXPECT_EQ(differing, 0) << threads << " threads, nnRatio " << nnRatio;
      }
    }
  }
}
