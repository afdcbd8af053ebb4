// FeatureGrid: window and radius queries with octave filters equal brute force, incl. points and queries
// outside the grid bounds; bad input is rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pslam/core/Error.h"
#include "pslam/features/FeatureGrid.h"

using namespace pslam::features;

TEST(FeatureGrid, QueriesEqualBruteForce) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> ux(-20.f, 660.f), uy(-20.f, 500.f), ur(0.f, 150.f);
  std::uniform_int_distribution<int> uo(0, 7);
  std::vector<cv::Point2f> pts(3000);
  std::vector<int> oct(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    pts[i] = {ux(rng), uy(rng)};
    oct[i] = uo(rng);
  }
  pts[0] = {640.f, 480.f};  // exactly on the far bounds
  const FeatureGrid grid(pts, oct, cv::Rect2f(0, 0, 640, 480));
  ASSERT_EQ(grid.size(), pts.size());
  size_t nonEmpty = 0;
  for (int q = 0; q < 400; ++q) {
    const float cx = ux(rng), cy = uy(rng), r = q % 10 == 0 ? 0.f : ur(rng);
    OctaveRange range;
    if (q % 3 == 1) range = OctaveRange::only(uo(rng));
    if (q % 3 == 2) range = {2, 5};
    std::vector<size_t> window, radius;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (!range.contains(oct[i])) continue;
      const float dx = pts[i].x - cx, dy = pts[i].y - cy;
      if (std::abs(dx) < r && std::abs(dy) < r) window.push_back(i);
      if (dx * dx + dy * dy <= r * r) radius.push_back(i);
    }
    EXPECT_EQ(grid.featuresInWindow(cx, cy, r, range), window) << "query " << q;
    EXPECT_EQ(grid.featuresInRadius(cx, cy, r, range), radius) << "query " << q;
    nonEmpty += window.empty() ? 0 : 1;
  }
  EXPECT_GT(nonEmpty, 200u) << "the comparison must exercise non-empty results";
}

TEST(FeatureGrid, FromKeypointsAndEdgeCases) {
  std::vector<cv::KeyPoint> kps{{cv::Point2f(10, 10), 31, 0, 0, 0}, {cv::Point2f(12, 11), 31, 0, 0, 1}};
  const auto grid = FeatureGrid::fromKeypoints(kps, cv::Rect2f(0, 0, 100, 100), 10, 10);
  EXPECT_EQ(grid.featuresInRadius(11, 10, 3), (std::vector<size_t>{0, 1}));
  EXPECT_EQ(grid.featuresInRadius(11, 10, 3, OctaveRange::only(1)), (std::vector<size_t>{1}));
  EXPECT_TRUE(grid.featuresInWindow(11, 10, -1).empty());
  EXPECT_TRUE(grid.featuresInWindow(NAN, 10, 5).empty());
  EXPECT_TRUE(FeatureGrid({}, {}, cv::Rect2f(0, 0, 10, 10)).featuresInRadius(1, 1, 100).empty());

  EXPECT_THROW(FeatureGrid({{1, 1}}, {}, cv::Rect2f(0, 0, 10, 10)), pslam::Error);
  EXPECT_THROW(FeatureGrid({{NAN, 1}}, {0}, cv::Rect2f(0, 0, 10, 10)), pslam::Error);
  EXPECT_THROW(FeatureGrid({{1, 1}}, {0}, cv::Rect2f(0, 0, 0, 10)), pslam::Error);
  EXPECT_THROW(FeatureGrid({{1, 1}}, {0}, cv::Rect2f(0, 0, 10, 10), 0, 4), pslam::Error);
}
