// Matching: Hamming distance against brute-force bit counting, the rotation histogram, SearchForInitialization
// on shifted/rotated copies of a synthetic image (known correspondences), and the brute-force/ratio matcher.
#include <gtest/gtest.h>

#include <bitset>
#include <numeric>
#include <set>
#include <random>

#include <opencv2/imgproc.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/Matching.h"
#include "pslam/features/OrbExtractor.h"

using namespace pslam::features;
using pslam::features::test::texturedImage;

namespace {

cv::Mat randomDescriptors(int n, std::mt19937& rng) {
  cv::Mat d(n, 32, CV_8UC1);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 32; ++j) d.at<uint8_t>(i, j) = static_cast<uint8_t>(byte(rng));
  return d;
}

cv::Point2f apply(const cv::Mat& M, cv::Point2f p) {
  return {static_cast<float>(M.at<double>(0, 0) * p.x + M.at<double>(0, 1) * p.y + M.at<double>(0, 2)),
          static_cast<float>(M.at<double>(1, 0) * p.x + M.at<double>(1, 1) * p.y + M.at<double>(1, 2))};
}

/// Frame 2 = frame 1 warped by the affine M (border grey 128): its ORB keypoints, descriptors and grid.
FeatureGrid extractWarped(OrbExtractor& ex, const cv::Mat& img1, const cv::Mat& M, std::vector<cv::KeyPoint>& k2,
                          cv::Mat& d2) {
  cv::Mat img2;
  cv::warpAffine(img1, img2, M, img1.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));
  ex.extract(img2, k2, d2);
  return FeatureGrid::fromKeypoints(k2, cv::Rect2f(0, 0, static_cast<float>(img1.cols),
                                                  static_cast<float>(img1.rows)));
}

}  // namespace

TEST(Hamming, EqualsBitCountingAndOpenCv) {
  std::mt19937 rng(21);
  const cv::Mat a = randomDescriptors(50, rng), b = randomDescriptors(50, rng);
  for (int i = 0; i < 50; ++i) {
    int bits = 0;
    for (int j = 0; j < 32; ++j) bits += static_cast<int>(std::bitset<8>(a.at<uint8_t>(i, j) ^ b.at<uint8_t>(i, j)).count());
    EXPECT_EQ(hammingDistance(a, i, b, i), bits);
    EXPECT_EQ(hammingDistance(a, i, b, i), static_cast<int>(cv::norm(a.row(i), b.row(i), cv::NORM_HAMMING)));
    EXPECT_EQ(hammingDistance(a, i, a, i), 0);
  }
}

TEST(Hamming, BestCandidateEqualsExhaustiveSearch) {
  std::mt19937 rng(22);
  const cv::Mat pool = randomDescriptors(300, rng), query = randomDescriptors(20, rng);
  std::uniform_int_distribution<int> pick(0, 299);
  for (int q = 0; q < 20; ++q) {
    std::vector<size_t> cand;
    for (int k = 0; k < q; ++k) cand.push_back(static_cast<size_t>(pick(rng)));
    const BestCandidate r = bestCandidate(query.ptr<uint8_t>(q), pool, cand);
    std::vector<int> d;
    for (size_t c : cand) d.push_back(hammingDistance(query, q, pool, static_cast<int>(c)));
    if (cand.empty()) {
      EXPECT_EQ(r.index, -1);
      EXPECT_FALSE(r.accepted(256, 1.f));
      continue;
    }
    const auto it = std::min_element(d.begin(), d.end());
    EXPECT_EQ(r.distance, *it);
    EXPECT_EQ(r.index, static_cast<int>(cand[it - d.begin()]));
    std::vector<int> sorted = d;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(r.secondDistance, sorted.size() > 1 ? sorted[1] : 257);
  }
  EXPECT_THROW(bestCandidate(query.ptr<uint8_t>(0), pool, {300}), pslam::Error);
}

TEST(Hamming, ThreeLargestBins) {
  std::vector<std::vector<int>> h(30);
  h[3].resize(50);
  h[7].resize(20);
  h[9].resize(6);
  h[12].resize(4);  // < 10 % of 50
  int b1, b2, b3;
  threeLargestBins(h, b1, b2, b3);
  EXPECT_EQ(b1, 3);
  EXPECT_EQ(b2, 7);
  EXPECT_EQ(b3, 9);
  h[9].resize(4);
  threeLargestBins(h, b1, b2, b3);
  EXPECT_EQ(b3, -1);
  h[7].resize(4);
  threeLargestBins(h, b1, b2, b3);
  EXPECT_EQ(b1, 3);
  EXPECT_EQ(b2, -1);
  threeLargestBins(std::vector<std::vector<int>>(30), b1, b2, b3);
  EXPECT_EQ(b1, -1);
}

