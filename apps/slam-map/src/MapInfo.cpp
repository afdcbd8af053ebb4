// slam-map info: counts, camera, format, point-model statistics, the stores of the map extensions (doc/maps.md).
#include "pslam/apps/SlamMapApp.h"

#include "MapAppSupport.h"

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
    const geometry::PinholeCamera& c = map.keyFrames().begin()->second.camera;
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

}  // namespace pslam::apps
