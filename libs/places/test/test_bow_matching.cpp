#include <gtest/gtest.h>

#include <numeric>

#include "PlacesTestData.h"
#include "pslam/places/BowMatching.h"
#include "pslam/places/Vocabulary.h"
#include "pslam_test/TestSupport.h"

using namespace pslam;
using namespace pslam::places;

namespace {

std::vector<cv::KeyPoint> keypoints(int n, float angle) {
  std::vector<cv::KeyPoint> k(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    k[static_cast<std::size_t>(i)].pt = {static_cast<float>(i), 0.f};
    k[static_cast<std::size_t>(i)].angle = angle;
  }
  return k;
}

}  // namespace

TEST(BowMatching, FindsTheSameFeaturesInAPermutedNoisyView) {
  const test::PlaceSet s = test::makePlaces(6, 100, 1, 6, 5);
  VocabularyParams p;
  p.branching = 6;
  p.depth = 3;
  const Vocabulary v = Vocabulary::train(s.images, p);
  std::mt19937 rng(8);
  const cv::Mat d1 = s.prototypes[2];
  // View 2: the same descriptors with noise, in reversed order.
  const cv::Mat noisy = test::withNoise(d1, 6, rng);
  cv::Mat d2(noisy.rows, 32, CV_8U);
  for (int r = 0; r < noisy.rows; ++r) noisy.row(noisy.rows - 1 - r).copyTo(d2.row(r));
  BowVector b1, b2;
  FeatureVector f1, f2;
  v.transform(d1, b1, &f1, 1);
  v.transform(d2, b2, &f2, 1);
  NodeMatchParams mp;
  const auto k1 = keypoints(d1.rows, 10.f), k2 = keypoints(d2.rows, 30.f);
  const auto m = matchByVocabularyNode(f1, d1, k1, f2, d2, k2, mp);
  ASSERT_GT(m.size(), 50u);  // most features land in the same level-2 node in both views
  for (const auto& x : m) {
    EXPECT_EQ(x.i2, d1.rows - 1 - x.i1);
    EXPECT_LE(x.distance, mp.maxDistance);
  }
  for (std::size_t i = 1; i < m.size(); ++i) EXPECT_LT(m[i - 1].i1, m[i].i1);
  // The selectors: odd set-1 features only, set-2 features below 50 only.
  const auto sel = matchByVocabularyNode(f1, d1, k1, f2, d2, k2, mp, [](std::size_t i) { return i % 2 == 1; },
                                         [](std::size_t j) { return j < 50; });
  ASSERT_FALSE(sel.empty());
  for (const auto& x : sel) {
    EXPECT_EQ(x.i1 % 2, 1);
    EXPECT_LT(x.i2, 50);
  }
  // Rotation consistency: a match whose angle difference disagrees with the rest is dropped.
  auto k2odd = k2;
  k2odd[static_cast<std::size_t>(d2.rows - 1 - m.front().i1)].angle = 200.f;
  const auto rot = matchByVocabularyNode(f1, d1, k1, f2, d2, k2odd, mp);
  EXPECT_EQ(rot.size(), m.size() - 1);
  for (const auto& x : rot) EXPECT_NE(x.i1, m.front().i1);
}

TEST(BowMatching, RejectsIndicesOutsideTheFeatures) {
  FeatureVector f;
  f.nodes.push_back({1, {0, 7}});
  const cv::Mat d(3, 32, CV_8U, cv::Scalar(0));
  const auto k = keypoints(3, 0.f);
  const std::string e = test_support::errorOf([&] { matchByVocabularyNode(f, d, k, f, d, k, NodeMatchParams{}); });
  EXPECT_NE(e.find("feature 7 of set 1"), std::string::npos) << e;
}
