#include "pslam/priors/NormalsFromDepth.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numeric>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::priors {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

/// First and second moments of a point set: enough to fit a least-squares plane (PCA) and to merge sets.
struct Moments {
  double n = 0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();

  void add(const Eigen::Vector3d& p) {
    n += 1;
    s += p;
    ss += p * p.transpose();
  }
  Moments& operator+=(const Moments& o) {
    n += o.n;
    s += o.s;
    ss += o.ss;
    return *this;
  }
};

struct PlaneFit {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, facing the camera
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double d = 0;    ///< plane: normal . p + d = 0
  double rms = 0;  ///< RMS point-to-plane distance (sqrt of the smallest covariance eigenvalue)
  double curvature = 0;
};

PlaneFit fitPlane(const Moments& m) {
  PlaneFit f;
  f.centroid = m.s / m.n;
  const Eigen::Matrix3d cov = m.ss / m.n - f.centroid * f.centroid.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  const Eigen::Vector3d ev = es.eigenvalues().cwiseMax(0.0);  // ascending
  f.normal = es.eigenvectors().col(0).normalized();
  if (f.normal.dot(f.centroid) > 0) f.normal = -f.normal;  // the visible side faces the camera
  f.d = -f.normal.dot(f.centroid);
  f.rms = std::sqrt(ev(0));
  const double trace = ev.sum();
  f.curvature = trace > 0 ? ev(0) / trace : 1.0;
  return f;
}

}  // namespace

PSLAM_DEFINE_PARAMS(DepthNormalParams)

PinholeIntrinsics PinholeIntrinsics::fromCamera(const mrpt::img::TCamera& c) {
  return {c.fx(), c.fy(), c.cx(), c.cy()};
}

DepthNormalEstimator::DepthNormalEstimator(DepthNormalParams params) : params_(params) { params_.check(); }

NormalMap DepthNormalEstimator::computeFromRaw(const cv::Mat& depth, double depthUnits,
                                               const PinholeIntrinsics& K) const {
  require(depth.type() == CV_16UC1, "NormalsFromDepth", "raw depth must be CV_16UC1");
  require(std::isfinite(depthUnits) && depthUnits > 0, "NormalsFromDepth", "depth units must be > 0");
  cv::Mat metres;
  depth.convertTo(metres, CV_32F, depthUnits);
  return compute(metres, K);
}

