// .slammap save / load: exact round trip, and a pslam::Error naming the file for missing, truncated,
// corrupt, foreign and wrong-version files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

#include "SyntheticMap.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"
#include "pslam/map/MapIO.h"

namespace fs = std::filesystem;
using namespace pslam::map;
using namespace pslam::map::testing;

namespace {

fs::path tempDir() {
  const fs::path d = fs::temp_directory_path() / ("pslam_map_io_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

Map richMap() {
  SyntheticScene scene;
  Map map = buildSyntheticMap(5, 200, scene);
  // Exercise every optional field.
  KeyFrame& kf = map.mutableKeyFrame(scene.keyframeIds[1]);
  kf.semanticProbabilities.assign(kf.keypoints.size(), {0.7f, 0.2f, 0.1f});
  std::size_t i = 0;
  for (const auto& [id, p] : map.mapPoints()) {
    MapPoint& mp = map.mutableMapPoint(id);
    mp.landmarkState = {double(i), 0.25, -1e-300, 1.0 / 3.0};
    mp.visibleCount = int(i % 9) + 1;
    mp.bad = (i % 13) == 0;
    ++i;
  }
  map.eraseKeyFrame(scene.keyframeIds[3]);  // ids with a gap
  return map;
}

// Removes the per-process scratch folder after all tests.
class ScratchCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(tempDir(), ec);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

std::string readAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}
void writeAll(const fs::path& p, const std::string& s) {
  std::ofstream f(p, std::ios::binary);
  f << s;
}

std::string expectLoadError(const fs::path& p) {
  try {
    loadMap(p);
  } catch (const pslam::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    return msg;
  }
  ADD_FAILURE() << "loading " << p << " did not throw";
  return {};
}

}  // namespace

TEST(MapIO, RoundTripIsExact) {
  Map map = richMap();
  map.setVocabulary("k 16, L 4, 65228 words, fnv1a64 0123456789abcdef");
  const fs::path file = tempDir() / "round.slammap";
  saveMap(map, file);
  const Map loaded = loadMap(file);
  EXPECT_TRUE(loaded == map);
  EXPECT_EQ(loaded.numKeyFrames(), map.numKeyFrames());
  EXPECT_EQ(loaded.numMapPoints(), map.numMapPoints());
  // Saving the loaded map gives the same bytes (deterministic output).
  const fs::path again = tempDir() / "again.slammap";
  saveMap(loaded, again);
  EXPECT_EQ(readAll(file), readAll(again));
  // Continue working on the loaded map: ids continue where they stopped.
  Map m2 = loaded;
  KeyFrame kf = m2.keyFrame(m2.rootKeyFrame());
  EXPECT_EQ(m2.addKeyFrame(kf), map.nextKeyFrameId());
  // No temporary files left behind.
  for (const auto& e : fs::directory_iterator(file.parent_path()))
    EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST(MapIO, TheVocabularyRecordIsPartOfTheMap) {
  Map a = richMap(), b = richMap();
  b.setVocabulary("another");
  EXPECT_FALSE(a == b);
  const fs::path file = tempDir() / "vocabulary.slammap";
  saveMap(b, file);
  EXPECT_EQ(loadMap(file).vocabulary(), "another");
}

TEST(MapIO, EmptyMapRoundTrip) {
  const fs::path file = tempDir() / "empty.slammap";
  saveMap(Map(), file);
  EXPECT_TRUE(loadMap(file) == Map());
}

TEST(MapIO, MissingFile) {
  const std::string msg = expectLoadError(tempDir() / "does_not_exist.slammap");
  EXPECT_NE(msg.find("not found"), std::string::npos) << msg;
}

TEST(MapIO, TruncatedFile) {
  const fs::path file = tempDir() / "full.slammap";
  saveMap(richMap(), file);
  const std::string bytes = readAll(file);
  for (double fraction : {0.05, 0.5, 0.95}) {
    const fs::path cut = tempDir() / "cut.slammap";
    writeAll(cut, bytes.substr(0, std::size_t(bytes.size() * fraction)));
    expectLoadError(cut);
  }
}

TEST(MapIO, CutBetweenGzipMembers) {
  // A map file is gzip members of 1 MiB of the archive each (GzipOutputStream); cut right after the first, it is a
  // valid gzip file of the first MiB of the map's bytes, which the map reader must refuse.
  SyntheticScene scene;
  const Map map = buildSyntheticMap(12, 2000, scene);
  const fs::path file = tempDir() / "members.slammap";
  saveMap(map, file);
  std::string raw;
  {
    pslam::GzipInputStream in(file);
    char buf[4096];
    std::size_t n = 0;
    while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  }
  const std::size_t block = pslam::GzipOutputStream::kDefaultBlockBytes;
  ASSERT_GT(raw.size(), block) << "the map is not larger than one gzip member";
  const fs::path firstBlock = tempDir() / "first_block.gz";
  {
    pslam::GzipOutputStream out(firstBlock, 1);
    out.Write(raw.data(), block);
    out.close();
  }
  const std::string first = readAll(firstBlock), bytes = readAll(file);
  ASSERT_LT(first.size(), bytes.size());
  ASSERT_EQ(bytes.substr(0, first.size()), first) << "the map file's first member is not its first MiB";
  const fs::path cut = tempDir() / "cut_between.slammap";
  writeAll(cut, first);
  const std::string msg = expectLoadError(cut);
  EXPECT_NE(msg.find("cut_between.slammap: "), std::string::npos) << msg;
}

TEST(MapIO, CorruptFile) {
  const fs::path file = tempDir() / "full2.slammap";
  saveMap(richMap(), file);
  std::string bytes = readAll(file);
  for (std::size_t i = bytes.size() / 3; i < bytes.size() / 3 + 64; ++i) bytes[i] = char(bytes[i] ^ 0x5A);
  const fs::path bad = tempDir() / "corrupt.slammap";
  writeAll(bad, bytes);
  expectLoadError(bad);
  // Not gz / not a map at all.
  const fs::path text = tempDir() / "text.slammap";
  writeAll(text, "this is not a map\n");
  const std::string foreign = expectLoadError(text);
  EXPECT_NE(foreign.find("not a .slammap file (not gzip-compressed)"), std::string::npos) << foreign;
}

TEST(MapIO, WrongVersion) {
  const fs::path file = tempDir() / "v.slammap";
  saveMap(richMap(), file);
  // Decompress, bump the version byte that follows the class name in MRPT's object header, recompress.
  std::string raw;
  {
    mrpt::io::CFileGZInputStream in(file.string());
    char buf[4096];
    std::size_t n = 0;
    while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  }
  const std::string name = CSlamMapArchive::className;
  const std::size_t pos = raw.find(name);
  ASSERT_NE(pos, std::string::npos);
  ASSERT_EQ(std::uint8_t(raw[pos + name.size()]), CSlamMapArchive::kFormatVersion);
  raw[pos + name.size()] = char(CSlamMapArchive::kFormatVersion + 1);
  const fs::path bumped = tempDir() / "v_next.slammap";
  {
    mrpt::io::CFileGZOutputStream out(bumped.string());
    out.Write(raw.data(), raw.size());
  }
  const std::string msg = expectLoadError(bumped);
  static_assert(CSlamMapArchive::kFormatVersion == 2, "the message below names the next version");
  EXPECT_NE(msg.find("version 3"), std::string::npos) << msg;
}

namespace {
/// The uncompressed MRPT archive inside a .slammap.
std::string decompress(const fs::path& file) {
  std::string raw;
  mrpt::io::CFileGZInputStream in(file.string());
  char buf[4096];
  std::size_t n = 0;
  while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  return raw;
}
void compress(const std::string& raw, const fs::path& file) {
  mrpt::io::CFileGZOutputStream out(file.string());
  out.Write(raw.data(), raw.size());
}
}  // namespace

// Format 0 (before the vocabulary record) is still read: a version-1 file turned back into version 0 (version
// byte 0, the empty vocabulary string removed) loads as the same map.
/// The file of `map` (no vocabulary, no extensions) rewritten as format `version` (0 or 1): the fields the later
/// formats added dropped from its end.
fs::path olderFormat(const Map& map, int version, const std::string& name) {
  const fs::path file = tempDir() / (name + "_v2.slammap");
  saveMap(map, file);
  std::string raw = decompress(file);
  const std::string cls = CSlamMapArchive::className;
  const std::size_t pos = raw.find(cls);
  EXPECT_NE(pos, std::string::npos);
  EXPECT_EQ(std::uint8_t(raw[pos + cls.size()]), 2u);
  raw[pos + cls.size()] = char(version);
  // ... [vocabulary length u32 = 0][extension count u64 = 0]["SLME" u32][MRPT end flag u8]
  EXPECT_EQ(raw.substr(raw.size() - 17, 12), std::string(12, '\0'));
  raw.erase(version == 0 ? raw.size() - 17 : raw.size() - 13, version == 0 ? 12 : 8);
  const fs::path older = tempDir() / (name + "_v" + std::to_string(version) + ".slammap");
  compress(raw, older);
  return older;
}

TEST(MapIO, Version0And1FilesAreStillRead) {
  const Map map = richMap();
  ASSERT_TRUE(map.vocabulary().empty());
  ASSERT_TRUE(map.extensions().empty());
  for (const int v : {0, 1}) {
    std::uint8_t version = 99;
    EXPECT_TRUE(loadMap(olderFormat(map, v, "older"), &version) == map) << v;
    EXPECT_EQ(version, v);
  }
}

TEST(MapIO, ExtensionsAreCarriedByteForByte) {
  // Format 2: named blobs other libraries keep beside the map (lines, loop edges) come back as they were written.
  Map map = richMap();
  std::string binary(300, '\0');
  for (std::size_t i = 0; i < binary.size(); ++i) binary[i] = static_cast<char>(i * 7);
  map.setExtension("lines", binary);
  map.setExtension("loop_edges", "");
  const fs::path file = tempDir() / "extensions.slammap";
  saveMap(map, file);
  const Map loaded = loadMap(file);
  EXPECT_TRUE(loaded == map);
  ASSERT_NE(loaded.extension("lines"), nullptr);
  EXPECT_EQ(*loaded.extension("lines"), binary);
  ASSERT_NE(loaded.extension("loop_edges"), nullptr);
  EXPECT_TRUE(loaded.extension("loop_edges")->empty());
  EXPECT_EQ(loaded.extension("other"), nullptr);
  const fs::path again = tempDir() / "extensions_again.slammap";
  saveMap(loaded, again);
  EXPECT_EQ(decompress(again), decompress(file));
}

// Reliability (doc/reliability.md): a flag byte other than 0 / 1 is refused (it used to be read straight into
// a bool: undefined behaviour).
TEST(MapIO, FlagByteOtherThanZeroOrOneIsRefused) {
  Map map = richMap();
  const MapPointId last = map.mapPoints().rbegin()->first;
  map.mutableMapPoint(last).landmarkState.clear();
  const fs::path file = tempDir() / "flag.slammap";
  saveMap(map, file);
  std::string raw = decompress(file);
  // The archive ends with the last point's [bad u8][firstKeyFrame u64][landmark count u64 = 0], the vocabulary
  // record (an MRPT string: u32 length, here 0), the extension count (u64 = 0), the end marker "SLME" (u32) and
  // MRPT's end-of-object flag (u8).
  ASSERT_TRUE(map.vocabulary().empty());
  const std::size_t at = raw.size() - 34;
  ASSERT_EQ(raw.substr(raw.size() - 5, 4), std::string("EMLS"));
  ASSERT_LE(std::uint8_t(raw[at]), 1u);
  raw[at] = char(0x42);
  const fs::path bad = tempDir() / "flag_0x42.slammap";
  compress(raw, bad);
  const std::string msg = expectLoadError(bad);
  EXPECT_NE(msg.find("flag 'bad' is 66 (expected 0 or 1)"), std::string::npos) << msg;
}

// Reliability: keypoints must lie in (a margin around) the keyframe's image.
TEST(MapIO, KeypointFarOutsideTheImageIsRefused) {
  Map map = richMap();
  const KeyFrameId id = map.keyFrames().begin()->first;
  map.mutableKeyFrame(id).keypoints[0].pt.y = 3e38f;
  const fs::path file = tempDir() / "far_keypoint.slammap";
  saveMap(map, file);
  const std::string msg = expectLoadError(file);
  EXPECT_NE(msg.find("keypoint 0 at (" ), std::string::npos) << msg;
  EXPECT_NE(msg.find("is far outside the 640x480 image"), std::string::npos) << msg;
}

// Reliability: the gzip stream is verified to its end (a changed CRC byte is corrupt data), and a truncated map
// says so in one line without MRPT's exception banner.
TEST(MapIO, GzipIsVerifiedAndTruncationIsOneLine) {
  const fs::path file = tempDir() / "crc.slammap";
  saveMap(richMap(), file);
  std::string bytes = readAll(file);
  bytes[bytes.size() - 6] = char(bytes[bytes.size() - 6] ^ 0x01);  // inside the CRC-32 of the trailer
  const fs::path bad = tempDir() / "crc_bad.slammap";
  writeAll(bad, bytes);
  const std::string crc = expectLoadError(bad);
  EXPECT_NE(crc.find("corrupt gzip data"), std::string::npos) << crc;

  const std::string full = readAll(file);
  const fs::path cut = tempDir() / "cut_one_line.slammap";
  writeAll(cut, full.substr(0, full.size() / 2));
  const std::string msg = expectLoadError(cut);
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("MRPT exception"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

// Reliability: another MRPT archive (here a pose) is named as such.
TEST(MapIO, ForeignArchiveSaysWhatItHolds) {
  const fs::path file = tempDir() / "pose.slammap";
  {
    mrpt::io::CFileGZOutputStream out(file.string());
    auto arch = mrpt::serialization::archiveFrom(out);
    arch << mrpt::poses::CPose3D(1, 2, 3, 0, 0, 0);
  }
  const std::string msg = expectLoadError(file);
  EXPECT_NE(msg.find("not a .slammap file (it holds a mrpt::poses::CPose3D)"), std::string::npos) << msg;
}

namespace {
void putU64(std::string& s, std::size_t at, std::uint64_t v) {
  for (int k = 0; k < 8; ++k) s[at + k] = static_cast<char>((v >> (8 * k)) & 0xff);
}
std::uint64_t getU64(const std::string& s, std::size_t at) {
  std::uint64_t v = 0;
  for (int k = 0; k < 8; ++k) v |= std::uint64_t(std::uint8_t(s[at + k])) << (8 * k);
  return v;
}
/// Offset of the map's first field (next keyframe id) in the archive of a saved map: after the class name and the
/// version byte.
std::size_t firstFieldOffset(const std::string& raw) {
  const std::string cls = CSlamMapArchive::className;
  return raw.find(cls) + cls.size() + 1;
}
}  // namespace

// Reliability (doc/reliability.md): next-id counters of 2^64-1 loaded, and extending such a map failed in mid-run
// blaming the rawlog. They are refused at load.
TEST(MapIO, ImplausibleNextIdsAreRefusedAtLoad) {
  const fs::path file = tempDir() / "ids.slammap";
  saveMap(richMap(), file);
  const std::string raw = decompress(file);
  const std::size_t at = firstFieldOffset(raw);
  for (const std::size_t field : {at, at + 8}) {
    std::string bad = raw;
    putU64(bad, field, ~std::uint64_t(0));
    const fs::path p = tempDir() / ("ids_" + std::to_string(field - at) + ".slammap");
    compress(bad, p);
    const std::string msg = expectLoadError(p);
    EXPECT_NE(msg.find(" id 18446744073709551615 is implausible"), std::string::npos) << msg;
  }
}

// Reliability: a count the rest of the file cannot hold is refused before anything is allocated for it (a crafted
// 3.2 MB map declaring 99 M keypoints took 3.7 GB and 21.6 s to be refused).
TEST(MapIO, ImpossibleCountsAreRefusedBeforeAllocating) {
  Map map = richMap();
  const fs::path file = tempDir() / "counts.slammap";
  saveMap(map, file);
  const std::string raw = decompress(file);
  // [nextKf][nextPt][keyframe count][id][timestamp][4x4 pose][fx fy cx cy][w h: int32] then the keypoint count.
  const std::size_t at = firstFieldOffset(raw) + 8 * 3 + 8 + 8 + 16 * 8 + 4 * 8 + 2 * 4;
  ASSERT_EQ(getU64(raw, at), map.keyFrames().begin()->second.keypoints.size());
  std::string bad = raw;
  putU64(bad, at, 99'000'000);
  const fs::path p = tempDir() / "99M_keypoints.slammap";
  compress(bad, p);
  const std::string msg = expectLoadError(p);
  EXPECT_NE(msg.find("declares 99000000 keypoints (2772000000 bytes at least), more than the "), std::string::npos)
      << msg;
}

// Reliability: bytes after the end of the gzip stream (a file appended to) were accepted.
TEST(MapIO, BytesAfterTheGzipStreamAreAnError) {
  const fs::path file = tempDir() / "trailing.slammap";
  saveMap(richMap(), file);
  writeAll(file, readAll(file) + "garbage");
  const std::string msg = expectLoadError(file);
  EXPECT_NE(msg.find("7 bytes after the end of the gzip data"), std::string::npos) << msg;
}

// Reliability: a gzip-compressed text file given as a map gave MRPT's "Exception while parsing typed object"; it is
// named as what it is not.
TEST(MapIO, GzippedTextIsNotAMap) {
  const fs::path file = tempDir() / "text.slammap";
  compress("timestamp tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n", file);
  const std::string msg = expectLoadError(file);
  EXPECT_NE(msg.find("text.slammap: not a .slammap file (its data is not an MRPT archive)"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("parsing typed object"), std::string::npos) << msg;
}
