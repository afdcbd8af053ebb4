#include "pslam/apps/SlamMapApp.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/Plot.h"
#include "pslam/eval/TrajectoryIO.h"
#include "pslam/landmarks/KeypointModel.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/lines/LineFrontEnd.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/map/MapIO.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/optimize/MapAdapter.h"

namespace fs = std::filesystem;

namespace pslam::apps {

namespace {

std::string fmt(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// Good (not bad) points, in id order.
template <class F>
void forGoodPoints(const map::Map& map, F&& f) {
  for (const auto& [id, p] : map.mapPoints())
    if (!p.bad) f(id, p);
}

/// Keyframes in timestamp order: the order of the keyframe trajectory.
std::vector<const map::KeyFrame*> keyFramesByTime(const map::Map& map) {
  std::vector<const map::KeyFrame*> kfs;
  for (const auto& [id, kf] : map.keyFrames()) kfs.push_back(&kf);
  std::stable_sort(kfs.begin(), kfs.end(),
                   [](const map::KeyFrame* a, const map::KeyFrame* b) { return a->timestamp < b->timestamp; });
  return kfs;
}

}  // namespace

ValueStats ValueStats::of(std::vector<double> v) {
  ValueStats s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  const std::size_t n = v.size();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return s;
}

nlohmann::json ValueStats::toJson() const {
  return {{"count", count}, {"mean", mean}, {"median", median}, {"min", min}, {"max", max}};
}

std::vector<std::pair<map::MapPointId, double>> inlierRatios(const map::Map& map) {
  const landmarks::KeypointModel model{landmarks::KeypointModelParams{}};
  std::vector<std::pair<map::MapPointId, double>> out;
  forGoodPoints(map, [&](map::MapPointId id, const map::MapPoint& p) {
    if (p.landmarkState.empty()) return;
    try {
      out.emplace_back(id, model.inlierRatio(mapping::decodeKeypointState(p.landmarkState, "map point")));
    } catch (const Error&) {
      // counted by mapInfo() as an invalid state; not drawn
    }
  });
  return out;
}

nlohmann::json LevelResiduals::toJson() const {
  return {{"level", level}, {"count", count}, {"mean_x_px", meanX}, {"mean_y_px", meanY},
          {"mean_radial_px", meanRadial}, {"rms_px", rms}, {"median_px", median}, {"p90_px", p90}};
}

nlohmann::json MapResiduals::toJson() const {
  nlohmann::json levelsJson = nlohmann::json::array();
  for (const LevelResiduals& l : levels) levelsJson.push_back(l.toJson());
  return {{"map", file.string()}, {"levels", levelsJson}, {"all", all.toJson()}, {"behind_camera", behindCamera}};
}

std::string MapResiduals::toText() const {
  std::ostringstream os;
  os << "map: " << file.string() << "\n";
  os << "reprojection residuals (keypoint - projection, px) per pyramid level:\n";
  os << "level  observations   mean x   mean y   mean radial   rms    median  p90\n";
  auto row = [&](const LevelResiduals& l) {
    char buf[128];
    std::snprintf(buf, sizeof(buf), "%-5s  %12zu  %+7.3f  %+7.3f  %+12.3f  %5.3f  %6.3f  %5.3f\n",
                  l.level < 0 ? "all" : std::to_string(l.level).c_str(), l.count, l.meanX, l.meanY, l.meanRadial,
                  l.rms, l.median, l.p90);
    os << buf;
  };
  for (const LevelResiduals& l : levels) row(l);
  row(all);
  if (behindCamera > 0) os << behindCamera << " observations of points behind their keyframe left out\n";
  return os.str();
}

MapResiduals mapResiduals(const map::Map& map) {
  struct Sums {
    std::size_t n = 0;
    double x = 0, y = 0, radial = 0, squared = 0;
    std::vector<double> norms;
  };
  std::map<int, Sums> byLevel;
  Sums total;
  MapResiduals out;
  forGoodPoints(map, [&](map::MapPointId id, const map::MapPoint& p) {
    const Eigen::Vector3d X = map.worldPosition(id);
    for (const auto& [kfId, k] : p.observations) {
      const map::KeyFrame& kf = map.keyFrame(kfId);
      const Eigen::Vector3d pc = kf.T_cam_world * X;
      if (!(pc.z() > 0.0)) {
        ++out.behindCamera;
        continue;
      }
      const cv::KeyPoint& kp = kf.keypoints.at(k);
      const Eigen::Vector2d d = Eigen::Vector2d(kp.pt.x, kp.pt.y) - kf.camera.project(pc);
      const Eigen::Vector2d fromCentre(kp.pt.x - kf.camera.cx, kp.pt.y - kf.camera.cy);
      const double radial = fromCentre.norm() > 1e-9 ? d.dot(fromCentre.normalized()) : 0.0;
      for (Sums* s : {&byLevel[kp.octave], &total}) {
        ++s->n;
        s->x += d.x();
        s->y += d.y();
        s->radial += radial;
        s->squared += d.squaredNorm();
        s->norms.push_back(d.norm());
      }
    }
  });
  auto finish = [](int level, Sums& s) {
    LevelResiduals l;
    l.level = level;
    l.count = s.n;
    if (s.n == 0) return l;
    const double n = static_cast<double>(s.n);
    l.meanX = s.x / n;
    l.meanY = s.y / n;
    l.meanRadial = s.radial / n;
    l.rms = std::sqrt(s.squared / n);
    const auto quantile = [&](double q) {
      auto k = s.norms.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(s.norms.size() - 1));
      std::nth_element(s.norms.begin(), k, s.norms.end());
      return *k;
    };
    l.median = quantile(0.5);
    l.p90 = quantile(0.9);
    return l;
  };
  for (auto& [level, s] : byLevel) out.levels.push_back(finish(level, s));
  out.all = finish(-1, total);
  return out;
}

MapResiduals mapResiduals(const fs::path& file) {
  MapResiduals r = mapResiduals(map::loadMap(file));
  r.file = file;
  return r;
}

MapInfo mapInfo(const fs::path& file) {
  std::uint8_t version = map::CSlamMapArchive::kFormatVersion;
  const map::Map m = map::loadMap(file, &version);
  MapInfo info = mapInfo(m, file);
  info.formatVersion = version;  // the file's, which may be older than the one this build writes
  return info;
}

MapInfo mapInfo(const map::Map& map, const fs::path& file) {
  MapInfo info;
  info.file = file;
  std::error_code ec;
  if (!file.empty() && fs::is_regular_file(file, ec)) info.fileBytes = fs::file_size(file, ec);
  info.formatVersion = map::CSlamMapArchive::kFormatVersion;
  info.vocabulary = map.vocabulary();
  for (const auto& [name, bytes] : map.extensions()) info.extensions[name] = bytes.size();
  if (const std::string* store = map.extension(lines::LineFrontEnd::kMapExtension); store && !map.keyFrames().empty()) {
    const map::CameraIntrinsics& c = map.keyFrames().begin()->second.camera;
    lines::LineFrontEnd front(lines::LinesParams{}, geometry::PinholeCamera(c.fx, c.fy, c.cx, c.cy, c.width, c.height));
    try {
      front.restore(*store, map);
      info.lines = front.numLines();
      info.lineKeyFrames = front.keyFrames().size();
    } catch (const Error& e) {
      info.linesError = e.what();
    }
  }
  if (const std::string* store = map.extension(direct::DirectFrontEnd::kMapExtension)) {
    try {
      for (const auto& [id, host] : direct::DirectFrontEnd::parse(*store, map)) {
        ++info.directHosts;
        info.directPoints += host.points.size();
      }
    } catch (const Error& e) {
      info.directError = e.what();
    }
  }
  if (const std::string* edges = map.extension(loopclosing::LoopCloser::kMapExtension)) {
    try {
      info.loopEdges = loopclosing::LoopCloser::parseLoopEdges(*edges, map).size();
    } catch (const Error& e) {
      info.loopEdgesError = e.what();
    }
  }
  info.keyFrames = map.numKeyFrames();
  info.mapPoints = map.numMapPoints();
  if (!map.keyFrames().empty()) info.camera = map.keyFrames().begin()->second.camera;

  const auto kfs = keyFramesByTime(map);
  if (!kfs.empty()) {
    info.firstStamp = kfs.front()->timestamp;
    info.lastStamp = kfs.back()->timestamp;
  }
  for (std::size_t i = 1; i < kfs.size(); ++i)
    info.keyFramePathLength +=
        (kfs[i]->T_world_cam().translation() - kfs[i - 1]->T_world_cam().translation()).norm();

  const landmarks::KeypointModelParams modelParams;
  const landmarks::KeypointModel model(modelParams);
  info.psiMin = modelParams.psiMin;
  std::vector<double> obs, phi, updates;
  bool first = true;
  forGoodPoints(map, [&](map::MapPointId id, const map::MapPoint& p) {
    obs.push_back(static_cast<double>(p.numObservations()));
    info.observations += p.numObservations();
    const Eigen::Vector3d x = map.worldPosition(id);
    info.pointMin = first ? x : info.pointMin.cwiseMin(x);
    info.pointMax = first ? x : info.pointMax.cwiseMax(x);
    first = false;
    if (p.landmarkState.empty()) return;
    try {
      const landmarks::KeypointState st = mapping::decodeKeypointState(p.landmarkState, "map point");
      ++info.pointsWithModel;
      const double r = model.inlierRatio(st);
      phi.push_back(r);
      if (model.isActive(st)) ++info.activePoints;
      updates.push_back(static_cast<double>(st.depthUpdates));
    } catch (const Error&) {
      ++info.invalidModelStates;
    }
  });
  for (const auto& [id, p] : map.mapPoints())
    if (p.bad) ++info.badPoints;
  info.observationsPerPoint = ValueStats::of(obs);
  info.inlierRatio = ValueStats::of(phi);
  info.depthUpdates = ValueStats::of(updates);
  return info;
}

namespace {
constexpr const char* kNoLines = "none stored (a run without [Lines] enabled)";
constexpr const char* kNoDirect = "none stored (a run without [DirectFeatures] enabled)";

/// What `info` says of one map extension: absent, stored but unusable (why), or what it holds.
std::string storedText(bool stored, const char* absent, const std::string& error, const std::string& holds) {
  if (!stored) return absent;
  return error.empty() ? holds : "stored but unusable: " + error;
}
nlohmann::json storedJson(bool stored, const char* absent, const std::string& error, nlohmann::json holds) {
  if (!stored) return absent;
  return error.empty() ? std::move(holds) : nlohmann::json{{"error", error}};
}
}  // namespace

nlohmann::json MapInfo::toJson() const {
  nlohmann::json j;
  j["file"] = file.string();
  j["file_bytes"] = fileBytes;
  j["format_version"] = formatVersion;
  j["camera"] = {{"fx", camera.fx}, {"fy", camera.fy}, {"cx", camera.cx}, {"cy", camera.cy},
                 {"width", camera.width}, {"height", camera.height}};
  j["vocabulary"] = vocabulary;
  nlohmann::json ext = nlohmann::json::object();
  for (const auto& [name, bytes] : extensions) ext[name] = bytes;
  j["extensions"] = ext;
  j["lines"] = storedJson(extensions.count(lines::LineFrontEnd::kMapExtension) > 0, kNoLines, linesError,
                          {{"lines", lines}, {"keyframes", lineKeyFrames}});
  j["direct_points"] = storedJson(extensions.count(direct::DirectFrontEnd::kMapExtension) > 0, kNoDirect, directError,
                                  {{"points", directPoints}, {"hosts", directHosts}});
  j["loop_edges"] = loopEdges;
  if (!loopEdgesError.empty()) j["loop_edges_error"] = loopEdgesError;
  j["keyframes"] = keyFrames;
  j["map_points"] = mapPoints;
  j["bad_points"] = badPoints;
  j["observations"] = observations;
  j["observations_per_point"] = observationsPerPoint.toJson();
  j["keyframe_timestamps"] = {firstStamp, lastStamp};
  j["keyframe_path_length"] = keyFramePathLength;
  j["point_extent"] = {{"min", vec(pointMin)}, {"max", vec(pointMax)}};
  nlohmann::json m;
  m["points_with_model"] = pointsWithModel;
  m["invalid_states"] = invalidModelStates;
  if (pointsWithModel > 0) {
    m["inlier_ratio"] = inlierRatio.toJson();
    m["active_points"] = activePoints;
    m["psi_min"] = psiMin;
    m["depth_updates"] = depthUpdates.toJson();
    m["parameters"] = "default keypoint-model parameters (the map does not store the run's [PointModel])";
  }
  j["point_model"] = m;
  return j;
}

std::string MapInfo::toText() const {
  std::ostringstream os;
  os << "map:          " << file.string() << " (" << fileBytes << " bytes, format version " << formatVersion << ")\n";
  os << "camera:       fx " << camera.fx << ", fy " << camera.fy << ", cx " << camera.cx << ", cy " << camera.cy
     << ", " << camera.width << "x" << camera.height << "\n";
  os << "vocabulary:   " << (vocabulary.empty() ? std::string("none recorded (built without one)") : vocabulary)
     << "\n";
  os << "lines:        "
     << storedText(extensions.count(lines::LineFrontEnd::kMapExtension) > 0, kNoLines, linesError,
                   std::to_string(lines) + " (segments of " + std::to_string(lineKeyFrames) + " keyframes)")
     << "\n";
  os << "direct:       "
     << storedText(extensions.count(direct::DirectFrontEnd::kMapExtension) > 0, kNoDirect, directError,
                   std::to_string(directPoints) + " points (hosted by " + std::to_string(directHosts) + " keyframes)")
     << "\n";
  os << "loop edges:   " << storedText(true, "", loopEdgesError, std::to_string(loopEdges)) << "\n";
  os << "keyframes:    " << keyFrames;
  if (keyFrames > 0)
    os << " (timestamps " << fmt(firstStamp, 6) << " .. " << fmt(lastStamp, 6) << ", path " << fmt(keyFramePathLength)
       << " map units)";
  os << "\n";
  os << "map points:   " << mapPoints << " (" << badPoints << " bad), " << observations << " observations";
  if (observationsPerPoint.count > 0)
    os << " (per point mean " << fmt(observationsPerPoint.mean, 2) << ", median " << fmt(observationsPerPoint.median, 1)
       << ", max " << fmt(observationsPerPoint.max, 0) << ")";
  os << "\n";
  if (observationsPerPoint.count > 0)
    os << "point extent: x [" << fmt(pointMin.x()) << ", " << fmt(pointMax.x()) << "], y [" << fmt(pointMin.y()) << ", "
       << fmt(pointMax.y()) << "], z [" << fmt(pointMin.z()) << ", " << fmt(pointMax.z()) << "]\n";
  if (pointsWithModel == 0) {
    os << "point model:  none (no point carries a probabilistic state)";
    if (invalidModelStates > 0) os << "; " << invalidModelStates << " invalid states";
    os << "\n";
  } else {
    os << "point model:  " << pointsWithModel << " points with a state";
    if (invalidModelStates > 0) os << " (+" << invalidModelStates << " invalid)";
    os << "; inlier ratio phi mean " << fmt(inlierRatio.mean) << ", median " << fmt(inlierRatio.median) << ", min "
       << fmt(inlierRatio.min) << ", max " << fmt(inlierRatio.max) << "; active (phi >= " << psiMin << ") "
       << activePoints << "; depth updates per point mean " << fmt(depthUpdates.mean, 2) << "\n";
  }
  return os.str();
}

// ------------------------------------------------------------------------------------------------ export

Eigen::Vector3d mapUpDirection(const map::Map& map) {
  require(map.numKeyFrames() > 0, "map", "no keyframe: no top view");
  Eigen::Vector3d down = Eigen::Vector3d::Zero();
  for (const auto& [id, kf] : map.keyFrames()) down += kf.T_world_cam().linear().col(1);
  down /= static_cast<double>(map.numKeyFrames());
  // The cameras agree on "down" (a mean of unit vectors longer than 0.5: within about 60 degrees).
  if (down.norm() > 0.5) return -down.normalized();
  // Else the normal of the plane of the keyframe centres, oriented against the mean camera y axis.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [id, kf] : map.keyFrames()) mean += kf.T_world_cam().translation();
  mean /= static_cast<double>(map.numKeyFrames());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& [id, kf] : map.keyFrames()) {
    const Eigen::Vector3d d = kf.T_world_cam().translation() - mean;
    cov += d * d.transpose();
  }
  if (map.numKeyFrames() < 3) return -map.keyFrames().begin()->second.T_world_cam().linear().col(1);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Eigen::Vector3d n = es.eigenvectors().col(0);  // smallest eigenvalue
  if (n.dot(down) > 0) n = -n;
  return n.normalized();
}

