// Seeded mutation fuzzing of the map loader (doc/reliability.md): a small valid .slammap, mutated a few hundred
// times (flipped, inserted and deleted bytes, truncation, zero-fill), in the gzip file and in the archive it
// holds (recompressed, so that the field validation behind a valid gzip stream is reached). Every case must
// load, giving a map that satisfies the map invariants, or throw pslam::Error naming the file: never a crash,
// another exception or a hang.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>

#include "FuzzSupport.h"
#include "SyntheticMap.h"
#include "pslam/core/Error.h"
#include "pslam/map/MapIO.h"

namespace fs = std::filesystem;
using namespace pslam::map;
using namespace pslam::map::testing;

namespace {

fs::path scratch() {
  static const fs::path d = [] {
    fs::path p = fs::temp_directory_path() / ("pslam_map_fuzz_" + std::to_string(::getpid()));
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

}  // namespace

TEST(MapIOFuzz, MutatedMapsLoadOrFailWithAnErrorNamingTheFile) {
  SyntheticScene scene;
  Map map = buildSyntheticMap(3, 25, scene);
  KeyFrame& kf = map.mutableKeyFrame(scene.keyframeIds[1]);
  kf.semanticProbabilities.assign(kf.keypoints.size(), {0.7f, 0.2f, 0.1f});
  std::size_t i = 0;
  for (const auto& [id, p] : map.mapPoints()) {
    MapPoint& mp = map.mutableMapPoint(id);
    if (i % 2 == 0) mp.landmarkState = {1.0, 0.25, 2.0, 1.0, 0.1, 0.2, 0.3, 4.0, 5.0};
    mp.bad = (i % 5) == 0;
    ++i;
  }
  const fs::path valid = scratch() / "valid.slammap";
  saveMap(map, valid);
  const std::string gz = readBytes(valid), raw = gunzip(valid);
  const fs::path file = scratch() / "m.slammap";

  pslam::testing::HangGuard guard(std::chrono::seconds(60));
  // A mutated size inside a valid gzip stream may ask MRPT for gigabytes (zero-filled): such requests fail fast.
  pslam::testing::capAddressSpace(std::size_t(256) << 20);
  std::mt19937 rng(7041);
  constexpr int kCases = 400;
  int failed = 0, loaded = 0;
  for (int k = 0; k < kCases; ++k) {
    std::string what;
    const bool inArchive = k % 2 == 1;  // odd cases: mutate the archive, then compress it again
    if (inArchive)
      gzip(pslam::testing::mutateBytes(raw, rng, what), file);
    else
      writeBytes(file, pslam::testing::mutateBytes(gz, rng, what));
    what = "case " + std::to_string(k) + (inArchive ? " (archive) " : " (gzip) ") + what;
    guard.startCase(what);
    try {
      const Map m = loadMap(file);
      m.checkInvariants(what);
      ++loaded;
    } catch (const pslam::Error& e) {
      ++failed;
      const std::string msg = e.what();
      EXPECT_NE(msg.find(file.string()), std::string::npos) << what << ": " << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << what << ": " << msg;
      EXPECT_EQ(msg.find("MRPT exception"), std::string::npos) << what << ": " << msg;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not a pslam::Error: " << e.what();
    }
  }
  guard.startCase("");
  EXPECT_GT(failed, kCases / 2) << loaded << " of " << kCases << " mutated maps loaded";
  std::printf("%d mutated maps: %d refused with a pslam::Error, %d loaded\n", kCases, failed, loaded);
}
