#include "pslam/geometry/Sim3Solver.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "pslam/core/Error.h"

namespace pslam::geometry {

PSLAM_DEFINE_PARAMS(Sim3RansacParams)

const char* toString(Sim3Failure failure) {
  switch (failure) {
    case Sim3Failure::None: return "none";
    case Sim3Failure::TooFewCorrespondences: return "too few correspondences";
    case Sim3Failure::InvalidInput: return "invalid input";
    case Sim3Failure::AllSamplesDegenerate: return "all samples degenerate";
    case Sim3Failure::TooFewInliers: return "too few inliers";
  }
  return "?";
}

namespace {

constexpr const char* kContext = "estimateSim3Ransac";

/// A triangle thinner than this (height over longest edge) leaves the rotation about its long edge to the noise;
/// exactly collinear points leave it undetermined, and then every point on the line is an inlier of any rotation.
constexpr double kMinTriangleAspect = 1e-3;
/// Points closer than this, relative to their distance from the camera, count as coincident (Umeyama divides by
/// their spread).
constexpr double kMinRelativeSpread = 1e-9;

void checkIntrinsics(const Eigen::Matrix3d& K, const char* name) {
  const bool ok = K.allFinite() && K(0, 0) > 0.0 && K(1, 1) > 0.0 && K(1, 0) == 0.0 && K(2, 0) == 0.0 &&
                  K(2, 1) == 0.0 && K(2, 2) == 1.0;
  if (!ok) {
    std::ostringstream s;
    s << name << " is not a pinhole matrix [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0: " << K.row(0) << "; "
      << K.row(1) << "; " << K.row(2);
    throw Error(std::string(kContext) + ": " + s.str());
  }
}

/// Squared pixel error of X (camera coordinates) against `pixel`; nullopt when X is not in front of the camera.
std::optional<double> reprojectionError2(const Eigen::Matrix3d& K, const Eigen::Vector3d& X,
                                         const Eigen::Vector2d& pixel) {
  if (!(X.z() > 0.0)) return std::nullopt;
  const Eigen::Vector3d h = K * X;
  const Eigen::Vector2d px = h.head<2>() / h.z();
  return (px - pixel).squaredNorm();
}

/// Not coincident and not (nearly) collinear: the only triples whose similarity is unique.
bool wellConditioned(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, bc = c - b;
  const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
  const double magnitude = std::max({a.norm(), b.norm(), c.norm()});
  if (!(longest2 > 0.0) || std::sqrt(longest2) <= kMinRelativeSpread * magnitude) return false;
  // |ab x ac| is twice the area = longest edge * height.
  return ab.cross(ac).norm() > kMinTriangleAspect * longest2;
}

/// Umeyama with scale from p2 (source) to p1 (target) over `indices`; nullopt when not finite or scale <= 0.
std::optional<Sim3> umeyamaSim3(const std::vector<Sim3Correspondence>& matches, const std::vector<int>& indices) {
  const Eigen::Index n = static_cast<Eigen::Index>(indices.size());
  Eigen::Matrix<double, 3, Eigen::Dynamic> src(3, n), dst(3, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    src.col(k) = matches[indices[k]].p2;
    dst.col(k) = matches[indices[k]].p1;
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, true);
  if (!T.allFinite()) return std::nullopt;
  const Eigen::Matrix3d sR = T.topLeftCorner<3, 3>();
  // Umeyama returns s R with R a proper rotation: the scale is the cube root of the determinant.
  const double s = std::cbrt(sR.determinant());
  if (!(s > 0.0) || !std::isfinite(s)) return std::nullopt;
  const Sim3 S12(s, sR / s, T.topRightCorner<3, 1>());
  if (!S12.R.allFinite() || !S12.t.allFinite()) return std::nullopt;
  return S12;
}

int scoreHypothesis(const std::vector<Sim3Correspondence>& matches, const Sim3& S12, const Eigen::Matrix3d& K1,
                    const Eigen::Matrix3d& K2, double chi2, std::vector<bool>& flags) {
  const Sim3 S21 = S12.inverse();
  int count = 0;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    flags[i] = isSim3Inlier(matches[i], S12, S21, K1, K2, chi2);
    count += flags[i] ? 1 : 0;
  }
  return count;
}

/// RANSAC iterations after which an all-inlier minimal set of 3 has been drawn with `probability`, for an
/// inlier ratio of numInliers / n; capped at maxIterations.
int requiredIterations(int numInliers, int n, double probability, int maxIterations) {
  const double w = static_cast<double>(numInliers) / static_cast<double>(n);
  if (w >= 1.0) return 1;
  const double allInlier = w * w * w;
  const double logMiss = std::log1p(-allInlier);
  if (!(logMiss < 0.0)) return maxIterations;
  const double k = std::ceil(std::log(1.0 - probability) / logMiss);
  if (!std::isfinite(k) || k >= static_cast<double>(maxIterations)) return maxIterations;
  return std::max(1, static_cast<int>(k));
}

}  // namespace