std::string MapExportSummary::toText() const {
  std::ostringstream os;
  os << points << " points, " << keyFrames << " keyframes";
  if (pointsOutsideView > 0) os << "; " << pointsOutsideView << " far points outside the top view";
  os << (colouredByInlierRatio ? "; points coloured by inlier ratio" : "") << "; up = (" << fmt(up.x()) << ", "
     << fmt(up.y()) << ", " << fmt(up.z()) << ")";
  return os.str();
}

namespace {

void writePly(std::ostream& os, const map::Map& map, const fs::path& source,
              const std::vector<std::pair<map::MapPointId, double>>& phi) {
  std::map<map::MapPointId, double> phiOf(phi.begin(), phi.end());
  std::size_t nPoints = 0;
  forGoodPoints(map, [&](map::MapPointId, const map::MapPoint&) { ++nPoints; });
  const auto kfs = keyFramesByTime(map);
  os << "ply\nformat ascii 1.0\n";
  os << "comment slam-map export of " << source.filename().string() << ": " << nPoints << " map points, then "
     << kfs.size() << " keyframe centres (red, timestamp order); map frame, map units\n";
  if (!phi.empty()) os << "comment points coloured by inlier ratio phi (blue 0 .. red 1); grey = no model state\n";
  os << "element vertex " << nPoints + kfs.size() << "\n";
  os << "property double x\nproperty double y\nproperty double z\n";
  os << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  os << "end_header\n";
  os << std::setprecision(9);
  forGoodPoints(map, [&](map::MapPointId id, const map::MapPoint&) {
    const Eigen::Vector3d x = map.worldPosition(id);
    int r = 160, g = 160, b = 160;
    if (const auto it = phiOf.find(id); it != phiOf.end()) {
      const cv::Scalar c = eval::colormapColor(it->second, 0.0, 1.0);  // BGR
      r = static_cast<int>(c[2]);
      g = static_cast<int>(c[1]);
      b = static_cast<int>(c[0]);
    }
    os << x.x() << ' ' << x.y() << ' ' << x.z() << ' ' << r << ' ' << g << ' ' << b << '\n';
  });
  for (const map::KeyFrame* kf : kfs) {
    const Eigen::Vector3d c = kf->T_world_cam().translation();
    os << c.x() << ' ' << c.y() << ' ' << c.z() << " 255 0 0\n";
  }
}

/// The 2nd and 98th percentiles of `v` (the extent of the bulk of the points, without far outliers).
std::pair<double, double> robustRange(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return v[static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1)))]; };
  return {at(0.02), at(0.98)};
}

}  // namespace

