#include <gtest/gtest.h>

#include <unistd.h>

#include "TestUtil.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/DepthRatio.h"

using namespace pslam;
using namespace pslam::eval;
using pslam::eval::test::TempDir;

namespace {
// Depth image: value 1000 * (1 + row) units of 1 mm, i.e. row r has depth (1 + r) metres; (0, 0) invalid.
DepthFrame makeDepthFrame(double t) {
  DepthFrame f;
  f.timestamp = t;
  f.depth = cv::Mat(48, 64, CV_16UC1);
  for (int r = 0; r < 48; ++r) f.depth.row(r).setTo(1000 * (1 + r));
  f.depth.at<std::uint16_t>(0, 0) = 0;
  f.depthUnits = 0.001;
  return f;
}
}  // namespace

TEST(DepthRatio, CountsInliersBelowTauOnRelativeError) {
  const std::vector<DepthFrame> frames = {makeDepthFrame(10.0), makeDepthFrame(11.0)};
  // GT depths: row 1 -> 2 m, row 3 -> 4 m, row 9 -> 10 m.
  const std::vector<DepthSample> samples = {
      {10.0, 5.0, 1.0, 2.1},     // rel 0.05 -> inlier
      {10.0, 5.2, 3.4, 4.5},     // rounded to (5, 3): rel 0.125 -> outlier
      {11.0005, 7.0, 9.0, 9.2},  // 0.5 ms off, rel 0.08 -> inlier
      {11.0, 0.0, 0.0, 1.0},     // GT invalid (0)
      {11.0, 100.0, 2.0, 1.0},   // outside the image
  };
  DepthRatioOptions o;  // tau 0.1
  const DepthRatioResult r = computeDepthRatio(samples, frames, o);
  EXPECT_EQ(r.evaluated, 3u);
  EXPECT_EQ(r.inliers, 2u);
  EXPECT_EQ(r.withoutGroundTruth, 2u);
  EXPECT_DOUBLE_EQ(r.ratio, 2.0 / 3.0);
  EXPECT_NEAR(r.relativeError.max, 0.125, 1e-12);
  // A monocular scale: depths estimated at half size are correct after scaling by 2.
  std::vector<DepthSample> half = samples;
  for (auto& s : half) s.depth *= 0.5;
  o.scale = 2.0;
  EXPECT_DOUBLE_EQ(computeDepthRatio(half, frames, o).ratio, 2.0 / 3.0);
}

TEST(DepthRatio, ErrorsNameTheProblem) {
  const std::vector<DepthFrame> frames = {makeDepthFrame(10.0)};
  DepthRatioOptions o;
  EXPECT_THROW(computeDepthRatio({{12.0, 1, 1, 1.0}}, frames, o), Error);  // no frame within 1 ms
  EXPECT_THROW(computeDepthRatio({{10.0, 0, 0, 1.0}}, frames, o), Error);  // no valid GT at all
  EXPECT_THROW(computeDepthRatio({}, frames, o), Error);
  o.tau = 0.0;
  try {
    o.check();
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dr_tau"), std::string::npos);
  }
  TempDir d("dr_read");
  try {
    readDepthSamples(d.write("s.txt", "# t u v d\n1.0 2 3 4\n1.0 2 3\n"));
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("s.txt:3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readDepthSamples(d.write("n.txt", "1.0 2 3 -1\n")), Error);
  EXPECT_THROW(readDepthSamples(d.path / "missing.txt"), Error);
  EXPECT_EQ(readDepthSamples(d.write("ok.txt", "1.0 2 3 4\n\n2.0 1 1 0.5\n")).size(), 2u);
}

TEST(DepthRatio, ReadsGroundTruthFromARawlogDepthChannel) {
  TempDir d("dr_rawlog");
  const auto rawlog = d.path / "seq.rawlog";
  {
    datasets::RawlogWriter w(rawlog);
    for (int i = 0; i < 3; ++i) {
      datasets::Frame f;
      f.timestamp = 100.0 + i;
      f.camera.ncols = 64;
      f.camera.nrows = 48;
      f.camera.fx(500);
      f.camera.fy(500);
      f.camera.cx(32);
      f.camera.cy(24);
      f.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(i * 10));
      if (i != 2) {
        const DepthFrame df = makeDepthFrame(f.timestamp);
        f.depth = df.depth;
        f.depthUnits = df.depthUnits;
      }
      w.write(f);
    }
    w.commit();
  }
  DepthRatioOptions o;
  const DepthRatioResult r = computeDepthRatio({{100.0, 3, 1, 2.05}, {101.0, 3, 3, 5.0}}, rawlog, o);
  EXPECT_EQ(r.evaluated, 2u);
  EXPECT_EQ(r.inliers, 1u);
  // Frame 2 has no DEPTH: referring to it is an error naming the rawlog.
  try {
    computeDepthRatio({{102.0, 3, 1, 2.0}}, rawlog, o);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("seq.rawlog"), std::string::npos) << e.what();
  }
}
