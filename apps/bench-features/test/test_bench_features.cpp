// BenchFeaturesApp: prints every stage, writes JSON atomically, names the file on bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "SyntheticImages.h"
#include "pslam/core/Error.h"
#include "pslam/features/BenchFeatures.h"

using namespace pslam::features;
namespace fs = std::filesystem;

namespace {
fs::path freshDir(const std::string& name) {
  const fs::path d = fs::path(PRIORSLAM_BINARY_DIR) / "test_tmp" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}
}  // namespace

TEST(BenchFeatures, PrintsStagesAndWritesJson) {
  const fs::path dir = freshDir("bench_features");
  cv::imwrite((dir / "a.png").string(), test::texturedImage(320, 240, 1));
  cv::imwrite((dir / "b.png").string(), test::texturedImage(320, 240, 2));
  BenchFeaturesOptions o;
  o.input = dir;
  o.runs = 2;
  o.orb.nFeatures = 300;
  o.jsonOutput = dir / "out" / "bench.json";
  o.directPoints = 500;
  std::ostringstream out;
  const auto r = BenchFeaturesApp(o).run(out);
  for (const char* stage :
       {"pyramid", "fast+quadtree", "orientation", "descriptors", "levels", "total", "levels_cpu", "opencv_orb"}) {
    EXPECT_NE(out.str().find(stage), std::string::npos) << stage;
    ASSERT_EQ(r.timings.samples().at(stage).size(), 4u) << stage;  // 2 images x 2 runs
  }
  // The total is the pyramid plus the levels' wall time, not the sum of the per-level stages (which overlap on
  // the level threads).
  const auto& samples = r.timings.samples();
  for (size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(samples.at("total")[i], samples.at("pyramid")[i] + samples.at("levels")[i], 1e-9);
  EXPECT_NE(out.str().find("2 thread(s) for the levels"), std::string::npos) << out.str();
  EXPECT_EQ(r.timings.samples().at("direct_points").size(), 4u);
  EXPECT_GT(r.meanDirectPoints, 0);
  EXPECT_EQ(r.images.size(), 2u);
  EXPECT_GT(r.meanKeypoints, 0);
  std::ifstream f(o.jsonOutput);
  ASSERT_TRUE(f.good());
  const auto j = nlohmann::json::parse(f);
  EXPECT_EQ(j.at("runs_per_image"), 2);
  EXPECT_TRUE(j.at("timings_ms").contains("total"));
}

TEST(BenchFeatures, BadInputNamesTheFile) {
  const fs::path dir = freshDir("bench_features_bad");
  BenchFeaturesOptions o;
  o.input = dir / "missing.png";
  try {
    std::ostringstream out;
    BenchFeaturesApp(o).run(out);
    FAIL() << "no error";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "broken.png") << "not a png";
  o.input = dir / "broken.png";
  std::ostringstream out;
  EXPECT_THROW(BenchFeaturesApp(o).run(out), pslam::Error);
  o.input = freshDir("bench_features_empty");
  EXPECT_THROW(BenchFeaturesApp(o).run(out), pslam::Error);
  o.runs = 0;
  EXPECT_THROW(BenchFeaturesApp{o}, pslam::Error);
}

TEST(BenchFeatures, GridSpreadCountsCells) {
  std::vector<cv::KeyPoint> even, clumped;
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 16; ++x) even.emplace_back(cv::Point2f(x * 10 + 5.f, y * 10 + 5.f), 31);
  for (int i = 0; i < 96; ++i) clumped.emplace_back(cv::Point2f(1, 1), 31);
  const auto e = gridSpread(even, cv::Size(160, 60));
  EXPECT_EQ(e.emptyCells, 0);
  EXPECT_EQ(e.minCount, 1);
  EXPECT_EQ(e.maxCount, 1);
  EXPECT_DOUBLE_EQ(e.coefficientOfVariation, 0.0);
  const auto c = gridSpread(clumped, cv::Size(160, 60));
  EXPECT_EQ(c.emptyCells, 95);
  EXPECT_EQ(c.maxCount, 96);
  EXPECT_NEAR(c.coefficientOfVariation, std::sqrt(95.0), 1e-9);  // one cell holds everything: std/mean = sqrt(n-1)
}
