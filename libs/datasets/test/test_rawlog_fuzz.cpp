// Seeded mutation fuzzing of the rawlog reader (doc/reliability.md): a small valid rawlog, mutated two thousand
// times (flipped, inserted and deleted bytes, truncation, zero-fill), in the gzip file and in the archive it
// holds (recompressed, so the deserialization behind a valid gzip stream is reached too). Every case must read
// to its end or throw pslam::Error naming the file: never a crash, another exception or a hang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>

#include "FuzzSupport.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::datasets;

namespace {

fs::path scratch() {
  static const fs::path d = [] {
    fs::path p = fs::temp_directory_path() / ("pslam_rawlog_fuzz_" + std::to_string(::getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p;
  }();
  return d;
}

class ScratchCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(scratch(), ec);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

Frame smallFrame(int i) {
  Frame f;
  f.timestamp = 1000.0 + 0.05 * i;
  const int W = 24, H = 16;
  f.camera.ncols = W;
  f.camera.nrows = H;
  f.camera.fx(20.0);
  f.camera.fy(20.0);
  f.camera.cx(11.5);
  f.camera.cy(7.5);
  f.image = cv::Mat(H, W, CV_8UC1);
  cv::randu(f.image, 0, 256);
  f.depth = cv::Mat(H, W, CV_16UC1);
  cv::randu(f.depth, 0, 20000);
  f.depthUnits = 1.0 / 5000.0;
  f.semantic = cv::Mat(H, W, CV_8UC3, cv::Scalar(255, 0, 0));
  f.normals = cv::Mat(H, W, CV_8UC3, cv::Scalar(128, 128, 255));
  return f;
}

std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}
void writeBytes(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary | std::ios::trunc) << s; }

std::string gunzip(const fs::path& p) {
  mrpt::io::CFileGZInputStream in(p.string());
  std::string out;
  char buf[4096];
  std::size_t n = 0;
  while ((n = in.Read(buf, sizeof buf)) > 0) out.append(buf, n);
  return out;
}
void gzip(const std::string& raw, const fs::path& p) {
  mrpt::io::CFileGZOutputStream out(p.string());
  out.Write(raw.data(), raw.size());
}

/// Reads every frame and the frame count: "" when both succeed, else the pslam::Error message. Any other
/// exception fails the test.
std::string readEverything(const fs::path& rawlog, const std::string& what) {
  try {
    RawlogReader::countFrames(rawlog);
    RawlogReader r(rawlog);
    Frame f;
    while (r.next(f)) {
    }
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": not a pslam::Error: " << e.what();
    return "other";
  }
  return "";
}

}  // namespace

TEST(RawlogFuzz, MutatedRawlogsReadOrFailWithAnErrorNamingTheFile) {
  const fs::path valid = scratch() / "valid.rawlog";
  {
    RawlogWriter w(valid);
    for (int i = 0; i < 3; ++i) w.write(smallFrame(i));
    w.commit();
  }
  const std::string gz = readBytes(valid), raw = gunzip(valid);
  ASSERT_FALSE(raw.empty());
  const fs::path file = scratch() / "m.rawlog";
  fs::copy(RawlogWriter::imagesDirFor(valid), RawlogWriter::imagesDirFor(file), fs::copy_options::recursive);

  pslam::testing::HangGuard guard(std::chrono::seconds(60));
  // A mutated size inside a valid gzip stream may ask MRPT for gigabytes (zero-filled): such requests fail fast.
  pslam::testing::capAddressSpace(std::size_t(256) << 20);
  std::mt19937 rng(20240516);
  // 2000 cases, half of them inside the archive: enough to reach the size fields of the DEPTH observations (one
  // crash in 300 mutants of a larger rawlog before the reader checked them: ArchivePeek.h); a few seconds.
  constexpr int kCases = 2000;
  int failed = 0, read = 0;
  for (int k = 0; k < kCases; ++k) {
    std::string what;
    const bool inArchive = k % 2 == 1;  // odd cases: mutate the archive, then compress it again
    if (inArchive)
      gzip(pslam::testing::mutateBytes(raw, rng, what), file);
    else
      writeBytes(file, pslam::testing::mutateBytes(gz, rng, what));
    what = "case " + std::to_string(k) + (inArchive ? " (archive) " : " (gzip) ") + what;
    guard.startCase(what);
    const std::string msg = readEverything(file, what);
    if (msg.empty()) {
      ++read;
      continue;
    }
    ++failed;
    EXPECT_NE(msg.find(file.string()), std::string::npos) << what << ": " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << what << ": " << msg;
    EXPECT_EQ(msg.find("MRPT exception"), std::string::npos) << what << ": " << msg;
  }
  guard.startCase("");
  // Most mutations are refused. Those that read are harmless: a changed depth value inside a recompressed
  // archive, a changed time stamp in the gzip header.
  EXPECT_GT(failed, kCases / 2) << read << " of " << kCases << " mutated rawlogs read without an error";
  std::printf("%d mutated rawlogs: %d refused with a pslam::Error, %d read\n", kCases, failed, read);
}
