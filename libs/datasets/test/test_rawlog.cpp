#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/serialization/CArchive.h>

#include "pslam/core/Error.h"
#include "pslam/datasets/PrefetchingRawlogReader.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::datasets;

namespace {

/// A fresh folder for one test in this process's temporary folder (removed when the process ends).
fs::path tempDir(const std::string& name) {
  static const pslam::test_support::TempDir root("pslam_test_rawlog");
  return pslam::test_support::freshSubDir(root, name);
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

namespace {
std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// Reads every frame; returns the pslam::Error message, or "" if the whole rawlog read without one.
std::string readAllFramesError(const fs::path& rawlog) {
  try {
    RawlogReader r(rawlog);
    Frame f;
    while (r.next(f)) {
    }
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
std::string countFramesError(const fs::path& rawlog) {
  try {
    RawlogReader::countFrames(rawlog);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// Reliability (doc/reliability.md): the gzip stream is verified to its end (CRC-32 and length) before any frame
// is decoded: a changed byte, a cut file and a file zero-filled from some offset are reported as corrupt, with
// the file and the byte offset, never read as a shorter or altered rawlog; in one line, without MRPT's banner.
TEST(Rawlog, CorruptGzipIsReportedNotReadAsAShorterRawlog) {
  const fs::path d = tempDir("corrupt");
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 3; ++i) w.write(makeFrame(i, false, true));
    w.commit();
  }
  const std::string bytes = readBytes(d / "seq.rawlog");
  ASSERT_GT(bytes.size(), 1000u);
  std::vector<std::pair<std::string, std::string>> cases;
  for (const std::size_t at : {bytes.size() / 4, bytes.size() / 2, bytes.size() * 3 / 4, bytes.size() - 6}) {
    std::string b = bytes;
    b[at] = static_cast<char>(b[at] ^ 0x01);
    cases.emplace_back("xor_" + std::to_string(at), b);
  }
  cases.emplace_back("cut", bytes.substr(0, bytes.size() * 2 / 3));
  std::string zero = bytes;
  std::fill(zero.begin() + static_cast<std::ptrdiff_t>(bytes.size() / 2), zero.end(), '\0');
  cases.emplace_back("zero", zero);
  for (const auto& [name, content] : cases) {
    SCOPED_TRACE(name);
    const fs::path file = d / (name + ".rawlog");
    std::ofstream(file, std::ios::binary) << content;
    fs::copy(d / "seq_Images", d / (name + "_Images"), fs::copy_options::recursive);
    // Zeros may decode as valid deflate codes up to the end of the file: zlib then reports the missing end.
    const std::string truncated = ": corrupt rawlog: truncated: the gzip data ends at byte ";
    const std::string corrupt = ": corrupt rawlog: corrupt gzip data (zlib: ";
    for (const std::string& msg : {readAllFramesError(file), countFramesError(file)}) {
      const bool isTruncated = msg.rfind(file.string() + truncated, 0) == 0;
      const bool isCorrupt = msg.rfind(file.string() + corrupt, 0) == 0;
      EXPECT_TRUE(name == "cut" ? isTruncated : name == "zero" ? isTruncated || isCorrupt : isCorrupt) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
      EXPECT_EQ(msg.find("MRPT exception"), std::string::npos) << msg;
    }
  }
}

namespace {
/// d/cut.rawlog (+ cut_Images): a valid gzip stream holding 3 frames' archive without its last 10 bytes.
void writeRawlogCutInsideItsLastObject(const fs::path& d) {
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 3; ++i) w.write(makeFrame(i, false, false));
    w.commit();
  }
  std::string raw;
  {
    mrpt::io::CFileGZInputStream in((d / "seq.rawlog").string());
    char buf[4096];
    std::size_t n = 0;
    while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  }
  {
    mrpt::io::CFileGZOutputStream out((d / "cut.rawlog").string());
    out.Write(raw.data(), raw.size() - 10);
  }
  fs::copy(d / "seq_Images", d / "cut_Images", fs::copy_options::recursive);
}
}  // namespace

// Reliability: a valid gzip stream whose archive is cut inside an object (e.g. written by a broken tool) is
// corrupt at a named object and frame, not the end of the rawlog.
TEST(Rawlog, ArchiveCutInsideAnObjectIsCorruptAtAFrame) {
  const fs::path d = tempDir("cut_archive");
  writeRawlogCutInsideItsLastObject(d);
  const std::string msg = readAllFramesError(d / "cut.rawlog");
  EXPECT_EQ(msg.rfind((d / "cut.rawlog").string() + ": corrupt rawlog at object 2 (after 2 frames): ", 0), 0u) << msg;
  EXPECT_EQ(countFramesError(d / "cut.rawlog"), msg);
}

// The prefetching reader (slam-run's input): the same frames in the same order as RawlogReader, whatever the
// capacity, and a read error only after every frame before it.
TEST(PrefetchingRawlogReader, GivesExactlyTheFramesOfTheReader) {
  const fs::path d = tempDir("prefetch");
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 7; ++i) w.write(makeFrame(i, i % 3 == 0, i % 2 == 0));
    w.commit();
  }
  std::vector<Frame> expected;
  {
    RawlogReader r(d / "seq.rawlog");
    for (Frame f; r.next(f);) expected.push_back(f);
  }
  ASSERT_EQ(expected.size(), 7u);
  for (std::size_t capacity : {1u, 3u, 10u}) {
    SCOPED_TRACE(capacity);
    PrefetchingRawlogReader r(d / "seq.rawlog", capacity);
    Frame f;
    for (const Frame& e : expected) {
      ASSERT_TRUE(r.next(f));
      EXPECT_EQ(f.index, e.index);
      EXPECT_EQ(f.timestamp, e.timestamp);
      EXPECT_TRUE(equalMats(f.image, e.image));
      EXPECT_EQ(f.hasDepth(), e.hasDepth());
      if (e.hasDepth()) {
        EXPECT_TRUE(equalMats(f.depth, e.depth));
        EXPECT_TRUE(equalMats(f.semantic, e.semantic));
        EXPECT_TRUE(equalMats(f.normals, e.normals));
      }
    }
    EXPECT_FALSE(r.next(f));
    EXPECT_FALSE(r.next(f));  // stays at the end
  }
}

TEST(PrefetchingRawlogReader, ThrowsTheReadErrorAfterTheFramesBeforeIt) {
  const fs::path d = tempDir("prefetch_cut");
  writeRawlogCutInsideItsLastObject(d);
  // The frames RawlogReader gives before its error (it reads one object ahead to end a frame).
  std::size_t before = 0;
  {
    RawlogReader plain(d / "cut.rawlog");
    Frame f;
    try {
      while (plain.next(f)) ++before;
    } catch (const Error&) {
    }
  }
  ASSERT_GE(before, 1u);
  PrefetchingRawlogReader r(d / "cut.rawlog", 4);
  Frame f;
  for (std::size_t i = 0; i < before; ++i) {
    ASSERT_TRUE(r.next(f));
    EXPECT_EQ(f.index, i);
  }
  std::string msg;
  try {
    r.next(f);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg, readAllFramesError(d / "cut.rawlog"));
  EXPECT_EQ(msg.rfind((d / "cut.rawlog").string() + ": corrupt rawlog at object 2 (after 2 frames): ", 0), 0u) << msg;
  // A caller that stops before the broken frame (slam-run's --last) never sees the error.
  PrefetchingRawlogReader early(d / "cut.rawlog", 4);
  ASSERT_TRUE(early.next(f));
  early.stop();
  EXPECT_FALSE(early.next(f));
}

TEST(PrefetchingRawlogReader, StopsWhileFramesAreReadAhead) {
  const fs::path d = tempDir("prefetch_stop");
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 6; ++i) w.write(makeFrame(i, false, true));
    w.commit();
  }
  {
    PrefetchingRawlogReader r(d / "seq.rawlog", 2);
    Frame f;
    ASSERT_TRUE(r.next(f));
    r.stop();  // the thread waits on a full queue: stop() must wake it
    EXPECT_FALSE(r.next(f));
  }
  { PrefetchingRawlogReader unread(d / "seq.rawlog", 1); }  // destroyed without a single next(): no hang
  EXPECT_THROW(PrefetchingRawlogReader(d / "missing.rawlog"), Error);
  EXPECT_THROW(PrefetchingRawlogReader(d / "seq.rawlog", 0), Error);
}