bool isSim3Inlier(const Sim3Correspondence& m, const Sim3& S12, const Sim3& S21, const Eigen::Matrix3d& K1,
                  const Eigen::Matrix3d& K2, double chi2) {
  const auto e1 = reprojectionError2(K1, S12.map(m.p2), m.px1);
  if (!e1 || !(*e1 < chi2 * m.sigma2_1)) return false;
  const auto e2 = reprojectionError2(K2, S21.map(m.p1), m.px2);
  return e2 && *e2 < chi2 * m.sigma2_2;
}

Sim3RansacResult estimateSim3Ransac(const std::vector<Sim3Correspondence>& matches, const Eigen::Matrix3d& K1,
                                    const Eigen::Matrix3d& K2, const Sim3RansacParams& params, std::mt19937& rng) {
  params.check();
  checkIntrinsics(K1, "K1");
  checkIntrinsics(K2, "K2");
  Sim3RansacResult result;
  const int n = static_cast<int>(matches.size());
  result.inliers.assign(matches.size(), false);
  auto fail = [&result](Sim3Failure why, const std::string& message) {
    result.success = false;
    result.failure = why;
    result.message = message;
    return result;
  };
  const int needed = std::max(3, params.minInliers);
  if (n < needed) {
    return fail(Sim3Failure::TooFewCorrespondences,
                std::to_string(n) + " correspondences, need at least " + std::to_string(needed));
  }
  for (int i = 0; i < n; ++i) {
    const Sim3Correspondence& m = matches[i];
    if (!m.p1.allFinite() || !m.p2.allFinite() || !m.px1.allFinite() || !m.px2.allFinite()) {
      return fail(Sim3Failure::InvalidInput, "correspondence " + std::to_string(i) + " has non-finite coordinates");
    }
    if (!(m.sigma2_1 > 0.0) || !(m.sigma2_2 > 0.0) || !std::isfinite(m.sigma2_1) || !std::isfinite(m.sigma2_2)) {
      return fail(Sim3Failure::InvalidInput, "correspondence " + std::to_string(i) +
                                                 " has a keypoint variance that is not a positive number");
    }
  }

  std::vector<int> sample(3);
  std::vector<bool> flags(matches.size());
  std::optional<Sim3> best;
  int bestCount = -1;
  int iterationsNeeded = params.maxIterations;
  int degenerate = 0;
  for (int it = 0; it < iterationsNeeded; ++it) {
    ++result.iterations;
    // Three distinct indices: each draw skips the ones already taken (kept sorted).
    std::uniform_int_distribution<int> d0(0, n - 1), d1(0, n - 2), d2(0, n - 3);
    int a = d0(rng), b = d1(rng), c = d2(rng);
    if (b >= a) ++b;
    const int lo = std::min(a, b), hi = std::max(a, b);
    if (c >= lo) ++c;
    if (c >= hi) ++c;
    sample = {a, b, c};
    const Sim3Correspondence &ma = matches[a], &mb = matches[b], &mc = matches[c];
    if (!wellConditioned(ma.p1, mb.p1, mc.p1) || !wellConditioned(ma.p2, mb.p2, mc.p2)) {
      ++degenerate;
      continue;
    }
    const std::optional<Sim3> S12 = umeyamaSim3(matches, sample);
    if (!S12) {
      ++degenerate;
      continue;
    }
    const int count = scoreHypothesis(matches, *S12, K1, K2, params.chi2, flags);
    if (count > bestCount) {
      bestCount = count;
      best = S12;
      result.inliers = flags;
      iterationsNeeded = requiredIterations(count, n, params.probability, params.maxIterations);
    }
  }
  if (!best) {
    return fail(Sim3Failure::AllSamplesDegenerate,
                "all " + std::to_string(result.iterations) +
                    " minimal sets were degenerate (coincident or collinear points)");
  }
  result.S12 = *best;
  result.numInliers = bestCount;

  // Refinement on all inliers of the best hypothesis.
  if (bestCount >= 3) {
    std::vector<int> inlierIdx;
    for (int i = 0; i < n; ++i)
      if (result.inliers[i]) inlierIdx.push_back(i);
    if (const std::optional<Sim3> refined = umeyamaSim3(matches, inlierIdx)) {
      const int count = scoreHypothesis(matches, *refined, K1, K2, params.chi2, flags);
      if (count >= bestCount) {
        result.S12 = *refined;
        result.numInliers = count;
        result.inliers = flags;
      }
    }
  }

  std::ostringstream info;
  info << result.numInliers << " of " << n << " inliers after " << result.iterations << " iterations ("
       << degenerate << " degenerate samples), scale " << result.S12.s;
  if (result.numInliers < params.minInliers) {
    return fail(Sim3Failure::TooFewInliers, info.str() + ", need " + std::to_string(params.minInliers));
  }
  result.success = true;
  result.message = info.str();
  return result;
}

}  // namespace pslam::geometry
