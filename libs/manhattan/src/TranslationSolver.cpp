#include "pslam/manhattan/TranslationSolver.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>

#include "pslam/core/Error.h"

namespace pslam::manhattan {

namespace {

constexpr const char* kCtx = "TranslationSolver";

/// Row of eq. 2.34 for unit bearings: t . (R f_prev x f_cur) = 0.
Eigen::Vector3d epipolarRow(const Eigen::Vector3d& fPrev, const Eigen::Vector3d& fCur, const Eigen::Matrix3d& R) {
  return (R * fPrev.normalized()).cross(fCur.normalized());
}

/// Sine of the angle between f_cur and the epipolar plane spanned by t and R f_prev.
double epipolarError(const Eigen::Vector3d& fPrev, const Eigen::Vector3d& fCur, const Eigen::Matrix3d& R,
                     const Eigen::Vector3d& t) {
  const Eigen::Vector3d planeNormal = t.cross(R * fPrev);
  const double n = planeNormal.norm() * fCur.norm();
  if (n < 1e-12) return 1.0;  // degenerate: the ray is parallel to t
  return std::abs(fCur.dot(planeNormal)) / n;
}

/// Depths (Z_cur, Z_prev) of Z_cur f_cur = Z_prev R f_prev + t in the least-squares sense.
Eigen::Vector2d triangulateDepths(const Eigen::Vector3d& fPrev, const Eigen::Vector3d& fCur, const Eigen::Matrix3d& R,
                                  const Eigen::Vector3d& t) {
  Eigen::Matrix<double, 3, 2> A;
  A.col(0) = fCur;
  A.col(1) = -(R * fPrev);
  return A.colPivHouseholderQr().solve(t);
}

Eigen::Vector3d directionFromRows(const std::vector<Eigen::Vector3d>& rows) {
  Eigen::MatrixXd A(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t i = 0; i < rows.size(); ++i) A.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  return svd.matrixV().col(2).normalized();
}

Eigen::Vector3d orientByCheirality(Eigen::Vector3d t, const std::vector<Eigen::Vector3d>& fp,
                                   const std::vector<Eigen::Vector3d>& fc, const Eigen::Matrix3d& R,
                                   const std::vector<bool>* mask) {
  int votes = 0;
  for (std::size_t i = 0; i < fp.size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    const Eigen::Vector2d z = triangulateDepths(fp[i], fc[i], R, t);
    if (z(0) > 0 && z(1) > 0) ++votes;
    if (z(0) < 0 && z(1) < 0) --votes;
  }
  return votes < 0 ? Eigen::Vector3d(-t) : t;
}

/// Generic RANSAC loop over 2-element minimal samples.
TranslationEstimate ransac(std::size_t n, const TranslationRansacParams& P,
                           const std::function<bool(std::size_t, std::size_t, Eigen::Vector3d&)>& minimal,
                           const std::function<double(std::size_t, const Eigen::Vector3d&)>& error,
                           const std::function<Eigen::Vector3d(const std::vector<bool>&)>& refit) {
  TranslationEstimate best;
  best.inliers.assign(n, false);
  std::mt19937 rng(P.seed);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  int needed = P.maxIterations;
  for (int it = 0; it < needed && it < P.maxIterations; ++it) {
    ++best.iterations;
    const std::size_t i = pick(rng);
    std::size_t j = pick(rng);
    if (i == j) j = (j + 1) % n;
    Eigen::Vector3d t;
    if (!minimal(i, j, t)) continue;
    std::vector<bool> inl(n, false);
    std::size_t count = 0;
    for (std::size_t k = 0; k < n; ++k)
      if (error(k, t) < P.inlierThreshold) {
        inl[k] = true;
        ++count;
      }
    if (count > best.inlierCount) {
      best.inlierCount = count;
      best.inliers = inl;
      best.t_cur_prev = t;
      const double w = static_cast<double>(count) / n;
      const double pAllInlier = w * w;
      if (pAllInlier >= 1.0 - 1e-12)
        needed = it + 1;
      else
        needed = static_cast<int>(std::ceil(std::log(1.0 - P.confidence) / std::log(1.0 - pAllInlier)));
    }
  }
  if (best.inlierCount >= 2) {
    // Refit on all inliers, then re-collect the inliers of the refined solution.
    best.t_cur_prev = refit(best.inliers);
    best.inlierCount = 0;
    for (std::size_t k = 0; k < n; ++k) {
      best.inliers[k] = error(k, best.t_cur_prev) < P.inlierThreshold;
      best.inlierCount += best.inliers[k] ? 1 : 0;
    }
  }
  best.valid = best.inlierCount >= std::max<std::size_t>(2, P.minInliers);
  return best;
}

void checkFinite(const Eigen::Matrix3d& R) {
  require(R.allFinite(), kCtx, "rotation has NaN/Inf entries");
  require((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0, kCtx,
          "R_cur_prev is not a rotation matrix");
}

}  // namespace

PSLAM_DEFINE_PARAMS(TranslationRansacParams)

Eigen::Vector3d solveTranslationDirection(const std::vector<Eigen::Vector3d>& fp, const std::vector<Eigen::Vector3d>& fc,
                                          const Eigen::Matrix3d& R) {
  require(fp.size() == fc.size(), kCtx, "bearing lists differ in length");
  require(fp.size() >= 2, kCtx, "needs at least 2 correspondences");
  checkFinite(R);
  std::vector<Eigen::Vector3d> rows;
  for (std::size_t i = 0; i < fp.size(); ++i) {
    require(fp[i].allFinite() && fc[i].allFinite(), kCtx, "bearing " + std::to_string(i) + " is NaN/Inf");
    rows.push_back(epipolarRow(fp[i], fc[i], R));
  }
  return orientByCheirality(directionFromRows(rows), fp, fc, R, nullptr);
}

Eigen::Vector3d solveTranslationMetric(const std::vector<Eigen::Vector3d>& Xp, const std::vector<Eigen::Vector2d>& xc,
                                       const Eigen::Matrix3d& R) {
  require(Xp.size() == xc.size(), kCtx, "point and observation lists differ in length");
  require(Xp.size() >= 2, kCtx, "needs at least 2 points");
  checkFinite(R);
  Eigen::MatrixXd A(static_cast<Eigen::Index>(2 * Xp.size()), 3);
  Eigen::VectorXd b(static_cast<Eigen::Index>(2 * Xp.size()));
  for (std::size_t i = 0; i < Xp.size(); ++i) {
    require(Xp[i].allFinite() && xc[i].allFinite(), kCtx, "point " + std::to_string(i) + " is NaN/Inf");
    const Eigen::Vector3d X = R * Xp[i];
    const auto r = static_cast<Eigen::Index>(2 * i);
    A.row(r) << 1.0, 0.0, -xc[i].x();
    b(r) = xc[i].x() * X.z() - X.x();
    A.row(r + 1) << 0.0, 1.0, -xc[i].y();
    b(r + 1) = xc[i].y() * X.z() - X.y();
  }
  return A.colPivHouseholderQr().solve(b);
}

TranslationEstimate ransacTranslationDirection(const std::vector<Eigen::Vector3d>& fp,
                                               const std::vector<Eigen::Vector3d>& fc, const Eigen::Matrix3d& R,
                                               const TranslationRansacParams& P) {
  P.check();
  require(fp.size() == fc.size(), kCtx, "bearing lists differ in length");
  require(fp.size() >= 2, kCtx, "needs at least 2 correspondences");
  checkFinite(R);
  std::vector<Eigen::Vector3d> rows(fp.size());
  for (std::size_t i = 0; i < fp.size(); ++i) {
    require(fp[i].allFinite() && fc[i].allFinite(), kCtx, "bearing " + std::to_string(i) + " is NaN/Inf");
    rows[i] = epipolarRow(fp[i], fc[i], R);
  }
  auto minimal = [&](std::size_t i, std::size_t j, Eigen::Vector3d& t) {
    t = rows[i].cross(rows[j]);  // the null vector of two rows of eq. 2.34
    if (t.norm() < 1e-12) return false;
    t.normalize();
    return true;
  };
  auto error = [&](std::size_t k, const Eigen::Vector3d& t) { return epipolarError(fp[k], fc[k], R, t); };
  auto refit = [&](const std::vector<bool>& inl) {
    std::vector<Eigen::Vector3d> sel;
    for (std::size_t k = 0; k < rows.size(); ++k)
      if (inl[k]) sel.push_back(rows[k]);
    return directionFromRows(sel);
  };
  TranslationEstimate e = ransac(fp.size(), P, minimal, error, refit);
  e.t_cur_prev = orientByCheirality(e.t_cur_prev, fp, fc, R, &e.inliers);
  return e;
}

TranslationEstimate ransacTranslationMetric(const std::vector<Eigen::Vector3d>& Xp,
                                            const std::vector<Eigen::Vector2d>& xc, const Eigen::Matrix3d& R,
                                            const TranslationRansacParams& P) {
  P.check();
  require(Xp.size() == xc.size(), kCtx, "point and observation lists differ in length");
  require(Xp.size() >= 2, kCtx, "needs at least 2 points");
  checkFinite(R);
  auto minimal = [&](std::size_t i, std::size_t j, Eigen::Vector3d& t) {
    t = solveTranslationMetric({Xp[i], Xp[j]}, {xc[i], xc[j]}, R);
    return t.allFinite();
  };
  auto error = [&](std::size_t k, const Eigen::Vector3d& t) {
    const Eigen::Vector3d X = R * Xp[k] + t;
    if (X.z() <= 1e-9) return 1e9;  // behind the camera
    return (X.head<2>() / X.z() - xc[k]).norm();
  };
  auto refit = [&](const std::vector<bool>& inl) {
    std::vector<Eigen::Vector3d> a;
    std::vector<Eigen::Vector2d> b;
    for (std::size_t k = 0; k < Xp.size(); ++k)
      if (inl[k]) {
        a.push_back(Xp[k]);
        b.push_back(xc[k]);
      }
    return solveTranslationMetric(a, b, R);
  };
  return ransac(Xp.size(), P, minimal, error, refit);
}

}  // namespace pslam::manhattan
