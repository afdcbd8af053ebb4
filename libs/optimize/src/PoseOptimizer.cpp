#include "pslam/optimize/PoseOptimizer.h"

#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "pslam/core/Error.h"

namespace pslam::optimize {

bool poseOnlyResidual(const Eigen::Isometry3d& T_cam_world, const geometry::PinholeCamera& camera,
                      const PoseObservation& o, Eigen::Vector2d& residual, Eigen::Matrix<double, 2, 6>* jacobian) {
  const Eigen::Vector3d pc = T_cam_world * o.p_world;
  const double z = pc.z();
  if (!(std::abs(z) > 1e-12)) return false;
  const double s = std::sqrt(o.invSigma2), iz = 1.0 / z;
  residual.x() = s * (camera.fx * pc.x() * iz + camera.cx - o.pixel.x());
  residual.y() = s * (camera.fy * pc.y() * iz + camera.cy - o.pixel.y());
  if (jacobian) {
    // d(pi(pc))/d(pc) (whitened) times d(pc)/d(xi) = [-[pc]x | I] for the left perturbation T <- Exp(xi) T.
    Eigen::Matrix<double, 2, 3> Jp;
    Jp << s * camera.fx * iz, 0.0, -s * camera.fx * pc.x() * iz * iz, 0.0, s * camera.fy * iz,
        -s * camera.fy * pc.y() * iz * iz;
    Eigen::Matrix3d minusSkew;
    minusSkew << 0.0, pc.z(), -pc.y(), -pc.z(), 0.0, pc.x(), pc.y(), -pc.x(), 0.0;
    jacobian->leftCols<3>() = Jp * minusSkew;
    jacobian->rightCols<3>() = Jp;
  }
  return z > 0.0;
}

Eigen::Isometry3d retractPoseLeft(const Eigen::Matrix<double, 6, 1>& xi, const Eigen::Isometry3d& T_cam_world) {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d omega = xi.head<3>();
  const double angle = omega.norm();
  if (angle > 0.0) delta.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  delta.translation() = xi.tail<3>();
  Eigen::Isometry3d T = delta * T_cam_world;
  // Keep the rotation orthonormal to machine precision over many updates.
  T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return T;
}

namespace {

/// Robust cost and Gauss-Newton system of the active observations at T.
using Linearization = PoseNormalEquations;

using Factors = std::vector<std::shared_ptr<const PoseFactor>>;

Linearization linearize(const Eigen::Isometry3d& T, const geometry::PinholeCamera& camera,
                        const std::vector<PoseObservation>& obs, const std::vector<bool>& excluded, double huberDelta,
                        const Factors& factors, const std::vector<bool>& factorExcluded, bool robust) {
  Linearization L;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 6> J;
  for (std::size_t i = 0; i < obs.size(); ++i) {
    if (excluded[i]) continue;
    poseOnlyResidual(T, camera, obs[i], r, &J);
    L.add(r, J, huberDelta);
  }
  for (std::size_t i = 0; i < factors.size(); ++i)
    if (!factorExcluded[i]) factors[i]->addTo(L, T, robust ? factors[i]->huberDelta() : 0.0);
  return L;
}

double chi2At(const Eigen::Isometry3d& T, const geometry::PinholeCamera& cam, const PoseObservation& o, bool& inFront) {
  Eigen::Vector2d r;
  inFront = poseOnlyResidual(T, cam, o, r, nullptr);
  return r.squaredNorm();
}

/// Levenberg-Marquardt on the 6x6 normal equations (what g2o does for ORB-SLAM's PoseOptimization). A Ceres
/// problem per round cost ~3 ms per call at 1000 correspondences, mostly per-problem set-up; this loop ~0.3 ms.
Eigen::Isometry3d levenbergMarquardt(const Eigen::Isometry3d& start, const geometry::PinholeCamera& camera,
                                     const std::vector<PoseObservation>& obs, const std::vector<bool>& excluded,
                                     double huberDelta, int maxIterations, const Factors& factors,
                                     const std::vector<bool>& factorExcluded, PoseFreedom freedom) {
  const bool robust = huberDelta > 0.0;
  auto lin = [&](const Eigen::Isometry3d& T) {
    Linearization L = linearize(T, camera, obs, excluded, huberDelta, factors, factorExcluded, robust);
    if (freedom == PoseFreedom::TranslationOnly) {
      // Rotation held: its rows/columns leave the system, so the rotation part of every step is zero.
      L.H.topRows<3>().setZero();
      L.H.leftCols<3>().setZero();
      L.H.topLeftCorner<3, 3>().setIdentity();
      L.g.head<3>().setZero();
    }
    return L;
  };
  Eigen::Isometry3d T = start;
  Linearization L = lin(T);
  double lambda = 1e-4;
  for (int it = 0; it < maxIterations; ++it) {
    Eigen::Matrix<double, 6, 6> A = L.H;
    A.diagonal() += lambda * L.H.diagonal().cwiseMax(1e-9);
    const Eigen::Matrix<double, 6, 1> xi = A.ldlt().solve(-L.g);
    if (!xi.allFinite()) break;
    const Eigen::Isometry3d Tn = retractPoseLeft(xi, T);
    Linearization Ln = lin(Tn);
    if (Ln.cost < L.cost) {
      const double decrease = L.cost - Ln.cost;
      T = Tn;
      L = std::move(Ln);
      lambda = std::max(lambda * 0.1, 1e-12);
      // Iterations are cheap here: converge further than Ceres' default function tolerance (1e-6), so the
      // result depends less on where the iterations stop.
      if (decrease <= 1e-10 * (L.cost + decrease) || xi.norm() < 1e-12) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e12) break;
    }
  }
  return T;
}

}  // namespace

