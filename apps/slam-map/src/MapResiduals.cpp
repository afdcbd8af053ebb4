// slam-map residuals: reprojection residuals of a saved map per pyramid level (doc/maps.md).
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

}  // namespace pslam::apps