NormalMap DepthNormalEstimator::compute(const cv::Mat& depthMetres, const PinholeIntrinsics& K) const {
  const std::string ctx = "NormalsFromDepth";
  require(!depthMetres.empty(), ctx, "empty depth image");
  require(depthMetres.type() == CV_32FC1, ctx, "metric depth must be CV_32FC1");
  require(std::isfinite(K.fx) && std::isfinite(K.fy) && K.fx > 0 && K.fy > 0 && std::isfinite(K.cx) &&
              std::isfinite(K.cy),
          ctx, "intrinsics must be finite with positive focal lengths");
  const DepthNormalParams& P = params_;
  const int rows = depthMetres.rows, cols = depthMetres.cols;
  auto sigmaAt = [&](double z) { return P.noiseQuadratic * z * z + P.noiseConstant; };

  // Back-projection; the ten moment images are box-filtered (unnormalized) to get window sums in O(1)/px.
  cv::Mat X(rows, cols, CV_64F, 0.0), Y(rows, cols, CV_64F, 0.0), Z(rows, cols, CV_64F, 0.0);
  cv::Mat valid(rows, cols, CV_64F, 0.0);
  for (int v = 0; v < rows; ++v) {
    const float* d = depthMetres.ptr<float>(v);
    double *X0 = X.ptr<double>(v), *Y0 = Y.ptr<double>(v), *Z0 = Z.ptr<double>(v), *ok = valid.ptr<double>(v);
    for (int u = 0; u < cols; ++u) {
      const double z = d[u];
      if (!std::isfinite(z) || z < P.minDepth || z > P.maxDepth || z <= 0) continue;
      X0[u] = (u - K.cx) / K.fx * z;
      Y0[u] = (v - K.cy) / K.fy * z;
      Z0[u] = z;
      ok[u] = 1.0;
    }
  }
  // Depth discontinuities: a jump between 4-neighbours (or a valid/invalid border) is an edge; the
  // chessboard distance to the nearest edge tells whether the box window reaches across one.
  cv::Mat notEdge(rows, cols, CV_8UC1, cv::Scalar(255));
  for (int v = 0; v < rows; ++v)
    for (int u = 0; u < cols; ++u) {
      const double z = Z.at<double>(v, u);
      if (z == 0.0) continue;
      for (const auto& [du, dv] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (u + du >= cols || v + dv >= rows) continue;
        const double zn = Z.at<double>(v + dv, u + du);
        if (zn != 0.0 && std::abs(zn - z) > P.maxDepthJumpRatio * std::min(z, zn)) {
          notEdge.at<uchar>(v, u) = 0;
          notEdge.at<uchar>(v + dv, u + du) = 0;
        }
      }
    }
  cv::Mat edgeDistance;
  cv::distanceTransform(notEdge, edgeDistance, cv::DIST_C, 3);

  const cv::Size win(2 * P.windowRadius + 1, 2 * P.windowRadius + 1);
  auto boxSum = [&](const cv::Mat& m) {
    cv::Mat out;
    cv::boxFilter(m, out, CV_64F, win, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
    return out;
  };
  const cv::Mat N = boxSum(valid), SX = boxSum(X), SY = boxSum(Y), SZ = boxSum(Z);
  const cv::Mat SXX = boxSum(X.mul(X)), SXY = boxSum(X.mul(Y)), SXZ = boxSum(X.mul(Z));
  const cv::Mat SYY = boxSum(Y.mul(Y)), SYZ = boxSum(Y.mul(Z)), SZZ = boxSum(Z.mul(Z));

  NormalMap out;
  out.normals = cv::Mat(rows, cols, CV_32FC3, cv::Scalar::all(0));
  out.planarMask = cv::Mat(rows, cols, CV_8UC1, cv::Scalar(0));
  out.planeLabels = cv::Mat(rows, cols, CV_32SC1, cv::Scalar(-1));
  const double minWindowCount = P.minWindowValidShare * win.area();
  for (int v = 0; v < rows; ++v) {
    const double *pn = N.ptr<double>(v), *px = SX.ptr<double>(v), *py = SY.ptr<double>(v), *pz = SZ.ptr<double>(v);
    const double *pxx = SXX.ptr<double>(v), *pxy = SXY.ptr<double>(v), *pxz = SXZ.ptr<double>(v);
    const double *pyy = SYY.ptr<double>(v), *pyz = SYZ.ptr<double>(v), *pzz = SZZ.ptr<double>(v);
    const double *ok = valid.ptr<double>(v), *X0 = X.ptr<double>(v), *Y0 = Y.ptr<double>(v), *Z0 = Z.ptr<double>(v);
    const float* edge = edgeDistance.ptr<float>(v);
    auto* outN = out.normals.ptr<cv::Vec3f>(v);
    for (int u = 0; u < cols; ++u) {
      if (ok[u] == 0.0 || pn[u] < minWindowCount) continue;
      if (edge[u] <= P.windowRadius) continue;  // window would straddle a depth jump
      Moments m;
      m.n = pn[u];
      m.s << px[u], py[u], pz[u];
      m.ss << pxx[u], pxy[u], pxz[u], pxy[u], pyy[u], pyz[u], pxz[u], pyz[u], pzz[u];
      const PlaneFit f = fitPlane(m);
      if (f.curvature > P.maxCurvature) continue;  // window crosses a fold or clutter
      Eigen::Vector3d n = f.normal;
      if (n.x() * X0[u] + n.y() * Y0[u] + n.z() * Z0[u] > 0) n = -n;
      outN[u] = cv::Vec3f(float(n.x()), float(n.y()), float(n.z()));
    }
  }

  // ---- AHC-style plane segmentation on cells.
  const int cs = P.cellSize, gw = cols / cs, gh = rows / cs;
  std::vector<Moments> cellMoments(static_cast<std::size_t>(gw * gh));
  std::vector<PlaneFit> cellFit(cellMoments.size());
  std::vector<char> cellOk(cellMoments.size(), 0);
  for (int gy = 0; gy < gh; ++gy) {
    for (int gx = 0; gx < gw; ++gx) {
      Moments m;
      for (int v = gy * cs; v < (gy + 1) * cs; ++v)
        for (int u = gx * cs; u < (gx + 1) * cs; ++u)
          if (valid.at<double>(v, u) != 0.0)
            m.add({X.at<double>(v, u), Y.at<double>(v, u), Z.at<double>(v, u)});
      const std::size_t i = static_cast<std::size_t>(gy * gw + gx);
      cellMoments[i] = m;
      if (m.n < P.minCellValidShare * cs * cs) continue;
      cellFit[i] = fitPlane(m);
      cellOk[i] = cellFit[i].rms <= P.cellMseFactor * sigmaAt(cellFit[i].centroid.z());
    }
  }
  std::vector<std::size_t> seeds;
  for (std::size_t i = 0; i < cellOk.size(); ++i)
    if (cellOk[i]) seeds.push_back(i);
  // Best-fitting cells first, as AHC pops the lowest-MSE node first (relative to the noise at its depth).
  std::stable_sort(seeds.begin(), seeds.end(), [&](std::size_t a, std::size_t b) {
    return cellFit[a].rms / sigmaAt(cellFit[a].centroid.z()) < cellFit[b].rms / sigmaAt(cellFit[b].centroid.z());
  });
  std::vector<int> cellRegion(cellOk.size(), -1);
  std::vector<PlaneFit> planes;
  const double cosMerge = std::cos(P.mergeAngleDeg * kDegToRad);
  int regionId = 0;
  for (std::size_t seed : seeds) {
    if (cellRegion[seed] != -1) continue;
    Moments region = cellMoments[seed];
    PlaneFit fit = cellFit[seed];
    std::vector<std::size_t> members{seed};
    cellRegion[seed] = regionId;
    std::deque<std::size_t> queue{seed};
    while (!queue.empty()) {
      const std::size_t c = queue.front();
      queue.pop_front();
      const int cx = static_cast<int>(c) % gw, cy = static_cast<int>(c) / gw;
      const int nx[4] = {cx - 1, cx + 1, cx, cx}, ny[4] = {cy, cy, cy - 1, cy + 1};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= gw || ny[k] >= gh) continue;
        const std::size_t nb = static_cast<std::size_t>(ny[k] * gw + nx[k]);
        if (!cellOk[nb] || cellRegion[nb] != -1) continue;
        if (cellFit[nb].normal.dot(fit.normal) < cosMerge) continue;
        Moments merged = region;
        merged += cellMoments[nb];
        const PlaneFit mf = fitPlane(merged);
        if (mf.rms > P.mergeMseFactor * sigmaAt(mf.centroid.z())) continue;
        region = merged;
        fit = mf;
        cellRegion[nb] = regionId;
        members.push_back(nb);
        queue.push_back(nb);
      }
    }
    if (static_cast<int>(members.size()) < P.minPlaneCells) {
      // Too small to be a plane: release the cells (marked -2 so they do not seed again).
      for (std::size_t m : members) cellRegion[m] = -2;
      continue;
    }
    planes.push_back(fit);
    ++regionId;
  }

  // Pixel-level assignment (as AHC's boundary refinement): each valid pixel may join the closest of the
  // planes that own its cell or one of the 8 neighbouring cells. This fills the fold cells that failed the
  // cell fit and, at a fold, gives a pixel the plane it actually lies on rather than its cell's plane.
  auto regionOfCell = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= gw || y >= gh) return -1;
    return cellRegion[static_cast<std::size_t>(y * gw + x)];
  };
  std::vector<cv::Vec3f> planeNormals;
  for (const auto& pl : planes) planeNormals.emplace_back(float(pl.normal.x()), float(pl.normal.y()), float(pl.normal.z()));
  for (int v = 0; v < rows; ++v) {
    const int gy = std::min(v / cs, gh - 1);
    const double *ok = valid.ptr<double>(v), *X0 = X.ptr<double>(v), *Y0 = Y.ptr<double>(v), *Z0 = Z.ptr<double>(v);
    auto* outN = out.normals.ptr<cv::Vec3f>(v);
    uchar* mask = out.planarMask.ptr<uchar>(v);
    int* label = out.planeLabels.ptr<int>(v);
    for (int u = 0; u < cols; ++u) {
      if (ok[u] == 0.0) continue;
      const int gx = std::min(u / cs, gw - 1);
      const Eigen::Vector3d p(X0[u], Y0[u], Z0[u]);
      const cv::Vec3f own = outN[u];
      int bestPlane = -1;
      double bestDist = P.inlierSigmas * sigmaAt(p.z());
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int r = regionOfCell(gx + dx, gy + dy);
          if (r < 0 || r == bestPlane) continue;
          const PlaneFit& pl = planes[static_cast<std::size_t>(r)];
          const double dist = std::abs(pl.normal.dot(p) + pl.d);
          if (dist > bestDist) continue;
          // The pixel's own normal, where it has one, must agree with the plane.
          if (own != cv::Vec3f(0, 0, 0) && own.dot(planeNormals[static_cast<std::size_t>(r)]) < cosMerge) continue;
          bestDist = dist;
          bestPlane = r;
        }
      if (bestPlane < 0) continue;
      mask[u] = 255;
      label[u] = bestPlane;
      if (P.usePlaneNormals) outN[u] = planeNormals[static_cast<std::size_t>(bestPlane)];
    }
  }
  out.planeCount = static_cast<int>(planes.size());
  return out;
}

}  // namespace pslam::priors