TEST(Rawlog, ChannelsLeftOutAreNotDecoded) {
  // A reader told to leave channels out gives the same CAMERA frames with those channels empty, and does not read
  // their files: a missing NORMALS image is an error only for a reader that decodes NORMALS.
  const fs::path d = tempDir("channels");
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 3; ++i) w.write(makeFrame(i, false, true));
    w.commit();
  }
  RawlogChannels none;
  none.depth = none.semantic = none.normals = false;
  RawlogChannels semanticOnly = none;
  semanticOnly.semantic = true;
  RawlogReader all(d / "seq.rawlog"), without(d / "seq.rawlog", none), semantic(d / "seq.rawlog", semanticOnly);
  Frame a, b, c;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(all.next(a));
    ASSERT_TRUE(without.next(b));
    ASSERT_TRUE(semantic.next(c));
    EXPECT_EQ(b.index, a.index);
    EXPECT_EQ(b.timestamp, a.timestamp);
    EXPECT_TRUE(equalMats(b.image, a.image));
    EXPECT_TRUE(a.hasDepth() && !a.semantic.empty() && !a.normals.empty());
    EXPECT_TRUE(b.depth.empty() && b.semantic.empty() && b.normals.empty());
    EXPECT_TRUE(c.depth.empty() && c.normals.empty());
    EXPECT_TRUE(equalMats(c.semantic, a.semantic));
  }
  EXPECT_FALSE(without.next(b));

  std::size_t removed = 0;
  for (const auto& e : fs::directory_iterator(d / "seq_Images"))
    if (e.path().filename().string().rfind("NORMALS", 0) == 0) removed += fs::remove(e.path()) ? 1 : 0;
  ASSERT_EQ(removed, 3u);
  RawlogReader skipping(d / "seq.rawlog", none);
  EXPECT_TRUE(skipping.next(b));
  RawlogReader decoding(d / "seq.rawlog");
  EXPECT_THROW(decoding.next(a), pslam::Error);
  PrefetchingRawlogReader prefetching(d / "seq.rawlog", 2, none);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(prefetching.next(b));
  EXPECT_FALSE(prefetching.next(b));
}