TEST(MatchForInitialization, FindsTrueCorrespondencesUnderShiftAndRotation) {
  const cv::Mat img1 = texturedImage(640, 480, 31);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> k1, k2;
  cv::Mat d1, d2;
  ex.extract(img1, k1, d1);
  const cv::Point2f centre(320, 240);
  struct Case { double angleDeg, tx, ty; };
  for (const Case c : {Case{0, 12, -7}, Case{10, 15, 5}, Case{-25, -10, 8}}) {
    SCOPED_TRACE("rotation " + std::to_string(c.angleDeg));
    cv::Mat M = cv::getRotationMatrix2D(centre, c.angleDeg, 1.0);
    M.at<double>(0, 2) += c.tx;
    M.at<double>(1, 2) += c.ty;
    const FeatureGrid grid2 = extractWarped(ex, img1, M, k2, d2);
    std::vector<cv::Point2f> prev(k1.size());
    for (size_t i = 0; i < k1.size(); ++i) prev[i] = k1[i].pt;

    int level0Inside = 0;  // frame-1 level-0 keypoints whose true position is well inside image 2
    for (const auto& kp : k1) {
      const cv::Point2f q = apply(M, kp.pt);
      level0Inside += kp.octave == 0 && q.x > 30 && q.y > 30 && q.x < 610 && q.y < 450;
    }
    const auto matches = matchForInitialization(k1, d1, k2, d2, grid2, prev);
    int correct = 0;
    std::set<int> used2;
    for (const auto& m : matches) {
      EXPECT_EQ(k1[m.i1].octave, 0);
      EXPECT_EQ(k2[m.i2].octave, 0);
      EXPECT_LE(m.distance, kOrbThLow);
      EXPECT_EQ(m.distance, hammingDistance(d1, m.i1, d2, m.i2));
      EXPECT_TRUE(used2.insert(m.i2).second) << "frame-2 keypoint matched twice";
      EXPECT_EQ(prev[m.i1], k2[m.i2].pt);
      // FAST corners are integer pixels and move under resampling: 4 px = 2 px localisation per image.
      correct += cv::norm(apply(M, k1[m.i1].pt) - k2[m.i2].pt) < 4.0;
    }
    // ORB-SLAM attempts the two-view initialization only with >= 100 matches; RANSAC absorbs a few outliers.
    EXPECT_GE(matches.size(), 100u) << "level-0 keypoints inside: " << level0Inside;
    EXPECT_GE(correct, 0.95 * matches.size());
  }
}

TEST(MatchForInitialization, OctaveSlackKeepsMatchesAcrossAScaleChange) {
  // A camera driving forward sees the scene grow: at 1.3x about the centre, many level-0 corners of frame 1 are
  // found one level up in frame 2, where the same-level search (ORB-SLAM) cannot see them.
  const cv::Mat img1 = texturedImage(640, 480, 33);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> k1, k2;
  cv::Mat d1, d2;
  ex.extract(img1, k1, d1);
  const cv::Mat M = cv::getRotationMatrix2D(cv::Point2f(320, 240), 0.0, 1.3);
  const FeatureGrid grid2 = extractWarped(ex, img1, M, k2, d2);
  auto run = [&](int slack, int& correct, int& crossLevel) {
    std::vector<cv::Point2f> prev(k1.size());
    for (size_t i = 0; i < k1.size(); ++i) prev[i] = apply(M, k1[i].pt);  // a known motion, as after tracking
    InitMatchParams p;
    p.octaveSlack = slack;
    const auto matches = matchForInitialization(k1, d1, k2, d2, grid2, prev, p);
    correct = crossLevel = 0;
    for (const auto& m : matches) {
      EXPECT_LE(std::abs(k2[m.i2].octave - k1[m.i1].octave), slack);
      crossLevel += k2[m.i2].octave != k1[m.i1].octave;
      correct += cv::norm(apply(M, k1[m.i1].pt) - k2[m.i2].pt) < 5.0;
    }
    return static_cast<int>(matches.size());
  };
  int correct0 = 0, cross0 = 0, correct1 = 0, cross1 = 0;
  const int n0 = run(0, correct0, cross0);
  const int n1 = run(1, correct1, cross1);
  std::cout << "1.3x zoom: same level " << n0 << " matches (" << correct0 << " correct), +-1 level " << n1 << " ("
            << correct1 << " correct, " << cross1 << " across levels)\n";
  EXPECT_EQ(cross0, 0);
  EXPECT_GT(cross1, 0);
  EXPECT_GT(correct1, correct0);
  EXPECT_GE(correct1, 0.9 * n1);
  InitMatchParams bad;
  bad.octaveSlack = -1;
  EXPECT_THROW(bad.check(), pslam::Error);
}

