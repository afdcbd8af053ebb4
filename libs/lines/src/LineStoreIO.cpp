// The line store as bytes, carried by map.slammap as the map extension "lines" (format 2 of the map file).
// Little-endian fixed-size fields:
//   "PSLN" u8 version(1) | u64 nextId | u64 keyframesAdded
//   u64 keyframes, each: u64 id | f64 pixelSigma | u64 segments | segments x 4 f64 (start x, y, end x, y)
//                        | u64 descriptor bytes per row | segments x that many bytes | segments x i64 line id (-1)
//   u64 lines, each: u64 id | 6 f64 endpoints | u8 fixed | u64 descriptor bytes | bytes | u64 observations,
//                    each u64 keyframe | i32 segment | u64 createdAt | u32 visible | u32 found | u8 bad
// parse() checks every count, value and cross-reference; restore() installs only a store that passed.
#include <set>

#include "pslam/core/ByteCodec.h"
#include "pslam/core/Error.h"
#include "pslam/lines/LineFrontEnd.h"

namespace pslam::lines {

namespace {

constexpr char kMagic[4] = {'P', 'S', 'L', 'N'};
constexpr std::uint8_t kVersion = 1;
constexpr std::uint64_t kMaxItems = 10'000'000;   // guards against absurd counts in a corrupt blob
constexpr std::uint64_t kMaxDescriptorBytes = 256;

}  // namespace

std::string LineFrontEnd::serialize() const {
  ByteWriter w;
  w.putHeader(kMagic, kVersion);
  w.put<std::uint64_t>(nextId_);
  w.put<std::uint64_t>(keyframesAdded_);
  w.put<std::uint64_t>(keyframes_.size());
  for (const auto& [id, k] : keyframes_) {
    w.put<std::uint64_t>(id);
    w.put(k.features.pixelSigma);
    w.put<std::uint64_t>(k.features.segments.size());
    for (const LineSegment& s : k.features.segments) {
      w.put(s.start.x());
      w.put(s.start.y());
      w.put(s.end.x());
      w.put(s.end.y());
    }
    const cv::Mat& d = k.features.descriptors;
    const std::size_t rowBytes = d.empty() ? 0 : static_cast<std::size_t>(d.cols) * d.elemSize();
    w.put<std::uint64_t>(rowBytes);
    for (int r = 0; r < d.rows; ++r) w.putBytes(d.ptr<unsigned char>(r), rowBytes);
    for (long long l : k.lineIds) w.put<std::int64_t>(l);
  }
  w.put<std::uint64_t>(lines_.size());
  for (const auto& [id, l] : lines_) {
    w.put<std::uint64_t>(id);
    for (double e : l.landmark->endpoints) w.put(e);
    w.put<std::uint8_t>(l.landmark->fixed ? 1 : 0);
    const std::size_t n = l.descriptor.empty() ? 0 : l.descriptor.total() * l.descriptor.elemSize();
    w.put<std::uint64_t>(n);
    if (n) w.putBytes(l.descriptor.ptr<unsigned char>(0), n);
    w.put<std::uint64_t>(l.observations.size());
    for (const auto& [kf, seg] : l.observations) {
      w.put<std::uint64_t>(kf);
      w.put<std::int32_t>(seg);
    }
    w.put<std::uint64_t>(l.createdAt);
    w.put<std::uint32_t>(l.visible);
    w.put<std::uint32_t>(l.found);
    w.put<std::uint8_t>(l.bad ? 1 : 0);
  }
  return w.take();
}

void LineFrontEnd::restore(const std::string& bytes, const map::Map& map) {
  reset();  // a refused store leaves the front end empty
  restore(parse(bytes, map));
}

void LineFrontEnd::restore(Store store) {
  reset();
  lines_ = std::move(store.lines);
  keyframes_ = std::move(store.keyframes);
  nextId_ = store.nextId;
  keyframesAdded_ = store.keyframesAdded;
}

LineFrontEnd::Store LineFrontEnd::parse(const std::string& bytes, const map::Map& map) {
  ByteReader r(bytes, "lines");
  r.header(kMagic, kVersion, "line store");
  std::map<std::uint64_t, MapLine> lines;
  std::map<map::KeyFrameId, LineKeyFrame> keyframes;
  const auto nextId = r.get<std::uint64_t>("next id");
  const auto keyframesAdded = r.get<std::uint64_t>("keyframes added");
  const std::uint64_t nKf = r.count("keyframe", kMaxItems);
  for (std::uint64_t i = 0; i < nKf; ++i) {
    const auto id = r.get<std::uint64_t>("keyframe id");
    if (!map.hasKeyFrame(id)) throw Error("lines: keyframe " + std::to_string(id) + " is not in the map");
    LineKeyFrame k;
    k.features.pixelSigma = r.finite("pixel sigma");
    if (!(k.features.pixelSigma > 0)) throw Error("lines: keyframe " + std::to_string(id) + ": pixel sigma <= 0");
    const std::uint64_t nSeg = r.count("segment", kMaxItems);
    for (std::uint64_t s = 0; s < nSeg; ++s) {
      LineSegment seg;
      seg.start.x() = r.finite("segment");
      seg.start.y() = r.finite("segment");
      seg.end.x() = r.finite("segment");
      seg.end.y() = r.finite("segment");
      k.features.segments.push_back(seg);
    }
    const std::uint64_t rowBytes = r.count("descriptor bytes", kMaxDescriptorBytes);
    if (nSeg > 0 && rowBytes == 0)
      throw Error("lines: keyframe " + std::to_string(id) + ": segments without descriptors");
    if (nSeg > 0) {
      k.features.descriptors.create(static_cast<int>(nSeg), static_cast<int>(rowBytes), CV_8U);
      for (std::uint64_t s = 0; s < nSeg; ++s)
        r.bytes(k.features.descriptors.ptr<unsigned char>(static_cast<int>(s)), rowBytes, "descriptor");
    }
    for (std::uint64_t s = 0; s < nSeg; ++s) k.lineIds.push_back(r.get<std::int64_t>("segment line"));
    if (!keyframes.emplace(id, std::move(k)).second) throw Error("lines: keyframe " + std::to_string(id) + " twice");
  }
  const std::uint64_t nLines = r.count("line", kMaxItems);
  for (std::uint64_t i = 0; i < nLines; ++i) {
    const auto id = r.get<std::uint64_t>("line id");
    const std::string ctx = "lines: line " + std::to_string(id);
    if (id >= nextId) throw Error(ctx + " is not below the next line id " + std::to_string(nextId));
    MapLine l;
    l.landmark = std::make_shared<LineLandmark>();
    for (double& e : l.landmark->endpoints) e = r.finite("endpoint");
    l.landmark->fixed = r.flag("fixed");
    const std::uint64_t n = r.count("line descriptor bytes", kMaxDescriptorBytes);
    if (n > 0) {
      l.descriptor.create(1, static_cast<int>(n), CV_8U);
      r.bytes(l.descriptor.ptr<unsigned char>(0), n, "line descriptor");
    }
    const std::uint64_t nObs = r.count("observation", kMaxItems);
    for (std::uint64_t o = 0; o < nObs; ++o) {
      const auto kf = r.get<std::uint64_t>("observation keyframe");
      const auto seg = r.get<std::int32_t>("observation segment");
      const auto k = keyframes.find(kf);
      if (k == keyframes.end()) throw Error(ctx + ": observed by keyframe " + std::to_string(kf) + " without segments");
      if (seg < 0 || static_cast<std::size_t>(seg) >= k->second.lineIds.size() ||
          k->second.lineIds[static_cast<std::size_t>(seg)] != static_cast<long long>(id))
        throw Error(ctx + ": observation by segment " + std::to_string(seg) + " of keyframe " + std::to_string(kf) +
                    " does not match the keyframe's segments");
      if (!l.observations.emplace(kf, seg).second) throw Error(ctx + ": keyframe " + std::to_string(kf) + " twice");
    }
    l.createdAt = r.get<std::uint64_t>("created at");
    l.visible = r.get<std::uint32_t>("visible");
    l.found = r.get<std::uint32_t>("found");
    l.bad = r.flag("bad");
    if (l.found > l.visible) throw Error(ctx + ": found more often than visible");
    if (!lines.emplace(id, std::move(l)).second) throw Error(ctx + " twice");
  }
  if (!r.atEnd()) throw Error("lines: unexpected bytes after the last line");
  // Every segment that names a line is one of that line's observations.
  for (const auto& [kf, k] : keyframes)
    for (std::size_t s = 0; s < k.lineIds.size(); ++s) {
      const long long l = k.lineIds[s];
      if (l == -1) continue;
      const auto it = l < 0 ? lines.end() : lines.find(static_cast<std::uint64_t>(l));
      if (it == lines.end() || !it->second.observations.count(kf) ||
          it->second.observations.at(kf) != static_cast<int>(s))
        throw Error("lines: segment " + std::to_string(s) + " of keyframe " + std::to_string(kf) + " names line " +
                    std::to_string(l) + ", which does not observe it there");
    }
  Store store;
  store.lines = std::move(lines);
  store.keyframes = std::move(keyframes);
  store.nextId = nextId;
  store.keyframesAdded = keyframesAdded;
  return store;
}

}  // namespace pslam::lines
