// slam-map export: the map as a PLY point cloud with keyframe centres and a PNG top view (doc/maps.md).
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
