#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::datasets;

namespace {

fs::path tempDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("pslam_test_rawlog_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

Frame makeFrame(int i, bool colour, bool channels) {
  Frame f;
  f.timestamp = 1305031102.175304 + 0.0333 * i;
  const int W = 64, H = 48;
  f.camera.ncols = W;
  f.camera.nrows = H;
  f.camera.fx(535.4);
  f.camera.fy(539.2);
  f.camera.cx(32.1);
  f.camera.cy(24.6);
  f.camera.dist[0] = 0.1;
  f.camera.dist[1] = -0.01;
  f.image = cv::Mat(H, W, colour ? CV_8UC3 : CV_8UC1);
  cv::randu(f.image, 0, 256);
  if (channels) {
    f.depth = cv::Mat(H, W, CV_16UC1);
    cv::randu(f.depth, 0, 65535);
    f.depthUnits = 1.0 / 5000.0;
    f.semantic = cv::Mat(H, W, CV_8UC3, cv::Scalar(255, 0, 0));
    f.normals = cv::Mat(H, W, CV_8UC3, cv::Scalar(128, 128, 0));
  }
  return f;
}

bool equalMats(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a.reshape(1) != b.reshape(1)) == 0;
}

}  // namespace

TEST(Rawlog, RoundTripKeepsEveryChannelExactly) {
  const fs::path d = tempDir("roundtrip");
  std::vector<Frame> frames;
  for (int i = 0; i < 3; ++i) frames.push_back(makeFrame(i, i % 2 == 1 ? false : true, i != 1));
  {
    RawlogWriter w(d / "seq.rawlog");
    for (const auto& f : frames) w.write(f);
    w.commit();
  }
  ASSERT_TRUE(fs::exists(d / "seq.rawlog"));
  ASSERT_TRUE(fs::is_directory(d / "seq_Images"));
  EXPECT_EQ(RawlogReader::countFrames(d / "seq.rawlog"), 3u);

  RawlogReader r(d / "seq.rawlog");
  Frame f;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    ASSERT_TRUE(r.next(f));
    EXPECT_EQ(f.index, i);
    EXPECT_NEAR(f.timestamp, frames[i].timestamp, 1e-6);
    EXPECT_TRUE(equalMats(f.image, frames[i].image));
    EXPECT_DOUBLE_EQ(f.camera.fx(), 535.4);
    EXPECT_DOUBLE_EQ(f.camera.cy(), 24.6);
    EXPECT_DOUBLE_EQ(f.camera.dist[0], 0.1);
    EXPECT_EQ(f.hasDepth(), frames[i].hasDepth());
    if (frames[i].hasDepth()) {
      EXPECT_TRUE(equalMats(f.depth, frames[i].depth));
      EXPECT_NEAR(f.depthUnits, 1.0 / 5000.0, 1e-9);
      EXPECT_TRUE(equalMats(f.semantic, frames[i].semantic));
      EXPECT_TRUE(equalMats(f.normals, frames[i].normals));
    }
  }
  EXPECT_FALSE(r.next(f));
}

TEST(Rawlog, UncommittedWriterLeavesNothingBehind) {
  const fs::path d = tempDir("abort");
  {
    RawlogWriter w(d / "seq.rawlog");
    w.write(makeFrame(0, false, false));
    Frame bad = makeFrame(1, false, false);
    bad.image = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));  // intrinsics say 64x48
    EXPECT_THROW(w.write(bad), Error);
  }
  EXPECT_TRUE(fs::is_empty(d));
}

TEST(Rawlog, WriterRejectsInvalidFrames) {
  const fs::path d = tempDir("invalid");
  RawlogWriter w(d / "seq.rawlog");
  Frame f = makeFrame(0, false, false);
  f.timestamp = std::nan("");
  EXPECT_THROW(w.write(f), Error);
  f = makeFrame(0, false, false);
  f.image = cv::Mat();
  EXPECT_THROW(w.write(f), Error);
  f = makeFrame(0, false, true);
  f.depthUnits = 0;
  EXPECT_THROW(w.write(f), Error);
  f = makeFrame(0, false, false);
  f.camera.fx(-1);
  EXPECT_THROW(w.write(f), Error);
  EXPECT_THROW(RawlogWriter(d / "x.rawlog", "jpg"), Error);
}

TEST(Rawlog, ReaderErrorsNameTheFile) {
  const fs::path d = tempDir("reader");
  try {
    RawlogReader r(d / "missing.rawlog");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.rawlog"), std::string::npos);
  }
  {
    std::ofstream(d / "garbage.rawlog") << "this is not a rawlog at all, just some text bytes";
  }
  RawlogReader r(d / "garbage.rawlog");
  Frame f;
  EXPECT_THROW(r.next(f), Error);

  // A rawlog whose image files were deleted.
  {
    RawlogWriter w(d / "noimg.rawlog");
    w.write(makeFrame(0, false, false));
    w.commit();
  }
  fs::remove_all(d / "noimg_Images");
  RawlogReader r2(d / "noimg.rawlog");
  try {
    r2.next(f);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("CAMERA_000000.png"), std::string::npos) << e.what();
  }
}

TEST(Rawlog, NormalEncodingRoundTrip) {
  cv::Vec3d n(0.3, -0.5, 0.8);
  n /= cv::norm(n);
  cv::Vec3d back;
  ASSERT_TRUE(decodeNormal(encodeNormal(n), back));
  EXPECT_LT(cv::norm(back - n), 0.01);
  EXPECT_FALSE(decodeNormal(cv::Vec3b(0, 0, 0), back));
}
