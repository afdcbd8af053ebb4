// The direct points as bytes, carried by map.slammap as the map extension "direct_points" (format 2 of the map
// file). Little-endian fixed-size fields:
//   "PSDP" u8 version(1) | u64 hosts, each:
//     u64 keyframe id | f64 affine a, b | u64 points, each:
//       f64 pixel x, y | f64 bearing x, y, z | f64 inverse depth | u8 fixed
//       | u64 levels, each: u64 n (0 or the pattern size) | n f64 host intensities
//       | keypoint model: f64 mu, sigma2, aObs, bObs | 3 f64 semantic NLL | u32 depth updates | u32 semantic updates
//       | u32 visible | u32 found | u32 updates
// Culled points are not written. The host images are not either: a loaded point tracks with the host intensities
// it carries (the photometric error, eq. 3.6) but is never measured again (the optical flow from its host needs the
// host image); only points hosted by keyframes made after the load are. restore() checks every count, value and
// cross-reference before it replaces the store.
#include <cmath>

#include "pslam/core/ByteCodec.h"
#include "pslam/direct/DirectFrontEnd.h"

namespace pslam::direct {

namespace {

constexpr char kMagic[4] = {'P', 'S', 'D', 'P'};
constexpr std::uint8_t kVersion = 1;
constexpr std::uint64_t kMaxHosts = 1'000'000;
constexpr std::uint64_t kMaxPointsPerHost = 1'000'000;
constexpr std::uint64_t kMaxLevels = 16;

}  // namespace

std::string DirectFrontEnd::serialize() const {
  ByteWriter w;
  w.putHeader(kMagic, kVersion);
  w.put<std::uint64_t>(hosts_.size());
  for (const auto& [id, host] : hosts_) {
    w.put<std::uint64_t>(id);
    w.put(host.affine.a);
    w.put(host.affine.b);
    std::uint64_t kept = 0;
    for (const DirectMapPoint& p : host.points) kept += p.bad ? 0 : 1;
    w.put<std::uint64_t>(kept);
    for (const DirectMapPoint& p : host.points) {
      if (p.bad) continue;
      const optimize::DirectLandmark& l = *p.landmark;
      w.put(l.pixel.x());
      w.put(l.pixel.y());
      for (int k = 0; k < 3; ++k) w.put(l.bearing[k]);
      w.put(l.inverseDepth);
      w.putFlag(l.fixed);
      w.put<std::uint64_t>(l.hostIntensities.size());
      for (const std::vector<double>& level : l.hostIntensities) {
        w.put<std::uint64_t>(level.size());
        for (double v : level) w.put(v);
      }
      const landmarks::KeypointState& s = p.state;
      for (double v : {s.mu, s.sigma2, s.aObs, s.bObs}) w.put(v);
      for (double v : s.semanticNll) w.put(v);
      w.put<std::uint32_t>(s.depthUpdates);
      w.put<std::uint32_t>(s.semanticUpdates);
      w.put<std::uint32_t>(p.visible);
      w.put<std::uint32_t>(p.found);
      w.put<std::uint32_t>(p.updates);
    }
  }
  return w.take();
}

void DirectFrontEnd::restore(const std::string& bytes, const map::Map& map) { restore(parse(bytes, map)); }

void DirectFrontEnd::restore(std::map<map::KeyFrameId, DirectHost> hosts) {
  reset();
  hosts_ = std::move(hosts);
}

std::map<map::KeyFrameId, DirectHost> DirectFrontEnd::parse(const std::string& bytes, const map::Map& map) {
  ByteReader r(bytes, "direct points");
  r.header(kMagic, kVersion, "direct point store");
  std::map<map::KeyFrameId, DirectHost> hosts;
  const std::uint64_t nHosts = r.count("host", kMaxHosts);
  for (std::uint64_t h = 0; h < nHosts; ++h) {
    const auto id = r.get<std::uint64_t>("host keyframe");
    const std::string ctx = "host keyframe " + std::to_string(id);
    if (!map.hasKeyFrame(id)) r.fail(ctx + " is not in the map");
    const geometry::PinholeCamera& camera = map.keyFrame(id).camera;
    DirectHost host;
    host.affine.a = r.finite("affine a");
    host.affine.b = r.finite("affine b");
    // The front end clamps a frame's log-gain to [-1, 1] (DirectFrontEnd::poseFactors); outside it exp(-a) in the
    // photometric error would turn a corrupt value into NaN residuals instead of an error here.
    if (std::abs(host.affine.a) > 1.0) r.fail(ctx + ": affine a outside [-1, 1]");
    const std::uint64_t nPoints = r.count("point", kMaxPointsPerHost);  // no reserve: the count is not trusted yet
    for (std::uint64_t i = 0; i < nPoints; ++i) {
      auto l = std::make_shared<optimize::DirectLandmark>();
      l->host = id;
      l->pixel.x() = r.finite("pixel");
      l->pixel.y() = r.finite("pixel");
      for (int k = 0; k < 3; ++k) l->bearing[k] = r.finite("bearing");
      l->inverseDepth = r.finite("inverse depth");
      l->fixed = r.flag("fixed");
      const std::string pointCtx = ctx + ", point " + std::to_string(i);
      if (l->pixel.x() < 0 || l->pixel.y() < 0 || l->pixel.x() > camera.width - 1 || l->pixel.y() > camera.height - 1)
        r.fail(pointCtx + ": pixel outside the keyframe's image");
      if (std::abs(l->bearing.norm() - 1.0) > 1e-9) r.fail(pointCtx + ": bearing is not a unit vector");
      if ((camera.unprojectToBearing(l->pixel) - l->bearing).norm() > 1e-9)
        r.fail(pointCtx + ": bearing does not go through its pixel");
      if (!(l->inverseDepth > 0.0)) r.fail(pointCtx + ": inverse depth <= 0");
      const std::uint64_t levels = r.count("levels", kMaxLevels);
      if (levels == 0) r.fail(pointCtx + ": no pyramid level");
      l->hostIntensities.resize(levels);
      for (std::vector<double>& level : l->hostIntensities) {
        const std::uint64_t n = r.get<std::uint64_t>("level intensities");
        if (n != 0 && n != static_cast<std::uint64_t>(optimize::kPatternSize))
          r.fail(pointCtx + ": " + std::to_string(n) + " intensities on a level (the pattern has " +
                 std::to_string(optimize::kPatternSize) + ")");
        level.resize(n);
        for (double& v : level) {
          v = r.finite("intensity");
          if (v < 0.0 || v > 1.0) r.fail(pointCtx + ": intensity outside [0, 1]");
        }
      }
      if (!l->usableAt(0)) r.fail(pointCtx + ": no intensities on level 0");
      DirectMapPoint p;
      p.landmark = std::move(l);
      landmarks::KeypointState& s = p.state;
      s.mu = r.finite("mu");
      s.sigma2 = r.finite("sigma2");
      s.aObs = r.finite("aObs");
      s.bObs = r.finite("bObs");
      for (double& v : s.semanticNll) v = r.finite("semantic NLL");
      s.depthUpdates = r.get<std::uint32_t>("depth updates");
      s.semanticUpdates = r.get<std::uint32_t>("semantic updates");
      if (!(s.sigma2 > 0.0) || !(s.aObs > 0.0) || !(s.bObs > 0.0))
        r.fail(pointCtx + ": keypoint model with sigma2, aObs or bObs <= 0");
      p.visible = r.get<std::uint32_t>("visible");
      p.found = r.get<std::uint32_t>("found");
      p.updates = r.get<std::uint32_t>("updates");
      if (p.found > p.visible) r.fail(pointCtx + ": found more often than visible");
      host.points.push_back(std::move(p));
    }
    if (!hosts.emplace(id, std::move(host)).second) r.fail(ctx + " twice");
  }
  if (!r.atEnd()) r.fail("unexpected bytes after the last host");
  return hosts;
}

}  // namespace pslam::direct