PoseOptimizationResult optimizePose(const Eigen::Isometry3d& T_cam_world_initial, const geometry::PinholeCamera& camera,
                                    const std::vector<PoseObservation>& observations,
                                    const PoseOptimizationParams& params, const std::vector<bool>& initialOutliers,
                                    const Factors& factors, PoseFreedom freedom) {
  params.check();
  camera.check("optimizePose: camera");
  require(T_cam_world_initial.matrix().allFinite(), "optimizePose", "initial pose has NaN/Inf entries");
  require(initialOutliers.empty() || initialOutliers.size() == observations.size(), "optimizePose",
          "initialOutliers must be empty or one flag per observation");
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const PoseObservation& o = observations[i];
    require(o.p_world.allFinite() && o.pixel.allFinite() && std::isfinite(o.invSigma2) && o.invSigma2 > 0.0,
            "optimizePose", "observation " + std::to_string(i) + " has a NaN/Inf value or non-positive weight");
  }

  for (std::size_t i = 0; i < factors.size(); ++i)
    require(factors[i] != nullptr && factors[i]->dimension() > 0, "optimizePose",
            "factor " + std::to_string(i) + " is null or has no residual");

  PoseOptimizationResult result;
  result.T_cam_world = T_cam_world_initial;
  result.factorOutlier.assign(factors.size(), false);
  result.outlier = initialOutliers.empty() ? std::vector<bool>(observations.size(), false) : initialOutliers;
  if (static_cast<int>(observations.size() + factors.size()) < params.minCorrespondences) {
    result.inliers = 0;
    return result;
  }

  // Chi-square and inlier flag of every observation and factor at a pose. Each round classifies at its
  // solution; the last round's classification is the returned one (the pose does not change after it).
  std::vector<double> chi2(observations.size()), factorChi2(factors.size());
  auto classify = [&](const Eigen::Isometry3d& T) {
    int inliers = 0;
    for (std::size_t i = 0; i < observations.size(); ++i) {
      bool inFront = false;
      chi2[i] = chi2At(T, camera, observations[i], inFront);
      result.outlier[i] = !(chi2[i] <= params.chi2Threshold) || !inFront;
      inliers += result.outlier[i] ? 0 : 1;
    }
    for (std::size_t i = 0; i < factors.size(); ++i) {
      const bool valid = factors[i]->squaredResidual(T, factorChi2[i]);
      result.factorOutlier[i] = !(factorChi2[i] <= factors[i]->chi2Threshold()) || !valid;
      inliers += result.factorOutlier[i] ? 0 : 1;
    }
    return inliers;
  };

  Eigen::Isometry3d solved = T_cam_world_initial;  // the estimate of the last round actually solved
  bool classifiedAtSolved = false;
  for (int round = 0; round < params.rounds; ++round) {
    int used = 0;
    for (bool out : result.outlier) used += out ? 0 : 1;
    for (bool out : result.factorOutlier) used += out ? 0 : 1;
    if (used < params.minCorrespondences) break;
    // ORB-SLAM restarts every round from the initial estimate, only the inlier set changes.
    solved = levenbergMarquardt(T_cam_world_initial, camera, observations, result.outlier,
                                round < params.robustRounds ? params.huberDelta : 0.0, params.iterationsPerRound,
                                factors, result.factorOutlier, freedom);
    result.roundsRun = round + 1;
    const int inliers = classify(solved);
    classifiedAtSolved = true;
    if (inliers < params.minInliersToContinue) break;
  }

  // Classification and chi-square at the returned pose.
  result.T_cam_world = solved;
  if (!classifiedAtSolved) classify(solved);
  result.inliers = 0;
  result.finalChi2Sum = 0.0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (result.outlier[i]) continue;
    ++result.inliers;
    result.finalChi2Sum += chi2[i];
  }
  for (std::size_t i = 0; i < factors.size(); ++i) {
    if (result.factorOutlier[i]) continue;
    ++result.inliers;
    result.finalChi2Sum += factorChi2[i];
  }
  return result;
}

}  // namespace pslam::optimize