MapExportSummary exportMap(const MapExportOptions& o) {
  require(!o.ply.empty() || !o.png.empty(), "slam-map export", "nothing to export: give --ply and/or --png");
  require(o.pngWidth >= 200 && o.pngHeight >= 200, "slam-map export", "the PNG must be at least 200x200 pixels");
  // Outputs are checked before the map is read (an impossible path fails at once) and committed together.
  OutputSet outputs({o.map});
  AtomicOutput* plyOut = o.ply.empty() ? nullptr : &outputs.add(o.ply);
  AtomicOutput* pngOut = o.png.empty() ? nullptr : &outputs.add(o.png);
  const map::Map map = map::loadMap(o.map);
  require(map.numKeyFrames() > 0, o.map.string(), "map has no keyframe: nothing to export");

  MapExportSummary sum;
  const auto phi = inlierRatios(map);
  sum.colouredByInlierRatio = !phi.empty();
  forGoodPoints(map, [&](map::MapPointId, const map::MapPoint&) { ++sum.points; });
  sum.keyFrames = map.numKeyFrames();
  sum.up = mapUpDirection(map);

  if (plyOut) writeOutputFile(*plyOut, [&](std::ostream& os) { writePly(os, map, o.map, phi); });

  if (pngOut) {
    // A right-handed view basis (e1, e2, up): e1 = the first keyframe's viewing direction in the ground plane.
    const auto kfs = keyFramesByTime(map);
    const Eigen::Vector3d up = sum.up;
    Eigen::Vector3d e1 = kfs.front()->T_world_cam().linear().col(2);
    e1 -= e1.dot(up) * up;
    if (e1.norm() < 1e-6) e1 = up.unitOrthogonal();
    e1.normalize();
    const Eigen::Vector3d e2 = up.cross(e1);
    std::vector<double> kx, ky;
    for (const map::KeyFrame* kf : kfs) {
      const Eigen::Vector3d c = kf->T_world_cam().translation();
      kx.push_back(c.dot(e1));
      ky.push_back(c.dot(e2));
    }
    std::map<map::MapPointId, double> phiOf(phi.begin(), phi.end());
    std::vector<double> px, py, pv, gx, gy;
    std::vector<bool> hasPhi;
    forGoodPoints(map, [&](map::MapPointId id, const map::MapPoint&) {
      const Eigen::Vector3d x = map.worldPosition(id);
      px.push_back(x.dot(e1));
      py.push_back(x.dot(e2));
      const auto it = phiOf.find(id);
      hasPhi.push_back(it != phiOf.end());
      pv.push_back(it != phiOf.end() ? it->second : 0.0);
    });
    // View: the bulk of the points (2-98 %) and every keyframe, with a margin; far outliers are left out.
    double xlo = *std::min_element(kx.begin(), kx.end()), xhi = *std::max_element(kx.begin(), kx.end());
    double ylo = *std::min_element(ky.begin(), ky.end()), yhi = *std::max_element(ky.begin(), ky.end());
    if (!px.empty()) {
      const auto [ax, bx] = robustRange(px);
      const auto [ay, by] = robustRange(py);
      xlo = std::min(xlo, ax), xhi = std::max(xhi, bx), ylo = std::min(ylo, ay), yhi = std::max(yhi, by);
    }
    const double margin = 0.05 * std::max({xhi - xlo, yhi - ylo, 1e-3});
    xlo -= margin, xhi += margin, ylo -= margin, yhi += margin;
    std::vector<double> cx, cy, cv;
    for (std::size_t i = 0; i < px.size(); ++i) {
      if (px[i] < xlo || px[i] > xhi || py[i] < ylo || py[i] > yhi) {
        ++sum.pointsOutsideView;
        continue;
      }
      if (hasPhi[i]) {
        cx.push_back(px[i]);
        cy.push_back(py[i]);
        cv.push_back(pv[i]);
      } else {
        gx.push_back(px[i]);
        gy.push_back(py[i]);
      }
    }
    eval::Plot plot("Top view of " + o.map.filename().string() + ": " + std::to_string(sum.points) + " points, " +
                        std::to_string(sum.keyFrames) + " keyframes",
                    "[map units]", "[map units]");
    plot.style().width = o.pngWidth;
    plot.style().height = o.pngHeight;
    plot.style().equalAspect = true;
    plot.setXRange(xlo, xhi);
    plot.setYRange(ylo, yhi);
    if (!gx.empty()) plot.addScatter(gx, gy, sum.colouredByInlierRatio ? "points without model state" : "map points",
                                     eval::colors::grey(), 1);
    if (!cx.empty()) {
      plot.addColoredScatter(cx, cy, cv, "map points", "inlier ratio phi", 1);
      plot.setColorRange(0.0, 1.0);
    }
    plot.addLine(kx, ky, "keyframe trajectory", eval::colors::red(), 2);
    plot.addScatter({kx.front()}, {ky.front()}, "first keyframe", eval::colors::green(), 5);
    plot.save(pngOut->tempPath());
  }
  outputs.commit();
  return sum;
}

}  // namespace pslam::apps

