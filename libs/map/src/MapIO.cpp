#include "pslam/map/MapIO.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <utility>

#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"

namespace pslam::map {

IMPLEMENTS_SERIALIZABLE(CSlamMapArchive, CSerializable, pslam::map)

// Private-state access for (de)serialization without widening Map's public API.
struct MapSerializationAccess {
  static std::map<KeyFrameId, KeyFrame>& keyframes(Map& m) { return m.keyframes_; }
  static std::map<MapPointId, MapPoint>& points(Map& m) { return m.points_; }
  static KeyFrameId& nextKf(Map& m) { return m.nextKeyFrameId_; }
  static MapPointId& nextPt(Map& m) { return m.nextMapPointId_; }
};

namespace {

using mrpt::serialization::CArchive;

// Guards against absurd counts read from a corrupt file (they would otherwise allocate gigabytes).
constexpr std::uint64_t kMaxCount = 100'000'000ULL;
constexpr std::uint64_t kMaxExtensions = 64;
constexpr std::uint64_t kMaxPyramidLevels = 64;
constexpr std::uint64_t kMaxLandmarkState = 1024;
constexpr std::int32_t kMaxImageSide = 1 << 16;
constexpr std::uint32_t kEndSentinel = 0x534C4D45;  // "SLME"
// A map file's compression level: level 6 made KITTI 00's map 3 % smaller and took 1.5x the time of level 1.
constexpr int kMapGzipLevel = 1;

// Ids are given one by one: a next id past this is no map's (and 2^64-1 would wrap when the map is extended).
constexpr std::uint64_t kMaxNextId = std::uint64_t(1) << 48;

/// The decompressed bytes of the file being loaded and the stream reading them (set by loadMap for its thread), so
/// that a count can be checked against the bytes left before anything is allocated or read for it.
struct ReadBudget {
  const mrpt::io::CStream* stream = nullptr;
  std::uint64_t total = 0;
  std::uint64_t left() const { return total > stream->getPosition() ? total - stream->getPosition() : 0; }
};
thread_local const ReadBudget* t_readBudget = nullptr;

/// A count of items of at least `bytesPerItem` bytes each: refused when implausible (above `max`) or when the items
/// cannot be in the bytes left of the file (a crafted count would otherwise be read item by item, for seconds and
/// gigabytes, until the data ran out).
std::uint64_t readCount(CArchive& in, const char* what, std::uint64_t max = kMaxCount, std::uint64_t bytesPerItem = 1) {
  std::uint64_t n = 0;
  in >> n;
  if (n > max) throw Error(std::string("implausible ") + what + " count " + std::to_string(n));
  if (t_readBudget && n * bytesPerItem > t_readBudget->left())
    throw Error(std::string("declares ") + std::to_string(n) + " " + what + "s (" + std::to_string(n * bytesPerItem) +
                " bytes at least), more than the " + std::to_string(t_readBudget->left()) + " bytes left in the file");
  return n;
}

/// An MRPT string (u32 length, then the bytes), its length checked before the string is allocated: MRPT's own
/// operator>> resizes to whatever length it reads (up to 4 GiB, zero-filled) before it reads a byte.
std::string readString(CArchive& in, const char* what, std::uint64_t max) {
  std::uint32_t n = 0;
  in >> n;
  if (n > max) throw Error(std::string(what) + " of " + std::to_string(n) + " bytes");
  if (t_readBudget && n > t_readBudget->left())
    throw Error(std::string(what) + " of " + std::to_string(n) + " bytes, more than the " +
                std::to_string(t_readBudget->left()) + " bytes left in the file");
  std::string s(n, '\0');
  if (n > 0 && in.ReadBuffer(s.data(), n) != n) throw Error(std::string(what) + " cut short");
  return s;
}

std::size_t cappedReserve(std::uint64_t n) { return static_cast<std::size_t>(std::min<std::uint64_t>(n, 1u << 16)); }

void requireFinite(double x, const std::string& context, const char* what) {
  if (!std::isfinite(x)) throw Error(context + ": " + what + " is NaN or Inf");
}

void writeDoubles(CArchive& out, const std::vector<double>& v) {
  out << std::uint64_t(v.size());
  for (double x : v) out << x;
}

std::vector<double> readDoubles(CArchive& in, const char* what, std::uint64_t max, const std::string& context) {
  const std::uint64_t n = readCount(in, what, max, 8);
  std::vector<double> v;
  v.reserve(cappedReserve(n));
  for (std::uint64_t i = 0; i < n; ++i) {
    double x = 0.0;
    in >> x;
    requireFinite(x, context, what);
    v.push_back(x);
  }
  return v;
}

void writeMat(CArchive& out, const cv::Mat& m) {
  const std::int32_t rows = m.rows, cols = m.cols, type = m.empty() ? 0 : m.type();
  out << rows << cols << type;
  if (m.empty()) return;
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  out.WriteBuffer(c.data, c.total() * c.elemSize());
}

/// A descriptor matrix: empty, or `maxRows` rows at most of 32 bytes.
cv::Mat readMat(CArchive& in, std::int64_t maxRows, const std::string& context) {
  std::int32_t rows = 0, cols = 0, type = 0;
  in >> rows >> cols >> type;
  if (rows == 0 && cols == 0) return {};
  if (rows <= 0 || rows > maxRows || cols != 32 || type != CV_8UC1)
    throw Error(context + ": invalid descriptor matrix header (" + std::to_string(rows) + " x " + std::to_string(cols) +
                ", type " + std::to_string(type) + ")");
  cv::Mat m(rows, cols, type);
  const std::size_t bytes = m.total() * m.elemSize();
  if (in.ReadBuffer(m.data, bytes) != bytes) throw Error(context + ": truncated descriptor matrix");
  return m;
}

/// A serialized bool: one byte, 0 or 1 (reading it into a bool directly is undefined for other values).
bool readFlag(CArchive& in, const std::string& context, const char* what) {
  std::uint8_t b = 0;
  in >> b;
  if (b > 1) throw Error(context + ": flag '" + what + "' is " + std::to_string(b) + " (expected 0 or 1)");
  return b == 1;
}

void writeVec3(CArchive& out, const Eigen::Vector3d& v) { out << v.x() << v.y() << v.z(); }
Eigen::Vector3d readVec3(CArchive& in) {
  Eigen::Vector3d v;
  in >> v.x() >> v.y() >> v.z();
  return v;
}

void writeKeyFrame(CArchive& out, const KeyFrame& kf) {
  out << std::uint64_t(kf.id) << kf.timestamp;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out << kf.T_cam_world.matrix()(r, c);
  out << kf.camera.fx << kf.camera.fy << kf.camera.cx << kf.camera.cy << std::int32_t(kf.camera.width)
      << std::int32_t(kf.camera.height);
  out << std::uint64_t(kf.keypoints.size());
  for (const cv::KeyPoint& k : kf.keypoints)
    out << k.pt.x << k.pt.y << k.size << k.angle << k.response << std::int32_t(k.octave) << std::int32_t(k.class_id);
  writeMat(out, kf.descriptors);
  writeDoubles(out, kf.scaleFactors);
  writeDoubles(out, kf.levelSigma2);
  out << std::uint64_t(kf.semanticProbabilities.size());
  for (const auto& s : kf.semanticProbabilities) out << s[0] << s[1] << s[2];
  out << std::uint64_t(kf.mapPointIds.size());
  for (MapPointId p : kf.mapPointIds) out << std::uint64_t(p);
  out << std::uint64_t(kf.sharedPoints.size());
  for (const auto& [o, w] : kf.sharedPoints) out << std::uint64_t(o) << std::int32_t(w);
  out << std::uint64_t(kf.parent) << std::uint64_t(kf.children.size());
  for (KeyFrameId c : kf.children) out << std::uint64_t(c);
}

KeyFrame readKeyFrame(CArchive& in) {
  KeyFrame kf;
  std::uint64_t u = 0;
  in >> u >> kf.timestamp;
  kf.id = u;
  if (kf.id == kNoKeyFrame) throw Error("keyframe with the reserved id " + std::to_string(u));
  const std::string ctx = "keyframe " + std::to_string(kf.id);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> kf.T_cam_world.matrix()(r, c);
  std::int32_t w = 0, h = 0;
  in >> kf.camera.fx >> kf.camera.fy >> kf.camera.cx >> kf.camera.cy >> w >> h;
  if (w <= 0 || h <= 0 || w > kMaxImageSide || h > kMaxImageSide)
    throw Error(ctx + ": image size " + std::to_string(w) + "x" + std::to_string(h) + " outside [1, " +
                std::to_string(kMaxImageSide) + "]");
  kf.camera.width = w;
  kf.camera.height = h;
  kf.camera.check(ctx);
  // Containers grow element by element (reserve is capped): a corrupt count fails at the end of the data
  // instead of allocating gigabytes first.
  const std::uint64_t nKeypoints = readCount(in, "keypoint", kMaxCount, 28);
  kf.keypoints.reserve(cappedReserve(nKeypoints));
  for (std::uint64_t i = 0; i < nKeypoints; ++i) {
    cv::KeyPoint k;
    std::int32_t octave = 0, classId = 0;
    in >> k.pt.x >> k.pt.y >> k.size >> k.angle >> k.response >> octave >> classId;
    // Undistorted keypoints may lie a little outside the image; one image size around it is generous.
    const bool inside = std::isfinite(k.pt.x) && std::isfinite(k.pt.y) && k.pt.x >= -w && k.pt.x <= 2.0 * w &&
                        k.pt.y >= -h && k.pt.y <= 2.0 * h;
    if (!inside)
      throw Error(ctx + ": keypoint " + std::to_string(i) + " at (" + std::to_string(k.pt.x) + ", " +
                  std::to_string(k.pt.y) + ") is far outside the " + std::to_string(w) + "x" + std::to_string(h) +
                  " image");
    if (!std::isfinite(k.size) || k.size < 0.f || !std::isfinite(k.angle) || !std::isfinite(k.response))
      throw Error(ctx + ": keypoint " + std::to_string(i) + " has a NaN/Inf or negative size, angle or response");
    k.octave = octave;
    k.class_id = classId;
    kf.keypoints.push_back(k);
  }
  kf.descriptors = readMat(in, static_cast<std::int64_t>(nKeypoints), ctx);
  kf.scaleFactors = readDoubles(in, "scale factor", kMaxPyramidLevels, ctx);
  kf.levelSigma2 = readDoubles(in, "level sigma2", kMaxPyramidLevels, ctx);
  const std::uint64_t nSemantic = readCount(in, "semantic", nKeypoints, 12);
  kf.semanticProbabilities.reserve(cappedReserve(nSemantic));
  for (std::uint64_t i = 0; i < nSemantic; ++i) {
    std::array<float, 3> s{};
    in >> s[0] >> s[1] >> s[2];
    kf.semanticProbabilities.push_back(s);
  }
  const std::uint64_t nIds = readCount(in, "map point id", nKeypoints, 8);
  kf.mapPointIds.reserve(cappedReserve(nIds));
  for (std::uint64_t i = 0; i < nIds; ++i) {
    in >> u;
    kf.mapPointIds.push_back(u);
  }
  const std::uint64_t nShared = readCount(in, "covisibility", kMaxCount, 12);
  for (std::uint64_t i = 0; i < nShared; ++i) {
    std::int32_t weight = 0;
    in >> u >> weight;
    if (weight <= 0 || u == kf.id || !kf.sharedPoints.emplace(u, weight).second)
      throw Error(ctx + ": invalid covisibility entry " + std::to_string(u) + " (weight " + std::to_string(weight) + ")");
  }
  in >> u;
  kf.parent = u;
  const std::uint64_t nChildren = readCount(in, "children", kMaxCount, 8);
  for (std::uint64_t i = 0; i < nChildren; ++i) {
    in >> u;
    if (u == kf.id || !kf.children.insert(u).second) throw Error(ctx + ": invalid child " + std::to_string(u));
  }
  kf.check(ctx);  // pose, pyramid, octaves, descriptor and semantic sizes, probabilities in [0, 1]
  return kf;
}

void writeMapPoint(CArchive& out, const MapPoint& p) {
  out << std::uint64_t(p.id) << std::uint64_t(p.anchorKeyFrame) << std::uint64_t(p.anchorKeypoint);
  writeVec3(out, p.bearing);
  out << p.inverseDepth << std::uint64_t(p.observations.size());
  for (const auto& [kf, k] : p.observations) out << std::uint64_t(kf) << std::uint64_t(k);
  writeMat(out, p.descriptor);
  writeVec3(out, p.normal);
  out << p.minDistance << p.maxDistance << std::int32_t(p.visibleCount) << std::int32_t(p.foundCount) << p.bad
      << std::uint64_t(p.firstKeyFrame);
  writeDoubles(out, p.landmarkState);
}

MapPoint readMapPoint(CArchive& in) {
  MapPoint p;
  std::uint64_t id = 0, anchor = 0, anchorKp = 0, first = 0;
  in >> id >> anchor >> anchorKp;
  if (id == kNoMapPoint) throw Error("map point with the reserved id " + std::to_string(id));
  const std::string ctx = "map point " + std::to_string(id);
  p.id = id;
  p.anchorKeyFrame = anchor;
  p.anchorKeypoint = anchorKp;
  p.bearing = readVec3(in);
  in >> p.inverseDepth;
  const std::uint64_t nObs = readCount(in, "observation", kMaxCount, 16);
  for (std::uint64_t i = 0; i < nObs; ++i) {
    std::uint64_t kf = 0, k = 0;
    in >> kf >> k;
    if (!p.observations.emplace(kf, k).second) throw Error(ctx + ": keyframe " + std::to_string(kf) + " observes it twice");
  }
  p.descriptor = readMat(in, 1, ctx);
  p.normal = readVec3(in);
  std::int32_t visible = 0, found = 0;
  in >> p.minDistance >> p.maxDistance >> visible >> found;
  p.bad = readFlag(in, ctx, "bad");
  in >> first;
  p.landmarkState = readDoubles(in, "landmark state", kMaxLandmarkState, ctx);
  if (!p.normal.allFinite()) throw Error(ctx + ": normal is NaN or Inf");
  if (!std::isfinite(p.minDistance) || !std::isfinite(p.maxDistance) || p.minDistance < 0.0 ||
      p.maxDistance < p.minDistance)
    throw Error(ctx + ": invalid distance range [" + std::to_string(p.minDistance) + ", " +
                std::to_string(p.maxDistance) + "]");
  if (visible < 0 || found < 0)
    throw Error(ctx + ": negative visible / found counts (" + std::to_string(visible) + ", " + std::to_string(found) + ")");
  p.visibleCount = visible;
  p.foundCount = found;
  p.firstKeyFrame = first;
  return p;
}

}  // namespace

uint8_t CSlamMapArchive::serializeGetVersion() const { return kFormatVersion; }

void CSlamMapArchive::serializeTo(mrpt::serialization::CArchive& out) const {
  Map& m = const_cast<Map&>(map);
  out << std::uint64_t(MapSerializationAccess::nextKf(m)) << std::uint64_t(MapSerializationAccess::nextPt(m));
  out << std::uint64_t(map.keyFrames().size());
  for (const auto& [id, kf] : map.keyFrames()) writeKeyFrame(out, kf);
  out << std::uint64_t(map.mapPoints().size());
  for (const auto& [id, p] : map.mapPoints()) writeMapPoint(out, p);
  out << map.vocabulary();
  out << std::uint64_t(map.extensions().size());
  for (const auto& [name, bytes] : map.extensions()) out << name << bytes;
  out << kEndSentinel;
}

void CSlamMapArchive::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  // MRPT wraps exceptions thrown here into its own generic message; keep ours for loadMap().
  readRecordingFailure(readFailure, "map", [&] { readContent(in, version); });
}