namespace {
std::string gunzipToString(const fs::path& p) {
  mrpt::io::CFileGZInputStream in(p.string());
  std::string raw;
  char buf[4096];
  std::size_t n = 0;
  while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  return raw;
}
void gzipString(const std::string& raw, const fs::path& p) {
  mrpt::io::CFileGZOutputStream out(p.string());
  out.Write(raw.data(), raw.size());
}
void putU32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s[at + k] = static_cast<char>((v >> (8 * k)) & 0xff);
}
/// Offset of the range image's rows field of the first DEPTH observation in the archive `raw` of a rawlog whose
/// frames are W x H: the first "<H><W>" (uint32, little endian) after the class name.
std::size_t rangeImageSizeOffset(const std::string& raw, std::uint32_t H, std::uint32_t W) {
  const std::size_t cls = raw.find("CObservation3DRangeScan");
  if (cls == std::string::npos) return std::string::npos;
  std::string pattern(8, '\0');
  putU32(pattern, 0, H);
  putU32(pattern, 4, W);
  return raw.find(pattern, cls);
}
}  // namespace

// Reliability: a DEPTH observation whose declared range-image size is corrupt inside a valid gzip stream (what
// crashed every rawlog reader inside MRPT's CObservation3DRangeScan::rangeImage_setSize, repro
// rawlog_depth_size_segfault) is refused before MRPT allocates it: one line naming the file and the frame.
TEST(Rawlog, CorruptRangeImageSizeIsRefusedBeforeMrptAllocatesIt) {
  const fs::path d = tempDir("depth_size");
  {
    RawlogWriter w(d / "seq.rawlog");
    for (int i = 0; i < 3; ++i) w.write(makeFrame(i, false, true));
    w.commit();
  }
  const std::string raw = gunzipToString(d / "seq.rawlog");
  const std::size_t at = rangeImageSizeOffset(raw, 48, 64);
  ASSERT_NE(at, std::string::npos);
  struct SizeCase {
    const char* name;
    std::uint32_t rows, cols;
  };
  // The repro's bytes (0xFE over both fields), sizes that overflow int, and one that fits int but not the file.
  for (const SizeCase& c : {SizeCase{"fe", 0xFEFEFEFEu, 0xFEFEFEFEu}, SizeCase{"rows_negative", 0x80000000u, 64},
                            SizeCase{"product_overflows", 65536, 65536}, SizeCase{"more_than_the_file", 4000, 4000}}) {
    SCOPED_TRACE(c.name);
    std::string bad = raw;
    putU32(bad, at, c.rows);
    putU32(bad, at + 4, c.cols);
    const fs::path file = d / (std::string(c.name) + ".rawlog");
    gzipString(bad, file);
    fs::copy(d / "seq_Images", d / (std::string(c.name) + "_Images"), fs::copy_options::recursive);
    for (const std::string& msg : {readAllFramesError(file), countFramesError(file)}) {
      EXPECT_EQ(msg.rfind(file.string() + ": corrupt rawlog at object 1 (after 1 frames): ", 0), 0u) << msg;
      EXPECT_NE(msg.find("DEPTH observation declares a " + std::to_string(c.rows) + "x" + std::to_string(c.cols) +
                         " range image"),
                std::string::npos)
          << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  }
  // The same size fields, written back, read as before: the check refuses only what cannot be.
  EXPECT_EQ(readAllFramesError(d / "seq.rawlog"), "");
}

// The repro file itself (read only, so copied first), when ../shared is there.
TEST(Rawlog, ReproDepthSizeSegfaultIsOneErrorLine) {
  const fs::path repro = fs::path(PRIORSLAM_SHARED_DATA_DIR).parent_path() / "repro" / "rawlog_depth_size_segfault";
  if (!fs::exists(repro / "min.rawlog")) GTEST_SKIP() << repro << " is absent (the shared folder is not here)";
  const fs::path d = tempDir("repro");
  fs::copy(repro / "min.rawlog", d / "min.rawlog");
  fs::copy(repro / "min_Images", d / "min_Images", fs::copy_options::recursive);
  const std::string msg = readAllFramesError(d / "min.rawlog");
  EXPECT_EQ(msg.rfind((d / "min.rawlog").string() + ": corrupt rawlog at object 1 (after 1 frames): ", 0), 0u) << msg;
  EXPECT_NE(msg.find("DEPTH observation declares a"), std::string::npos) << msg;
}

// Reliability: frame time stamps must increase. A stamp going back and the same stamp twice (all stamps equal,
// all zero) are errors naming the file and the frame: slam-run would otherwise sort its trajectory by stamp and
// score it wrong. A first stamp of 0 is a time (KITTI's times.txt starts there).
TEST(Rawlog, StampsMustIncrease) {
  const fs::path d = tempDir("stamps");
  struct StampCase {
    const char* name;
    std::vector<double> stamps;
    std::string expected;
  };
  const std::vector<StampCase> cases{
      {"back", {10.0, 10.1, 10.05}, "frame 2: timestamp 10.050000 is before the previous frame's 10.100000"},
      {"same", {10.0, 10.1, 10.1}, "frame 2: timestamp 10.100000 is the previous frame's"},
      {"all_zero", {0.0, 0.0, 0.0}, "frame 1: timestamp 0.000000 is the previous frame's"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path file = d / (std::string(c.name) + ".rawlog");
    {
      RawlogWriter w(file);
      for (std::size_t i = 0; i < c.stamps.size(); ++i) {
        Frame f = makeFrame(static_cast<int>(i), false, false);
        f.timestamp = c.stamps[i];
        w.write(f);
      }
      w.commit();
    }
    const std::string msg = readAllFramesError(file);
    EXPECT_EQ(msg.rfind(file.string() + ": " + c.expected, 0), 0u) << msg;
    // Sorting instead is an option: then every frame reads, in stamp order.
    RawlogReader r(file, RawlogChannels{}, StampOrder::sort);
    Frame f;
    double last = -1e300;
    std::size_t n = 0;
    {
      while (r.next(f)) {
        EXPECT_GE(f.timestamp, last);
        last = f.timestamp;
        ++n;
      }
      EXPECT_EQ(n, c.stamps.size());
      EXPECT_FALSE(r.warnings().empty());
    }
  }
}

// Reliability: on a full disk the writers (slam-synth, normal-priors, dataset2rawlog) said "cannot write image"
// without the reason. A file-size limit stands in for the full disk (EFBIG instead of ENOSPC).
TEST(Rawlog, ImageThatCannotBeWrittenSaysWhy) {
  const fs::path d = tempDir("full_disk");
  struct rlimit old {};
  ::getrlimit(RLIMIT_FSIZE, &old);
  const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
  std::string msg;
  {
    RawlogWriter w(d / "seq.rawlog");
    struct rlimit tiny = old;
    tiny.rlim_cur = 512;
    ::setrlimit(RLIMIT_FSIZE, &tiny);
    try {
      w.write(makeFrame(0, true, false));
    } catch (const Error& e) {
      msg = e.what();
    }
    ::setrlimit(RLIMIT_FSIZE, &old);
  }
  std::signal(SIGXFSZ, oldHandler);
  EXPECT_NE(msg.find("cannot write image"), std::string::npos) << msg;
  EXPECT_NE(msg.find("(File too large)"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(d / "seq.rawlog"));
}

// Reliability: an image stored inside the rawlog (MRPT writes them too) whose declared size is corrupt made OpenCV
// try to allocate it (an abort under AddressSanitizer, found by the rawlog fuzz test at 2000 cases); it is refused
// before MRPT reads it. The same image with its sizes intact reads.
TEST(Rawlog, CorruptEmbeddedImageSizeIsRefusedBeforeItIsAllocated) {
  const fs::path d = tempDir("embedded");
  auto write = [&](const fs::path& file) {
    mrpt::io::CFileGZOutputStream out(file.string());
    auto arch = mrpt::serialization::archiveFrom(out);
    auto obs = mrpt::obs::CObservationImage::Create();
    obs->sensorLabel = kCameraLabel;
    obs->timestamp = mrpt::Clock::fromDouble(5.0);
    obs->image = mrpt::img::CImage(cv::Mat(48, 64, CV_8UC1, cv::Scalar(7)), mrpt::img::DEEP_COPY);
    obs->cameraParams.ncols = 64;
    obs->cameraParams.nrows = 48;
    obs->cameraParams.setIntrinsicParamsFromValues(50, 50, 32, 24);
    arch << *obs;
  };
  write(d / "ok.rawlog");
  EXPECT_EQ(readAllFramesError(d / "ok.rawlog"), "");
  std::string raw = gunzipToString(d / "ok.rawlog");
  std::string size(8, '\0');
  putU32(size, 0, 64);
  putU32(size, 4, 48);
  const std::size_t at = raw.find(size, raw.find("CImage"));
  ASSERT_NE(at, std::string::npos);
  putU32(raw, at, 0x7FFFFFFF);
  putU32(raw, at + 4, 0x7FFFFFFF);
  gzipString(raw, d / "huge.rawlog");
  const std::string msg = readAllFramesError(d / "huge.rawlog");
  EXPECT_EQ(msg.rfind((d / "huge.rawlog").string() + ": corrupt rawlog at object 0 (after 0 frames): ", 0), 0u) << msg;
  EXPECT_NE(msg.find("a CObservationImage declares a 2147483647x2147483647 grey image"), std::string::npos) << msg;
}