namespace pslam::apps {

namespace {

/// The keyframe trajectory (timestamp order) and the ground-truth pose of each keyframe.
struct KeyFramePairs {
  Trajectory estimate, groundTruth;
};

KeyFramePairs keyFramePairs(const map::Map& map, const Trajectory& groundTruthSorted, const OptimumOptions& options) {
  KeyFramePairs pairs;
  for (const map::KeyFrame* kf : keyFramesByTime(map)) {
    const StampedPose* gt = nearestPose(groundTruthSorted, kf->timestamp, options.maxTimeDifference);
    require(gt != nullptr, "slam-map optimum",
            "keyframe " + std::to_string(kf->id) + " (stamp " + fmt(kf->timestamp, 6) + " s) has no pose within " +
                fmt(options.maxTimeDifference, 3) + " s in " + options.groundTruth.string());
    pairs.estimate.emplace_back(kf->timestamp, kf->T_world_cam());
    pairs.groundTruth.push_back(*gt);
  }
  return pairs;
}

OptimumStage measureStage(const std::string& name, const map::Map& map, const Trajectory& groundTruthSorted,
                          const OptimumOptions& options) {
  const KeyFramePairs pairs = keyFramePairs(map, groundTruthSorted, options);
  OptimumStage stage;
  stage.name = name;
  const eval::Alignment a = eval::alignTrajectories(pairs.groundTruth, pairs.estimate, eval::AlignmentMode::Sim3);
  stage.ate = eval::computeAte(pairs.groundTruth, eval::applyAlignment(pairs.estimate, a)).stats.rmse;
  if (options.segments > 0)
    stage.scaleSpread = eval::segmentScaleRange(eval::alignSegments(pairs.groundTruth, pairs.estimate,
                                                                    eval::AlignmentMode::Sim3, options.segments))
                            .spread();
  return stage;
}

/// Two stages: `m` as it is, then after a global BA of it (which `m` receives).
void addGlobalBundleAdjustmentStages(map::Map& m, const std::string& before, const std::string& after,
                                     const optimize::BundleAdjustmentParams& ba, const Trajectory& groundTruthSorted,
                                     const OptimumOptions& options, std::vector<OptimumStage>& stages) {
  OptimumStage start = measureStage(before, m, groundTruthSorted, options);
  optimize::BAResult r;
  optimize::globalBundleAdjustment(m, ba, &r);
  start.cost = r.initialCost;
  start.rmsPixels = r.initialRmsPixels;
  OptimumStage end = measureStage(after, m, groundTruthSorted, options);
  end.cost = r.finalCost;
  end.rmsPixels = r.finalRmsPixels;
  end.iterations = r.iterations;
  end.outliers = r.outliers.size();
  stages.push_back(start);
  stages.push_back(end);
}

}  // namespace

void OptimumOptions::check() const {
  require(iterations >= 1, "slam-map optimum",
          "--iterations must be at least 1 (got " + std::to_string(iterations) + ")");
  require(std::isfinite(maxTimeDifference) && maxTimeDifference > 0.0, "slam-map optimum",
          "--max-diff must be a positive number of seconds");
}

nlohmann::json OptimumStage::toJson() const {
  return {{"name", name},   {"keyframe_ate_m", ate}, {"scale_spread", scaleSpread}, {"cost", cost},
          {"rms_px", rmsPixels}, {"iterations", iterations}, {"outliers", outliers}};
}

nlohmann::json MapOptimum::toJson() const {
  nlohmann::json s = nlohmann::json::array();
  for (const OptimumStage& st : stages) s.push_back(st.toJson());
  return {{"map", file.string()},
          {"groundtruth", groundTruth.string()},
          {"keyframes", keyFrames},
          {"observations", observations},
          {"stages", s}};
}

std::string MapOptimum::toText() const {
  std::ostringstream os;
  os << "map: " << file.string() << " (" << keyFrames << " keyframes, " << observations << " observations)\n";
  os << "ground truth: " << groundTruth.string() << "\n";
  os << "state                 keyframe ATE   scale spread   BA cost       RMS px   BA its   outliers\n";
  for (const OptimumStage& st : stages) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "%-20s  %10.4f m   %10.2f %%   %10.1f   %6.3f   %6d   %8zu\n", st.name.c_str(),
                  st.ate, 100.0 * st.scaleSpread, st.cost, st.rmsPixels, st.iterations, st.outliers);
    os << buf;
  }
  return os.str();
}