void CSlamMapArchive::readContent(mrpt::serialization::CArchive& in, uint8_t version) {
  if (version > kFormatVersion)
    throw Error("unsupported .slammap format version " + std::to_string(version) + " (this build reads versions 0 to " +
                std::to_string(kFormatVersion) + ")");
  readVersion = version;
  Map m;
  std::uint64_t nextKf = 0, nextPt = 0;
  in >> nextKf >> nextPt;
  if (nextKf > kMaxNextId || nextPt > kMaxNextId)
    throw Error("next " + std::string(nextKf > kMaxNextId ? "keyframe" : "map point") + " id " +
                std::to_string(std::max(nextKf, nextPt)) + " is implausible (ids are given one by one; at most 2^48)");
  MapSerializationAccess::nextKf(m) = nextKf;
  MapSerializationAccess::nextPt(m) = nextPt;
  const std::uint64_t nKf = readCount(in, "keyframe", kMaxCount, 200);
  for (std::uint64_t i = 0; i < nKf; ++i) {
    KeyFrame kf = readKeyFrame(in);
    const KeyFrameId id = kf.id;
    if (id >= nextKf)
      throw Error("keyframe id " + std::to_string(id) + " is not below the next keyframe id " + std::to_string(nextKf));
    if (!MapSerializationAccess::keyframes(m).emplace(id, std::move(kf)).second)
      throw Error("duplicate keyframe id " + std::to_string(id));
  }
  const std::uint64_t nPt = readCount(in, "map point", kMaxCount, 100);
  for (std::uint64_t i = 0; i < nPt; ++i) {
    MapPoint p = readMapPoint(in);
    const MapPointId id = p.id;
    if (id >= nextPt)
      throw Error("map point id " + std::to_string(id) + " is not below the next map point id " + std::to_string(nextPt));
    if (p.firstKeyFrame != kNoKeyFrame && p.firstKeyFrame >= nextKf)
      throw Error("map point " + std::to_string(id) + ": first keyframe " + std::to_string(p.firstKeyFrame) +
                  " is not below the next keyframe id " + std::to_string(nextKf));
    if (!MapSerializationAccess::points(m).emplace(id, std::move(p)).second)
      throw Error("duplicate map point id " + std::to_string(id));
  }
  if (version >= 1) {
    m.setVocabulary(readString(in, "vocabulary fingerprint", 4096));
  }
  if (version >= 2) {
    const std::uint64_t nExtensions = readCount(in, "extension", kMaxExtensions);
    for (std::uint64_t i = 0; i < nExtensions; ++i) {
      const std::string name = readString(in, "extension name", 64);
      if (name.empty()) throw Error("extension name of 0 bytes");
      std::string bytes = readString(in, "extension", std::numeric_limits<std::uint32_t>::max());
      if (m.extension(name)) throw Error("duplicate extension '" + name + "'");
      m.setExtension(name, std::move(bytes));
    }
  }
  std::uint32_t sentinel = 0;
  in >> sentinel;
  if (sentinel != kEndSentinel) throw Error("missing end-of-map marker");
  map = std::move(m);
}

