#include "pslam/geometry/TwoViewInitializer.h"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <numeric>
#include <sstream>

#include <ceres/ceres.h>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <mrpt/math/CMatrixFixed.h>

#include "pslam/core/Error.h"
#include "pslam/geometry/Triangulation.h"

namespace pslam::geometry {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
// chi^2 quantiles at 95 %: 1 dof for a point-to-line distance, 2 dof for a point-to-point distance.
constexpr double kChi2OneDof = 3.841;
constexpr double kChi2TwoDof = 5.991;
// A point whose rays are (almost) parallel (< ~0.36 deg) is kept in the count even behind a camera, as
// ORB-SLAM does: its depth is meaningless, but it does not contradict the motion hypothesis.
constexpr double kLowParallaxCos = 0.99998;

using Points = std::vector<Eigen::Vector2d>;

ceres::Solver::Options refinementOptions() {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-12;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-12;
  options.num_threads = 1;  // deterministic
  options.logging_type = ceres::SILENT;
  return options;
}
using Candidate = std::pair<Eigen::Matrix3d, Eigen::Vector3d>;

/// Translates the points to zero mean and scales each axis to unit standard deviation (§2.3.2.1: "the 2d
/// coordinates are standardized using mean subtraction and division by the standard deviation").
/// Returns T with x_normalized = T x.
Eigen::Matrix3d normalizePoints(const Points& in, Points& out) {
  const double n = static_cast<double>(in.size());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : in) mean += p;
  mean /= n;
  Eigen::Vector2d var = Eigen::Vector2d::Zero();
  for (const auto& p : in) var += (p - mean).cwiseAbs2();
  var /= n;
  const double sx = var.x() > 0.0 ? 1.0 / std::sqrt(var.x()) : 1.0;
  const double sy = var.y() > 0.0 ? 1.0 / std::sqrt(var.y()) : 1.0;
  out.resize(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    out[i] = {(in[i].x() - mean.x()) * sx, (in[i].y() - mean.y()) * sy};
  }
  Eigen::Matrix3d T;
  T << sx, 0.0, -mean.x() * sx, 0.0, sy, -mean.y() * sy, 0.0, 0.0, 1.0;
  return T;
}