MapOptimum mapOptimum(const map::Map& savedMap, const Trajectory& groundTruth, const OptimumOptions& options) {
  options.check();
  const std::string ctx = "slam-map optimum";
  require(savedMap.numKeyFrames() >= 3, ctx, "the map has fewer than 3 keyframes");
  require(options.segments == 0 || savedMap.numKeyFrames() >= 3 * options.segments, ctx,
          "--segments " + std::to_string(options.segments) + " needs at least 3 keyframes per stretch; the map has " +
              std::to_string(savedMap.numKeyFrames()));
  Trajectory gt = groundTruth;
  std::stable_sort(gt.begin(), gt.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  MapOptimum out;
  out.keyFrames = savedMap.numKeyFrames();
  optimize::BundleAdjustmentParams ba;
  ba.globalIterations = options.iterations;

  // 1-2. The saved map, and a global BA from it.
  map::Map fromSaved = savedMap;
  addGlobalBundleAdjustmentStages(fromSaved, "saved", "ba_from_saved", ba, gt, options, out.stages);
  forGoodPoints(savedMap, [&](map::MapPointId, const map::MapPoint& p) { out.observations += p.observations.size(); });

  // 3. Every keyframe at its ground-truth pose, brought into the map's frame by the saved map's Sim(3) alignment
  // (p_gt = s R p_map + t), the points' depths refit along their anchor rays with the poses held.
  const KeyFramePairs pairs = keyFramePairs(savedMap, gt, options);
  const eval::Alignment a = eval::alignTrajectories(pairs.groundTruth, pairs.estimate, eval::AlignmentMode::Sim3);
  map::Map atTruth = savedMap;
  for (const map::KeyFrame* kf : keyFramesByTime(savedMap)) {
    const Eigen::Isometry3d T_gt = nearestPose(gt, kf->timestamp, options.maxTimeDifference)->T_world_cam();
    Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
    T_world_cam.linear() = a.rotation.transpose() * T_gt.linear();
    T_world_cam.translation() = a.rotation.transpose() * (T_gt.translation() - a.translation) / a.scale;
    atTruth.setKeyFramePose(kf->id, T_world_cam.inverse());
  }
  {
    optimize::BAProblem depthsOnly = optimize::makeGlobalProblem(atTruth);
    for (auto& [id, kf] : depthsOnly.keyframes) kf.fixed = true;
    optimize::BundleAdjustmentParams refit = ba;
    refit.firstPassIterations = refit.secondPassIterations = options.iterations;
    optimize::applyResult(atTruth, depthsOnly, optimize::localBundleAdjustment(depthsOnly, refit), false);
  }
  // 4. A global BA from there.
  addGlobalBundleAdjustmentStages(atTruth, "groundtruth_poses", "ba_from_groundtruth", ba, gt, options, out.stages);
  return out;
}

MapOptimum mapOptimum(const OptimumOptions& options) {
  options.check();
  const map::Map m = map::loadMap(options.map);
  const Trajectory gt = eval::readTrajectory(options.groundTruth);
  require(!gt.empty(), "slam-map optimum", options.groundTruth.string() + " holds no pose");
  // A static ground truth cannot be aligned to: refused before any bundle adjustment runs (and prints).
  const bool moves = std::any_of(gt.begin(), gt.end(), [&](const StampedPose& p) {
    return (p.position - gt.front().position).norm() > 1e-9 * std::max(1.0, gt.front().position.norm());
  });
  require(gt.size() < 2 || moves, options.groundTruth.string(),
          "all " + std::to_string(gt.size()) + " poses are at one position: a static ground truth cannot be aligned");
  MapOptimum out = mapOptimum(m, gt, options);
  out.file = options.map;
  out.groundTruth = options.groundTruth;
  return out;
}

}  // namespace pslam::apps