void saveMap(Map map, const std::filesystem::path& path) {
  map.checkInvariants(path.string() + ": refusing to save an inconsistent map");
  AtomicOutput out(path);
  // Compressed at level 1 in blocks on two threads while the map is serialized (GzipOutputStream): saving is the
  // serial end of every run, and deflate was most of its time (doc/performance.md, "the map saved on two threads").
  try {
    GzipOutputStream stream(out.tempPath(), kMapGzipLevel);
    CSlamMapArchive wrapper;
    wrapper.map = std::move(map);  // a temporary (System::saveMap) is moved, not copied
    auto arch = mrpt::serialization::archiveFrom(stream);
    arch << wrapper;
    stream.close();
  } catch (const std::exception& e) {
    throw Error(path.string() + ": writing the map failed (" + oneLineMessage(e) + ")");
  }
  out.commit();
}

Map loadMap(const std::filesystem::path& path, std::uint8_t* formatVersion) {
  // MRPT refuses to read objects of classes missing from its run-time registry.
  static std::once_flag registered;
  std::call_once(registered, [] { mrpt::rtti::registerClass(CLASS_ID(CSlamMapArchive)); });
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path.string() + ": map file not found");
  GzipInputStream stream(path);
  if (!stream.compressed()) throw Error(path.string() + ": not a .slammap file (not gzip-compressed)");
  const ReadBudget budget{&stream, verifyGzipFile(path)};  // before any field is decoded: a corrupt stream's data
                                                          // never reaches the reader
  CSlamMapArchive wrapper;
  struct BudgetScope {
    explicit BudgetScope(const ReadBudget* b) { t_readBudget = b; }
    ~BudgetScope() { t_readBudget = nullptr; }
  } scope(&budget);
  try {
    auto arch = mrpt::serialization::archiveFrom(stream);
    arch.ReadObject(&wrapper);
    stream.requireEnd();  // the CRC-32 and length of the gzip trailer are checked here at the latest
  } catch (const std::exception& e) {
    throwArchiveReadError(path, e, stream, wrapper.readFailure, ".slammap file");
  }
  try {
    wrapper.map.checkInvariants("inconsistent content");
  } catch (const Error& e) {
    throw Error(path.string() + ": " + e.what());
  }
  if (formatVersion) *formatVersion = wrapper.readVersion;
  return std::move(wrapper.map);
}

}  // namespace pslam::map