/// Unnormalized DLT on already normalized points (eq. 2.48): two rows per correspondence of x2 ~ H x1.
Eigen::Matrix3d dltHomography(const Points& x1, const Points& x2) {
  const int n = static_cast<int>(x1.size());
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(2 * n, 9);
  for (int i = 0; i < n; ++i) {
    const double u1 = x1[i].x(), v1 = x1[i].y(), u2 = x2[i].x(), v2 = x2[i].y();
    A.row(2 * i) << 0.0, 0.0, 0.0, -u1, -v1, -1.0, v2 * u1, v2 * v1, v2;
    A.row(2 * i + 1) << u1, v1, 1.0, 0.0, 0.0, 0.0, -u2 * u1, -u2 * v1, -u2;
  }
  Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 9>> svd(A, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 9, 1> h = svd.matrixV().col(8);
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(h.data());
}

/// 8-point on normalized points (eq. 2.36-2.39), then the rank-2 constraint (eq. 2.42-2.43).
Eigen::Matrix3d eightPointFundamental(const Points& x1, const Points& x2) {
  const int n = static_cast<int>(x1.size());
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(n, 9);
  for (int i = 0; i < n; ++i) {
    const double u1 = x1[i].x(), v1 = x1[i].y(), u2 = x2[i].x(), v2 = x2[i].y();
    A.row(i) << u2 * u1, u2 * v1, u2, v2 * u1, v2 * v1, v2, u1, v1, 1.0;
  }
  Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 9>> svd(A, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 9, 1> f = svd.matrixV().col(8);
  const Eigen::Matrix3d Fpre = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(f.data());
  Eigen::JacobiSVD<Eigen::Matrix3d> svd2(Fpre, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = svd2.singularValues();
  s(2) = 0.0;
  return svd2.matrixU() * s.asDiagonal() * svd2.matrixV().transpose();
}

/// Symmetric transfer error score (eq. 2.55) with ORB-SLAM's truncated chi^2 scoring: every match whose
/// error is below the 95 % threshold in both images adds (threshold - chi2) in each image.
double scoreHomography(const Eigen::Matrix3d& H21, const Points& x1, const Points& x2, double sigma,
                       std::vector<bool>& inliers) {
  const Eigen::Matrix3d H12 = H21.inverse();
  const double invSigma2 = 1.0 / (sigma * sigma);
  double score = 0.0;
  inliers.assign(x1.size(), false);
  for (std::size_t i = 0; i < x1.size(); ++i) {
    const Eigen::Vector3d p1 = x1[i].homogeneous(), p2 = x2[i].homogeneous();
    const Eigen::Vector3d p1in2 = H21 * p1;
    const Eigen::Vector3d p2in1 = H12 * p2;
    const double chi2In2 = (p1in2.head<2>() / p1in2.z() - x2[i]).squaredNorm() * invSigma2;
    const double chi2In1 = (p2in1.head<2>() / p2in1.z() - x1[i]).squaredNorm() * invSigma2;
    // NaN (a point mapped to infinity) fails both comparisons and counts as an outlier.
    if (!(chi2In2 <= kChi2TwoDof) || !(chi2In1 <= kChi2TwoDof)) continue;
    score += (kChi2TwoDof - chi2In2) + (kChi2TwoDof - chi2In1);
    inliers[i] = true;
  }
  return score;
}

/// Epipolar distance score (eq. 2.46): distance threshold chi^2(1) = 3.841, but the score uses the
/// chi^2(2) constant 5.991 so that S_F is on the same scale as S_H (ORB-SLAM).
double scoreFundamental(const Eigen::Matrix3d& F21, const Points& x1, const Points& x2, double sigma,
                        std::vector<bool>& inliers) {
  const double invSigma2 = 1.0 / (sigma * sigma);
  double score = 0.0;
  inliers.assign(x1.size(), false);
  for (std::size_t i = 0; i < x1.size(); ++i) {
    const Eigen::Vector3d p1 = x1[i].homogeneous(), p2 = x2[i].homogeneous();
    const Eigen::Vector3d line2 = F21 * p1;           // epipolar line of x1 in image 2
    const Eigen::Vector3d line1 = F21.transpose() * p2;  // epipolar line of x2 in image 1
    const double num2 = line2.dot(p2), num1 = line1.dot(p1);
    const double chi2In2 = num2 * num2 / line2.head<2>().squaredNorm() * invSigma2;
    const double chi2In1 = num1 * num1 / line1.head<2>().squaredNorm() * invSigma2;
    if (!(chi2In2 <= kChi2OneDof) || !(chi2In1 <= kChi2OneDof)) continue;
    score += (kChi2TwoDof - chi2In2) + (kChi2TwoDof - chi2In1);
    inliers[i] = true;
  }
  return score;
}

struct RansacOutcome {
  Eigen::Matrix3d model = Eigen::Matrix3d::Zero();
  double score = 0.0;
  std::vector<bool> inliers;
  int numInliers = 0;
  bool valid = false;
};

enum class RansacKind { Homography, Fundamental };

/// One RANSAC loop over the pre-drawn sample sets. Pure function of its inputs: running the H and F loops
/// concurrently or one after the other gives identical results.
RansacOutcome runRansac(RansacKind kind, const Points& x1, const Points& x2, const SampleSets& samples,
                        double sigma, int refitIterations) {
  Points n1, n2;
  const Eigen::Matrix3d T1 = normalizePoints(x1, n1);
  const Eigen::Matrix3d T2 = normalizePoints(x2, n2);
  const Eigen::Matrix3d T2inv = T2.inverse();
  RansacOutcome best;
  Points s1(8), s2(8);
  std::vector<bool> inliers;
  for (const auto& sample : samples) {
    for (int j = 0; j < 8; ++j) {
      s1[j] = n1[sample[j]];
      s2[j] = n2[sample[j]];
    }
    Eigen::Matrix3d model;
    double score = 0.0;
    if (kind == RansacKind::Homography) {
      model = T2inv * dltHomography(s1, s2) * T1;
      if (!model.allFinite() || std::abs(model.determinant()) < 1e-300) continue;
      score = scoreHomography(model, x1, x2, sigma, inliers);
    } else {
      model = T2.transpose() * eightPointFundamental(s1, s2) * T1;
      if (!model.allFinite()) continue;
      score = scoreFundamental(model, x1, x2, sigma, inliers);
    }
    if (!best.valid || score > best.score) {  // first best kept on ties: deterministic
      best.valid = true;
      best.model = model;
      best.score = score;
      best.inliers = inliers;
    }
  }
  // Refit on all inliers of the best hypothesis (least squares over the inliers, Hartley & Zisserman
  // §4.7.1), kept only while it raises the score. ORB-SLAM keeps the 8-point hypothesis, whose pose error
  // grows quickly with pixel noise; refitIterations = 0 restores that behaviour.
  for (int k = 0; k < refitIterations && best.valid; ++k) {
    Points r1, r2;
    for (std::size_t i = 0; i < x1.size(); ++i) {
      if (!best.inliers[i]) continue;
      r1.push_back(n1[i]);
      r2.push_back(n2[i]);
    }
    if (r1.size() < 8) break;
    Eigen::Matrix3d model;
    double score = 0.0;
    if (kind == RansacKind::Homography) {
      model = T2inv * dltHomography(r1, r2) * T1;
      if (!model.allFinite() || std::abs(model.determinant()) < 1e-300) break;
      score = scoreHomography(model, x1, x2, sigma, inliers);
    } else {
      model = T2.transpose() * eightPointFundamental(r1, r2) * T1;
      if (!model.allFinite()) break;
      score = scoreFundamental(model, x1, x2, sigma, inliers);
    }
    if (!(score > best.score)) break;
    best.model = model;
    best.score = score;
    best.inliers = inliers;
  }
  best.numInliers = static_cast<int>(std::count(best.inliers.begin(), best.inliers.end(), true));
  return best;
}

/// ORB-SLAM's CheckRT: triangulates every inlier for the candidate (R21, t21) and counts the points that
/// are in front of both cameras (or have negligible parallax) and re-project within th2 in both images.
struct CandidateCheck {
  int numGood = 0;
  double parallaxDeg = 0.0;
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> good;     ///< good and with enough parallax to be a usable map point
  std::vector<bool> counted;  ///< counted in numGood (includes low-parallax points)
};

CandidateCheck checkCandidate(const Eigen::Matrix3d& R21, const Eigen::Vector3d& t21, const Points& x1,
                              const Points& x2, const std::vector<bool>& inliers, const Eigen::Matrix3d& K,
                              double th2) {
  CandidateCheck out;
  out.points.assign(x1.size(), Eigen::Vector3d::Zero());
  out.good.assign(x1.size(), false);
  out.counted.assign(x1.size(), false);
  const Matrix34d P1 = projectionMatrix(K, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const Matrix34d P2 = projectionMatrix(K, R21, t21);
  const Eigen::Vector3d O1 = Eigen::Vector3d::Zero();
  const Eigen::Vector3d O2 = cameraCenter(R21, t21);
  std::vector<double> cosParallaxes;
  cosParallaxes.reserve(x1.size());
  for (std::size_t i = 0; i < x1.size(); ++i) {
    if (!inliers[i]) continue;
    Eigen::Vector3d X;
    if (!triangulateDLT(P1, x1[i], P2, x2[i], X)) continue;
    const double cosParallax = parallaxCosine(X, O1, O2);
    if (X.z() <= 0.0 && cosParallax < kLowParallaxCos) continue;
    const Eigen::Vector3d X2 = R21 * X + t21;
    if (X2.z() <= 0.0 && cosParallax < kLowParallaxCos) continue;
    // Projection via K directly: a low-parallax point may lie behind a camera (see kLowParallaxCos).
    const Eigen::Vector3d h1 = K * X, h2 = K * X2;
    if ((h1.head<2>() / h1.z() - x1[i]).squaredNorm() > th2) continue;
    if ((h2.head<2>() / h2.z() - x2[i]).squaredNorm() > th2) continue;
    cosParallaxes.push_back(cosParallax);
    out.points[i] = X;
    ++out.numGood;
    out.counted[i] = true;
    if (cosParallax < kLowParallaxCos) out.good[i] = true;
  }
  if (out.numGood > 0) {
    // ORB-SLAM: the parallax of the 51st most-parallax point (robust to a few wrong large-parallax ones).
    std::sort(cosParallaxes.begin(), cosParallaxes.end());
    const std::size_t idx = std::min<std::size_t>(50, cosParallaxes.size() - 1);
    out.parallaxDeg = std::acos(cosParallaxes[idx]) * kRadToDeg;
  }
  return out;
}

/// Sampson approximation of the geometric (re-projection) error of x2^T F21 x1 = 0 with
/// F21 = K^-T [t]x R K^-1 (eq. 2.10, 2.35), divided by sigma. Parameters: rotation as an Eigen quaternion
/// (x, y, z, w), unit translation on the sphere (the scale is unobservable).
struct SampsonError {
  Eigen::Vector3d p1, p2;
  Eigen::Matrix3d Kinv;
  double invSigma;

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> quat(q);
    const Eigen::Matrix<T, 3, 3> R = quat.normalized().toRotationMatrix();
    Eigen::Matrix<T, 3, 3> tx;
    tx << T(0), -t[2], t[1], t[2], T(0), -t[0], -t[1], t[0], T(0);
    const Eigen::Matrix<T, 3, 3> Ki = Kinv.cast<T>();
    const Eigen::Matrix<T, 3, 3> F = Ki.transpose() * tx * R * Ki;
    const Eigen::Matrix<T, 3, 1> Fp1 = F * p1.cast<T>();
    const Eigen::Matrix<T, 3, 1> Ftp2 = F.transpose() * p2.cast<T>();
    const T algebraic = p2.cast<T>().dot(Fp1);
    const T den = Fp1(0) * Fp1(0) + Fp1(1) * Fp1(1) + Ftp2(0) * Ftp2(0) + Ftp2(1) * Ftp2(1);
    residual[0] = algebraic / ceres::sqrt(den) * T(invSigma);
    return true;
  }
};

/// Minimizes the robust (Huber at the chi^2(1) 95 % bound) Sampson error of the selected matches over
/// (R21, t21) with ||t21|| = 1. The linear estimators minimize an algebraic error whose translation is
/// visibly biased at 0.5-1 px noise; ORB-SLAM leaves this to the global BA that follows initialization.
bool refineRelativePose(const Points& x1, const Points& x2, const std::vector<bool>& use, const Eigen::Matrix3d& Kinv,
                        double sigma, Eigen::Matrix3d& R21, Eigen::Vector3d& t21) {
  Eigen::Quaterniond q(R21);
  Eigen::Vector3d t = t21.normalized();
  ceres::Problem problem;
  int used = 0;
  for (std::size_t i = 0; i < x1.size(); ++i) {
    if (!use[i]) continue;
    auto* cost = new ceres::AutoDiffCostFunction<SampsonError, 1, 4, 3>(
        new SampsonError{x1[i].homogeneous(), x2[i].homogeneous(), Kinv, 1.0 / sigma});
    problem.AddResidualBlock(cost, new ceres::HuberLoss(std::sqrt(kChi2OneDof)), q.coeffs().data(), t.data());
    ++used;
  }
  if (used < 8) return false;
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  problem.SetManifold(t.data(), new ceres::SphereManifold<3>);
  ceres::Solver::Summary summary;
  ceres::Solve(refinementOptions(), &problem, &summary);
  if (!summary.IsSolutionUsable() || !q.coeffs().allFinite() || !t.allFinite()) return false;
  R21 = q.normalized().toRotationMatrix();
  t21 = t.normalized();
  return true;
}

}  // namespace

// ---- TwoViewParams

PSLAM_DEFINE_PARAMS(TwoViewParams)

const char* toString(TwoViewModel model) {
  switch (model) {
    case TwoViewModel::None: return "none";
    case TwoViewModel::Homography: return "homography";
    case TwoViewModel::Fundamental: return "fundamental";
  }
  return "?";
}

const char* toString(TwoViewFailure failure) {
  switch (failure) {
    case TwoViewFailure::None: return "none";
    case TwoViewFailure::TooFewMatches: return "too few matches";
    case TwoViewFailure::InvalidInput: return "invalid input";
    case TwoViewFailure::NoModel: return "no model";
    case TwoViewFailure::LowParallax: return "low parallax";
    case TwoViewFailure::TooFewTriangulated: return "too few triangulated points";
    case TwoViewFailure::Ambiguous: return "ambiguous solution";
  }
  return "?";
}

// ---- TwoViewInitializer

TwoViewInitializer::TwoViewInitializer(PinholeCamera camera, TwoViewParams params)
    : camera_(std::move(camera)), params_(params) {
  camera_.check();
  params_.check();
}

SampleSets TwoViewInitializer::drawSampleSets(int numMatches, int iterations, std::mt19937& rng) {
  if (numMatches < 8) throw Error("TwoViewInitializer: need at least 8 matches to draw samples, got " +
                                  std::to_string(numMatches));
  SampleSets sets(static_cast<std::size_t>(iterations));
  std::vector<int> pool(static_cast<std::size_t>(numMatches));
  for (auto& set : sets) {
    std::iota(pool.begin(), pool.end(), 0);
    // Partial Fisher-Yates: 8 distinct indices. The integer mapping is written out (not
    // std::uniform_int_distribution, whose algorithm is implementation-defined) so that sample sets
    // are the same with every standard library.
    for (int j = 0; j < 8; ++j) {
      const uint32_t range = static_cast<uint32_t>(numMatches - j);
      const int pick = j + static_cast<int>((static_cast<uint64_t>(rng()) * range) >> 32);
      std::swap(pool[j], pool[pick]);
      set[j] = pool[j];
    }
  }
  return sets;
}

Eigen::Matrix3d TwoViewInitializer::computeHomography(const Points& x1, const Points& x2) {
  if (x1.size() < 4 || x1.size() != x2.size())
    throw Error("computeHomography: need >= 4 correspondences of equal count");
  Points n1, n2;
  const Eigen::Matrix3d T1 = normalizePoints(x1, n1);
  const Eigen::Matrix3d T2 = normalizePoints(x2, n2);
  return T2.inverse() * dltHomography(n1, n2) * T1;
}

Eigen::Matrix3d TwoViewInitializer::computeFundamental(const Points& x1, const Points& x2) {
  if (x1.size() < 8 || x1.size() != x2.size())
    throw Error("computeFundamental: need >= 8 correspondences of equal count");
  Points n1, n2;
  const Eigen::Matrix3d T1 = normalizePoints(x1, n1);
  const Eigen::Matrix3d T2 = normalizePoints(x2, n2);
  return T2.transpose() * eightPointFundamental(n1, n2) * T1;
}

std::vector<Candidate> TwoViewInitializer::decomposeEssential(const Eigen::Matrix3d& E21) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E21, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d Vt = svd.matrixV().transpose();
  // eq. 2.45: t spans the left null space direction of E (last column of U).
  const Eigen::Vector3d t = U.col(2).normalized();
  Eigen::Matrix3d W;  // rotation by +pi/2 about z (eq. 2.44)
  W << 0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0;
  Eigen::Matrix3d R1 = U * W * Vt;
  if (R1.determinant() < 0.0) R1 = -R1;
  Eigen::Matrix3d R2 = U * W.transpose() * Vt;
  if (R2.determinant() < 0.0) R2 = -R2;
  return {{R1, t}, {R2, t}, {R1, -t}, {R2, -t}};
}

std::vector<Candidate> TwoViewInitializer::decomposeHomography(const Eigen::Matrix3d& A,
                                                               std::vector<Eigen::Vector3d>* normals) {
  if (normals) normals->clear();
  // Faugeras & Lustman (1988), the form of eq. 2.51-2.54: A = U diag(d1, d2, d3) V^T, d1 >= d2 >= d3.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  const Eigen::Matrix3d Vt = V.transpose();
  const double s = U.determinant() * Vt.determinant();
  const Eigen::Vector3d d = svd.singularValues();
  const double d1 = d(0), d2 = d(1), d3 = d(2);
  if (d1 / d2 < 1.00001 || d2 / d3 < 1.00001) return {};

  const double d1s = d1 * d1, d2s = d2 * d2, d3s = d3 * d3;
  const double aux1 = std::sqrt((d1s - d2s) / (d1s - d3s));
  const double aux3 = std::sqrt((d2s - d3s) / (d1s - d3s));
  const double x1[4] = {aux1, aux1, -aux1, -aux1};
  const double x3[4] = {aux3, -aux3, aux3, -aux3};
  std::vector<Candidate> out;
  out.reserve(8);

  // Case d' = d2 (eq. 2.53-2.54 with +).
  const double auxSinTheta = std::sqrt((d1s - d2s) * (d2s - d3s)) / ((d1 + d3) * d2);
  const double cosTheta = (d2s + d1 * d3) / ((d1 + d3) * d2);
  const double sinTheta[4] = {auxSinTheta, -auxSinTheta, -auxSinTheta, auxSinTheta};
  for (int i = 0; i < 4; ++i) {
    Eigen::Matrix3d Rp;
    Rp << cosTheta, 0.0, -sinTheta[i], 0.0, 1.0, 0.0, sinTheta[i], 0.0, cosTheta;
    const Eigen::Matrix3d R = s * U * Rp * Vt;
    const Eigen::Vector3d tp = Eigen::Vector3d(x1[i], 0.0, -x3[i]) * (d1 - d3);
    out.emplace_back(R, (U * tp).normalized());
    if (normals) normals->push_back(V * Eigen::Vector3d(x1[i], 0.0, x3[i]));
  }
  // Case d' = -d2 (eq. 2.53-2.54 with -).
  const double auxSinPhi = std::sqrt((d1s - d2s) * (d2s - d3s)) / ((d1 - d3) * d2);
  const double cosPhi = (d1 * d3 - d2s) / ((d1 - d3) * d2);
  const double sinPhi[4] = {auxSinPhi, -auxSinPhi, -auxSinPhi, auxSinPhi};
  for (int i = 0; i < 4; ++i) {
    Eigen::Matrix3d Rp;
    Rp << cosPhi, 0.0, sinPhi[i], 0.0, -1.0, 0.0, sinPhi[i], 0.0, -cosPhi;
    const Eigen::Matrix3d R = s * U * Rp * Vt;
    const Eigen::Vector3d tp = Eigen::Vector3d(x1[i], 0.0, x3[i]) * (d1 + d3);
    out.emplace_back(R, (U * tp).normalized());
    if (normals) normals->push_back(V * Eigen::Vector3d(x1[i], 0.0, x3[i]));
  }
  return out;
}

TwoViewResult TwoViewInitializer::initialize(const std::vector<cv::Point2f>& points_ref,
                                             const std::vector<cv::Point2f>& points_cur, std::mt19937& rng) const {
  if (points_ref.size() != points_cur.size()) {
    throw Error("TwoViewInitializer: " + std::to_string(points_ref.size()) + " reference points but " +
                std::to_string(points_cur.size()) + " current points for one-to-one matching");
  }
  std::vector<std::pair<int, int>> matches(points_ref.size());
  for (std::size_t i = 0; i < matches.size(); ++i) matches[i] = {static_cast<int>(i), static_cast<int>(i)};
  return initialize(points_ref, points_cur, matches, rng);
}

TwoViewResult TwoViewInitializer::initialize(const std::vector<cv::Point2f>& points_ref,
                                             const std::vector<cv::Point2f>& points_cur,
                                             const std::vector<std::pair<int, int>>& matches,
                                             std::mt19937& rng) const {
  TwoViewResult result;
  const std::size_t n = matches.size();
  result.points_ref.assign(n, Eigen::Vector3d::Zero());
  result.triangulated.assign(n, false);
  result.inliers.assign(n, false);
  auto fail = [&result](TwoViewFailure why, const std::string& message) {
    result.success = false;
    result.failure = why;
    result.message = message;
    return result;
  };

  Points x1(n), x2(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto [iRef, iCur] = matches[i];
    if (iRef < 0 || static_cast<std::size_t>(iRef) >= points_ref.size() || iCur < 0 ||
        static_cast<std::size_t>(iCur) >= points_cur.size()) {
      return fail(TwoViewFailure::InvalidInput, "match " + std::to_string(i) + " (" + std::to_string(iRef) + ", " +
                                                    std::to_string(iCur) + ") indexes outside the point lists");
    }
    x1[i] = {points_ref[iRef].x, points_ref[iRef].y};
    x2[i] = {points_cur[iCur].x, points_cur[iCur].y};
    if (!x1[i].allFinite() || !x2[i].allFinite()) {
      return fail(TwoViewFailure::InvalidInput, "match " + std::to_string(i) + " has non-finite coordinates");
    }
  }
  if (n < 8 || static_cast<int>(n) < params_.minTriangulated) {
    return fail(TwoViewFailure::TooFewMatches, std::to_string(n) + " matches, need at least " +
                                                   std::to_string(std::max(8, params_.minTriangulated)));
  }

  // Algorithm 1, line 3: one set of samples shared by both models.
  const SampleSets samples = drawSampleSets(static_cast<int>(n), params_.ransacIterations, rng);
  RansacOutcome h, f;
  const double sigma = params_.sigma;
  const int refit = params_.refitIterations;
  if (params_.parallel) {
    auto futureH = std::async(std::launch::async,
                              [&] { return runRansac(RansacKind::Homography, x1, x2, samples, sigma, refit); });
    auto futureF = std::async(std::launch::async,
                              [&] { return runRansac(RansacKind::Fundamental, x1, x2, samples, sigma, refit); });
    h = futureH.get();
    f = futureF.get();
  } else {
    h = runRansac(RansacKind::Homography, x1, x2, samples, sigma, refit);
    f = runRansac(RansacKind::Fundamental, x1, x2, samples, sigma, refit);
  }
  result.scoreH = h.score;
  result.scoreF = f.score;
  result.inliersH = h.numInliers;
  result.inliersF = f.numInliers;
  result.H_cur_ref = h.model;
  result.F_cur_ref = f.model;
  if (!h.valid && !f.valid) return fail(TwoViewFailure::NoModel, "every RANSAC hypothesis was degenerate");
  const double scoreSum = h.score + f.score;
  if (!(scoreSum > 0.0)) return fail(TwoViewFailure::NoModel, "no RANSAC hypothesis has any inlier");
  result.ratioH = h.score / scoreSum;
  const bool useH = result.ratioH > params_.homographyRatioThreshold;
  result.model = useH ? TwoViewModel::Homography : TwoViewModel::Fundamental;
  const RansacOutcome& chosen = useH ? h : f;
  result.inliers = chosen.inliers;

  std::ostringstream info;
  info << toString(result.model) << " (R_H = " << result.ratioH << ", S_H = " << h.score << ", S_F = " << f.score
       << ", inliers H/F = " << h.numInliers << "/" << f.numInliers << ")";

  const Eigen::Matrix3d K = camera_.K();
  std::vector<Candidate> candidates;
  if (useH) {
    candidates = decomposeHomography(camera_.Kinv() * h.model * K);
    if (candidates.empty()) {
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(camera_.Kinv() * h.model * K);
      const Eigen::Vector3d d = svd.singularValues();
      // All three singular values equal: H is a pure rotation (no translation, no parallax).
      if (d(0) / d(2) < 1.00001) return fail(TwoViewFailure::LowParallax, info.str() + ": homography is a pure rotation");
      return fail(TwoViewFailure::NoModel, info.str() + ": homography decomposition is degenerate (two equal singular values)");
    }
  } else {
    candidates = decomposeEssential(K.transpose() * f.model * K);  // eq. 2.40
  }

  const double th2 = 4.0 * params_.sigma * params_.sigma;
  std::vector<CandidateCheck> checks;
  checks.reserve(candidates.size());
  for (const auto& [R, t] : candidates) checks.push_back(checkCandidate(R, t, x1, x2, chosen.inliers, K, th2));

  std::size_t bestIdx = 0;
  int secondBest = 0;
  for (std::size_t i = 1; i < checks.size(); ++i) {
    if (checks[i].numGood > checks[bestIdx].numGood) bestIdx = i;
  }
  for (std::size_t i = 0; i < checks.size(); ++i) {
    if (i != bestIdx) secondBest = std::max(secondBest, checks[i].numGood);
  }
  info << "; best of " << candidates.size() << " decompositions: " << checks[bestIdx].numGood
       << " good points, second " << secondBest;

  // A plane seen by a camera moving parallel to it has a twin decomposition that explains every point on the
  // plane as well as the true one (a car driving straight over a road: both put the road in front of both
  // cameras). The matches off the plane (H outliers) satisfy only the true motion's epipolar geometry, so they
  // decide between the tied decompositions; the winner's points then come from every match.
  CandidateCheck best = checks[bestIdx];
  const bool tiedH = useH && !(secondBest < params_.secondBestFractionH * checks[bestIdx].numGood);
  if (tiedH && params_.minOffPlaneSupportH > 0) {
    // Each match is judged on its own, so a check over every match counts the H inliers exactly as `checks` did
    // and the off-plane matches on top of them.
    const std::vector<bool> everyMatch(n, true);
    std::size_t winner = bestIdx;
    int winnerGood = -1, rivalGood = 0;
    CandidateCheck winnerCheck;
    for (std::size_t i = 0; i < checks.size(); ++i) {
      if (checks[i].numGood < params_.secondBestFractionH * checks[bestIdx].numGood) continue;  // not tied
      const auto& [R, t] = candidates[i];
      CandidateCheck all = checkCandidate(R, t, x1, x2, everyMatch, K, th2);
      const int good = all.numGood - checks[i].numGood;  // off-plane matches triangulated
      if (good > winnerGood) {
        rivalGood = std::max(rivalGood, winnerGood);
        winnerGood = good;
        winner = i;
        winnerCheck = std::move(all);
      } else {
        rivalGood = std::max(rivalGood, good);
      }
    }
    info << "; tied decompositions, off-plane matches triangulated " << winnerGood << " / " << rivalGood;
    if (winnerGood >= params_.minOffPlaneSupportH && 2 * rivalGood < winnerGood) {
      bestIdx = winner;
      best = std::move(winnerCheck);
      result.twinResolved = true;
      result.offPlaneGood = winnerGood;
      result.offPlaneGoodTwin = rivalGood;
      info << " (resolved: " << best.numGood << " good points)";
    }
  }
  Eigen::Matrix3d R21 = candidates[bestIdx].first;
  Eigen::Vector3d t21 = candidates[bestIdx].second;
  info << ", parallax " << best.parallaxDeg << " deg";

  // Refine the best F-based solution before judging it: the acceptance rules count points that
  // re-project within 2 sigma, which a linear estimate misses at 0.5-1 px noise. Two rounds, because the
  // refined pose admits points the first round did not use. Only the F path is refined: on planar scenes
  // the Sampson error is ill-conditioned, and a refinement of the plane-induced homography over
  // (R, t/d, n) measured no gain over the refitted H decomposition, so it was not kept.
  if (params_.refinePose && !useH) {
    for (int round = 0; round < 2 && best.numGood >= 8; ++round) {
      Eigen::Matrix3d Rr = R21;
      Eigen::Vector3d tr = t21;
      if (!refineRelativePose(x1, x2, best.counted, camera_.Kinv(), params_.sigma, Rr, tr)) break;
      // The minimizer never raises the robust cost of its start, so the refined pose is kept even if
      // a point or two drops out of the 2-sigma count (the count is a hard threshold, the cost is not).
      CandidateCheck refinedCheck = checkCandidate(Rr, tr, x1, x2, chosen.inliers, K, th2);
      const bool sameSet = refinedCheck.counted == best.counted;
      R21 = Rr;
      t21 = tr;
      best = std::move(refinedCheck);
      result.refined = true;
      if (sameSet) break;  // a second round would see the same points
    }
    if (result.refined) {
      info << "; refined: " << best.numGood << " good points, parallax " << best.parallaxDeg << " deg";
    }
  }
  result.bestGood = best.numGood;
  result.secondBestGood = secondBest;
  result.parallaxDeg = best.parallaxDeg;

  const int minGood = std::max(params_.minTriangulated,
                               static_cast<int>(params_.minTriangulatedFraction * chosen.numInliers));
  if (best.numGood == 0) return fail(TwoViewFailure::TooFewTriangulated, info.str());
  // Low parallax first: without translation every decomposition looks alike, so it is the root cause.
  if (best.parallaxDeg < params_.minParallaxDeg) return fail(TwoViewFailure::LowParallax, info.str());
  if (best.numGood < minGood) return fail(TwoViewFailure::TooFewTriangulated, info.str() + ", need " + std::to_string(minGood));
  if (useH) {
    if (tiedH && !result.twinResolved) return fail(TwoViewFailure::Ambiguous, info.str());
  } else {
    int similar = 1;  // the best itself
    for (std::size_t i = 0; i < checks.size(); ++i) {
      if (i != bestIdx && checks[i].numGood > params_.similarSolutionFractionF * best.numGood) ++similar;
    }
    if (similar > 1) return fail(TwoViewFailure::Ambiguous, info.str());
  }
  const CandidateCheck* accepted = &best;

  result.success = true;
  result.failure = TwoViewFailure::None;
  result.R_cur_ref = R21;
  result.t_cur_ref = t21;
  result.parallaxDeg = accepted->parallaxDeg;
  result.points_ref = accepted->points;
  result.triangulated = accepted->good;
  result.numTriangulated = static_cast<int>(std::count(accepted->good.begin(), accepted->good.end(), true));
  result.message = info.str();
  return result;
}

}  // namespace pslam::geometry
