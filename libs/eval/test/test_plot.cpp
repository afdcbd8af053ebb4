#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/eval/Plot.h"

using namespace pslam::eval;

TEST(NiceTicks, StepsAreOneTwoFiveTimesPowerOfTen) {
  const auto t = niceTicks(0.0, 1.0, 5);
  ASSERT_EQ(t.size(), 6u);  // 0, 0.2, ..., 1.0
  EXPECT_NEAR(t.front(), 0.0, 1e-12);
  EXPECT_NEAR(t[1] - t[0], 0.2, 1e-12);
  EXPECT_NEAR(t.back(), 1.0, 1e-12);
  const auto u = niceTicks(-3.7, 12.1, 6);  // rough step 2.63 -> 5
  ASSERT_GE(u.size(), 2u);
  EXPECT_NEAR(u[1] - u[0], 5.0, 1e-12);
  EXPECT_GE(u.front(), -3.7);
  EXPECT_LE(u.back(), 12.1);
  EXPECT_TRUE(niceTicks(1.0, 1.0).empty());
  EXPECT_TRUE(niceTicks(0.0, NAN).empty());
}

TEST(Colormap, EndsDifferAndClamp) {
  const cv::Scalar lo = colormapColor(0.0, 0.0, 1.0), hi = colormapColor(1.0, 0.0, 1.0);
  EXPECT_NE(lo, hi);
  EXPECT_EQ(colormapColor(-5.0, 0.0, 1.0), lo);
  EXPECT_EQ(colormapColor(7.0, 0.0, 1.0), hi);
}

TEST(Plot, RendersSeriesInsideTheAxes) {
  Plot p("test", "x", "y");
  p.style().width = 400;
  p.style().height = 300;
  p.style().showLegend = false;
  // A thick red horizontal line at y = 0.5 over x in [0, 1]: the centre pixel of the plot area must be red.
  p.addLine({0.0, 1.0}, {0.5, 0.5}, "line", colors::red(), 5);
  p.addScatter({0.0, 1.0}, {0.0, 1.0}, "pts", colors::blue(), 3);
  const cv::Mat img = p.render();
  ASSERT_EQ(img.type(), CV_8UC3);
  ASSERT_EQ(img.cols, 400);
  ASSERT_EQ(img.rows, 300);
  // Plot area is [95, 370] x [55, 225] (see Plot.cpp margins); y data range [0,1] padded symmetrically.
  const cv::Vec3b centre = img.at<cv::Vec3b>(55 + 170 / 2, 95 + 275 / 2);
  EXPECT_EQ(centre, cv::Vec3b(40, 39, 214));
}

TEST(Plot, BadInputThrows) {
  Plot p("t", "x", "y");
  EXPECT_THROW(p.addLine({1, 2}, {1}, "l", colors::red()), pslam::Error);
  EXPECT_THROW(p.addColoredScatter({1, 2}, {1, 2}, {1}, "c", "v"), pslam::Error);
  EXPECT_THROW(p.setColorRange(1, 1), pslam::Error);
  EXPECT_THROW(p.setYRange(2, 1), pslam::Error);
}

TEST(Plot, SavesPngAtomicallyAndReadsBack) {
  const auto dir = std::filesystem::temp_directory_path() / "pslam_eval_test_plot";
  std::filesystem::remove_all(dir);
  Plot p("coloured", "x [m]", "y [m]");
  p.style().equalAspect = true;
  std::vector<double> x, y, v;
  for (int i = 0; i < 100; ++i) {
    x.push_back(std::cos(i * 0.1));
    y.push_back(std::sin(i * 0.1));
    v.push_back(i);
  }
  p.addLine(x, y, "path", colors::grey(), 1);
  p.addColoredScatter(x, y, v, "error", "value");
  const auto file = dir / "sub" / "plot.png";
  p.save(file);
  const cv::Mat back = cv::imread(file.string());
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(back.cols, p.style().width);
  // No temporary left behind.
  int entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir / "sub")) ++entries;
  EXPECT_EQ(entries, 1);
  std::filesystem::remove_all(dir);
}