TEST(MatchForInitialization, RotationHistogramRemovesInconsistentAngles) {
  const cv::Mat img = texturedImage(640, 480, 32);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> k1;
  cv::Mat d1;
  ex.extract(img, k1, d1);
  // Frame 2 = frame 1 with the angles of every 4th level-0 keypoint turned by 90..270 deg: identical
  // descriptors and positions, so every keypoint matches itself, but the turned ones disagree with the
  // dominant (zero) rotation.
  std::vector<cv::KeyPoint> k2 = k1;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> turn(90.f, 270.f);
  std::set<int> turned;
  int level0 = 0;
  for (int i = 0; i < static_cast<int>(k2.size()); ++i) {
    if (k2[i].octave != 0) continue;
    if (level0++ % 4 == 0) {
      k2[i].angle = std::fmod(k2[i].angle + turn(rng), 360.f);
      turned.insert(i);
    }
  }
  const auto grid2 = FeatureGrid::fromKeypoints(k2, cv::Rect2f(0, 0, 640, 480));
  std::vector<cv::Point2f> prev(k1.size());
  for (size_t i = 0; i < k1.size(); ++i) prev[i] = k1[i].pt;
  auto noCheck = prev;
  InitMatchParams p;
  p.checkOrientation = false;
  const auto all = matchForInitialization(k1, d1, k2, d1, grid2, noCheck, p);
  const auto checked = matchForInitialization(k1, d1, k2, d1, grid2, prev);
  // Self matches are found unless a second keypoint in the window has an identical descriptor (possible in
  // flat synthetic regions), where the ratio test rightly rejects both.
  std::set<std::pair<int, int>> checkedSet;
  for (const auto& m : checked) checkedSet.insert({m.i1, m.i2});
  int selfKept = 0, turnedInAll = 0;
  for (const auto& m : all) {
    if (m.i1 != m.i2) continue;
    if (turned.count(m.i1)) {
      ++turnedInAll;
      EXPECT_EQ(checkedSet.count({m.i1, m.i2}), 0u) << "turned keypoint " << m.i1 << " survived";
    } else {
      ++selfKept;
      EXPECT_EQ(checkedSet.count({m.i1, m.i2}), 1u) << "consistent keypoint " << m.i1 << " removed";
    }
  }
  EXPECT_GE(selfKept + turnedInAll, 0.8 * level0);
  EXPECT_GE(turnedInAll, 0.8 * turned.size());
  EXPECT_LE(checked.size(), all.size() - turnedInAll);
}

TEST(MatchForInitialization, RejectsInconsistentInput) {
  std::vector<cv::KeyPoint> k(3, cv::KeyPoint(cv::Point2f(5, 5), 31));
  cv::Mat d(3, 32, CV_8UC1, cv::Scalar(0));
  const auto grid = FeatureGrid::fromKeypoints(k, cv::Rect2f(0, 0, 10, 10));
  std::vector<cv::Point2f> prevShort(2);
  EXPECT_THROW(matchForInitialization(k, d, k, d, grid, prevShort), pslam::Error);
  std::vector<cv::Point2f> prev(3);
  EXPECT_THROW(matchForInitialization(k, cv::Mat(3, 16, CV_8UC1), k, d, grid, prev), pslam::Error);
  InitMatchParams bad;
  bad.nnRatio = 0;
  EXPECT_THROW(matchForInitialization(k, d, k, d, grid, prev, bad), pslam::Error);
}

TEST(MatchBruteForce, FindsNoisyCopiesAndRejectsDistractors) {
  std::mt19937 rng(41);
  const cv::Mat train = randomDescriptors(400, rng);
  // Queries 0..199: copies of train rows perm[i] with 0..12 bits flipped; 200..299: unrelated descriptors.
  std::vector<int> perm(400);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  cv::Mat query(300, 32, CV_8UC1);
  std::uniform_int_distribution<int> nflip(0, 12), bit(0, 255);
  for (int i = 0; i < 200; ++i) {
    train.row(perm[i]).copyTo(query.row(i));
    for (int f = nflip(rng); f > 0; --f) {
      const int b = bit(rng);
      query.at<uint8_t>(i, b / 8) ^= static_cast<uint8_t>(1u << (b % 8));
    }
  }
  randomDescriptors(100, rng).copyTo(query.rowRange(200, 300));

  for (bool cross : {false, true}) {
    BruteForceParams p;
    p.crossCheck = cross;
    p.maxDistance = 64;  // random 256-bit strings differ in 128 +- 8 bits: 64 is 8 sigma away
    const auto m = matchBruteForce(query, train, p);
    ASSERT_EQ(m.size(), 200u);
    for (int i = 0; i < 200; ++i) {
      EXPECT_EQ(m[i].i1, i);
      EXPECT_EQ(m[i].i2, perm[i]);
      EXPECT_EQ(m[i].distance, hammingDistance(query, i, train, perm[i]));
    }
  }
}

TEST(MatchBruteForce, CrossCheckKeepsOnlyMutualBest) {
  std::mt19937 rng(42);
  const cv::Mat train = randomDescriptors(50, rng);
  cv::Mat query(2, 32, CV_8UC1);
  train.row(7).copyTo(query.row(0));  // exact copy of train 7
  train.row(7).copyTo(query.row(1));
  query.at<uint8_t>(1, 0) ^= 0x0F;  // 4 bits away from train 7: train 7's best query is query 0
  BruteForceParams p;
  p.ratio = 1.f;  // ratio test off
  EXPECT_EQ(matchBruteForce(query, train, p).size(), 2u);
  p.crossCheck = true;
  const auto m = matchBruteForce(query, train, p);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].i1, 0);
  EXPECT_EQ(m[0].i2, 7);
  EXPECT_TRUE(matchBruteForce(cv::Mat(), train).empty());
  EXPECT_THROW(matchBruteForce(cv::Mat(2, 16, CV_8UC1), train), pslam::Error);
}
