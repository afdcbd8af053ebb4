#include "pslam/map/MapIO.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <mutex>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"

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
constexpr std::uint32_t kEndSentinel = 0x534C4D45;  // "SLME"

std::uint64_t readCount(CArchive& in, const char* what) {
  std::uint64_t n = 0;
  in >> n;
  if (n > kMaxCount) throw Error(std::string("implausible ") + what + " count " + std::to_string(n));
  return n;
}

std::size_t cappedReserve(std::uint64_t n) { return static_cast<std::size_t>(std::min<std::uint64_t>(n, 1u << 16)); }

void writeDoubles(CArchive& out, const std::vector<double>& v) {
  out << std::uint64_t(v.size());
  for (double x : v) out << x;
}

std::vector<double> readDoubles(CArchive& in, const char* what) {
  const std::uint64_t n = readCount(in, what);
  std::vector<double> v;
  v.reserve(cappedReserve(n));
  for (std::uint64_t i = 0; i < n; ++i) {
    double x = 0.0;
    in >> x;
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

cv::Mat readMat(CArchive& in) {
  std::int32_t rows = 0, cols = 0, type = 0;
  in >> rows >> cols >> type;
  if (rows == 0 || cols == 0) return {};
  if (rows < 0 || rows > 10'000'000 || cols != 32 || type != CV_8UC1)
    throw Error("invalid descriptor matrix header");
  cv::Mat m(rows, cols, type);
  const std::size_t bytes = m.total() * m.elemSize();
  if (in.ReadBuffer(m.data, bytes) != bytes) throw Error("truncated descriptor matrix");
  return m;
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
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> kf.T_cam_world.matrix()(r, c);
  std::int32_t w = 0, h = 0;
  in >> kf.camera.fx >> kf.camera.fy >> kf.camera.cx >> kf.camera.cy >> w >> h;
  kf.camera.width = w;
  kf.camera.height = h;
  // Containers grow element by element (reserve is capped): a corrupt count fails at the end of the data
  // instead of allocating gigabytes first.
  const std::uint64_t nKeypoints = readCount(in, "keypoint");
  kf.keypoints.reserve(cappedReserve(nKeypoints));
  for (std::uint64_t i = 0; i < nKeypoints; ++i) {
    cv::KeyPoint k;
    std::int32_t octave = 0, classId = 0;
    in >> k.pt.x >> k.pt.y >> k.size >> k.angle >> k.response >> octave >> classId;
    k.octave = octave;
    k.class_id = classId;
    kf.keypoints.push_back(k);
  }
  kf.descriptors = readMat(in);
  kf.scaleFactors = readDoubles(in, "scale factor");
  kf.levelSigma2 = readDoubles(in, "level sigma2");
  const std::uint64_t nSemantic = readCount(in, "semantic");
  kf.semanticProbabilities.reserve(cappedReserve(nSemantic));
  for (std::uint64_t i = 0; i < nSemantic; ++i) {
    std::array<float, 3> s{};
    in >> s[0] >> s[1] >> s[2];
    kf.semanticProbabilities.push_back(s);
  }
  const std::uint64_t nIds = readCount(in, "map point id");
  kf.mapPointIds.reserve(cappedReserve(nIds));
  for (std::uint64_t i = 0; i < nIds; ++i) {
    in >> u;
    kf.mapPointIds.push_back(u);
  }
  const std::uint64_t nShared = readCount(in, "covisibility");
  for (std::uint64_t i = 0; i < nShared; ++i) {
    std::int32_t weight = 0;
    in >> u >> weight;
    kf.sharedPoints[u] = weight;
  }
  in >> u;
  kf.parent = u;
  const std::uint64_t nChildren = readCount(in, "children");
  for (std::uint64_t i = 0; i < nChildren; ++i) {
    in >> u;
    kf.children.insert(u);
  }
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
  p.id = id;
  p.anchorKeyFrame = anchor;
  p.anchorKeypoint = anchorKp;
  p.bearing = readVec3(in);
  in >> p.inverseDepth;
  const std::uint64_t nObs = readCount(in, "observation");
  for (std::uint64_t i = 0; i < nObs; ++i) {
    std::uint64_t kf = 0, k = 0;
    in >> kf >> k;
    p.observations[kf] = k;
  }
  p.descriptor = readMat(in);
  p.normal = readVec3(in);
  std::int32_t visible = 0, found = 0;
  in >> p.minDistance >> p.maxDistance >> visible >> found >> p.bad >> first;
  p.landmarkState = readDoubles(in, "landmark state");
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
  out << kEndSentinel;
}

void CSlamMapArchive::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  // MRPT wraps exceptions thrown here into its own generic message; keep ours for loadMap().
  readFailure.clear();
  try {
    readContent(in, version);
  } catch (const std::exception& e) {
    readFailure = e.what();
    readFailure = readFailure.substr(0, readFailure.find('\n'));
    throw;
  }
}

void CSlamMapArchive::readContent(mrpt::serialization::CArchive& in, uint8_t version) {
  if (version != kFormatVersion)
    throw Error("unsupported .slammap format version " + std::to_string(version) + " (this build reads version " +
                std::to_string(kFormatVersion) + ")");
  Map m;
  std::uint64_t nextKf = 0, nextPt = 0;
  in >> nextKf >> nextPt;
  MapSerializationAccess::nextKf(m) = nextKf;
  MapSerializationAccess::nextPt(m) = nextPt;
  const std::uint64_t nKf = readCount(in, "keyframe");
  for (std::uint64_t i = 0; i < nKf; ++i) {
    KeyFrame kf = readKeyFrame(in);
    const KeyFrameId id = kf.id;
    if (!MapSerializationAccess::keyframes(m).emplace(id, std::move(kf)).second)
      throw Error("duplicate keyframe id " + std::to_string(id));
  }
  const std::uint64_t nPt = readCount(in, "map point");
  for (std::uint64_t i = 0; i < nPt; ++i) {
    MapPoint p = readMapPoint(in);
    const MapPointId id = p.id;
    if (!MapSerializationAccess::points(m).emplace(id, std::move(p)).second)
      throw Error("duplicate map point id " + std::to_string(id));
  }
  std::uint32_t sentinel = 0;
  in >> sentinel;
  if (sentinel != kEndSentinel) throw Error("missing end-of-map marker");
  map = std::move(m);
}

void saveMap(const Map& map, const std::filesystem::path& path) {
  map.checkInvariants(path.string() + ": refusing to save an inconsistent map");
  AtomicOutput out(path);
  {
    mrpt::io::CFileGZOutputStream stream;
    if (!stream.open(out.tempPath().string(), 6)) throw Error(path.string() + ": cannot open for writing");
    CSlamMapArchive wrapper;
    wrapper.map = map;
    try {
      auto arch = mrpt::serialization::archiveFrom(stream);
      arch << wrapper;
    } catch (const std::exception& e) {
      throw Error(path.string() + ": writing the map failed (" + e.what() + ")");
    }
    stream.close();
  }
  out.commit();
}

Map loadMap(const std::filesystem::path& path) {
  // MRPT refuses to read objects of classes missing from its run-time registry.
  static std::once_flag registered;
  std::call_once(registered, [] { mrpt::rtti::registerClass(CLASS_ID(CSlamMapArchive)); });
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path.string() + ": map file not found");
  mrpt::io::CFileGZInputStream stream;
  if (!stream.open(path.string())) throw Error(path.string() + ": cannot open map file");
  CSlamMapArchive wrapper;
  try {
    auto arch = mrpt::serialization::archiveFrom(stream);
    arch.ReadObject(&wrapper);
  } catch (const std::exception& e) {
    if (!wrapper.readFailure.empty()) throw Error(path.string() + ": " + wrapper.readFailure);
    // MRPT messages are multi-line stack traces; keep the first line.
    std::string msg = e.what();
    const std::size_t m = msg.find("Message:");
    if (m != std::string::npos) msg = msg.substr(m + 8);
    msg = msg.substr(msg.find_first_not_of(' ') == std::string::npos ? 0 : msg.find_first_not_of(' '));
    msg = msg.substr(0, msg.find('\n'));
    throw Error(path.string() + ": not a readable .slammap file (truncated or corrupt: " + msg + ")");
  }
  try {
    for (const auto& [id, kf] : wrapper.map.keyFrames()) kf.check("keyframe " + std::to_string(id));
    wrapper.map.checkInvariants("inconsistent content");
  } catch (const Error& e) {
    throw Error(path.string() + ": " + e.what());
  }
  return std::move(wrapper.map);
}

}  // namespace pslam::map
