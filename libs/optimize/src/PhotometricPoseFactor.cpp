#include "pslam/optimize/PhotometricPoseFactor.h"

#include <algorithm>
#include <string>

#include "pslam/core/Error.h"

namespace pslam::optimize {

PhotometricPoseFactor::PhotometricPoseFactor(std::shared_ptr<const DirectLandmark> point,
                                             const Eigen::Isometry3d& T_host_world, const AffineBrightness& hostAffine,
                                             std::shared_ptr<const ImagePyramid> target,
                                             const AffineBrightness& targetAffine, const geometry::PinholeCamera& camera,
                                             int level, const PhotometricParams& params)
    : point_(std::move(point)),
      T_host_world_(T_host_world),
      T_world_host_(T_host_world.inverse()),
      hostAffine_(hostAffine),
      targetAffine_(targetAffine),
      target_(std::move(target)),
      camera_(camera),
      level_(level),
      params_(params) {
  const std::string ctx = "PhotometricPoseFactor";
  require(point_ != nullptr && target_ != nullptr, ctx, "null point or target image");
  require(level >= 0 && level < target_->levels() && level < point_->levels(), ctx,
          "level " + std::to_string(level) + " beyond the target pyramid or the point's host intensities");
  require(T_host_world.matrix().allFinite(), ctx, "host pose has NaN/Inf entries");
  params_.check();
  rays_ = patternRays(*point_, camera_, level_);
}

std::shared_ptr<PhotometricPoseFactor> PhotometricPoseFactor::atLevel(int level) const {
  return std::make_shared<PhotometricPoseFactor>(point_, T_host_world_, hostAffine_, target_, targetAffine_, camera_,
                                                 level, params_);
}

PatternError PhotometricPoseFactor::patternError(const Eigen::Isometry3d& T_target_world) const {
  return evaluatePattern(*point_, level_, rays_, T_target_world * T_world_host_, point_->inverseDepth,
                         camera_, target_->level(level_), hostAffine_, targetAffine_);
}

bool PhotometricPoseFactor::evaluateFixed(const Eigen::Isometry3d& T_cam_world, Residual& residual,
                                          Jacobian* jacobian) const {
  const PatternError pe = patternError(T_cam_world);
  const double w = params_.whiteningScale();  // sqrt(eta_P / eta_R), eq. 3.6 with Table 3.2
  residual = w * pe.e;
  if (jacobian) {
    jacobian->setZero();
    if (pe.valid) {
      const geometry::PinholeCamera c = levelCamera(camera_, level_);
      const double rhoZ = point_->inverseDepth / point_->bearing.z();
      for (int k = 0; k < kPatternSize; ++k) {
        const std::size_t i = static_cast<std::size_t>(k);
        const Eigen::Vector3d& q = pe.q[i];
        const double iz = 1.0 / q.z();
        // g_k^T dpi/dq (1x3), whitened.
        const double gx = w * pe.gradient[i].x() * c.fx * iz, gy = w * pe.gradient[i].y() * c.fy * iz;
        const Eigen::RowVector3d dq(gx, gy, -(gx * q.x() + gy * q.y()) * iz);
        // d(q)/d(xi) = [-[q]x | rho_z I] for T <- Exp(xi) T (q = rho_z * T_target_world * X_world).
        jacobian->block<1, 3>(k, 0) = q.cross(dq.transpose()).transpose();  // dq * (-[q]x) = (q x dq^T)^T
        jacobian->block<1, 3>(k, 3) = rhoZ * dq;
      }
    }
  }
  return pe.valid;
}

bool PhotometricPoseFactor::evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                                     Eigen::MatrixXd* jacobian) const {
  Residual r;
  Jacobian J;
  const bool valid = evaluateFixed(T_cam_world, r, jacobian ? &J : nullptr);
  residual = r;
  if (jacobian) *jacobian = J;
  return valid;
}

bool PhotometricPoseFactor::addTo(PoseNormalEquations& eq, const Eigen::Isometry3d& T_cam_world,
                                  double huberDelta) const {
  Residual r;
  Jacobian J;
  if (!evaluateFixed(T_cam_world, r, &J)) return false;
  eq.add(r, J, huberDelta);
  return true;
}

bool PhotometricPoseFactor::squaredResidual(const Eigen::Isometry3d& T_cam_world, double& chi2) const {
  Residual r;
  const bool valid = evaluateFixed(T_cam_world, r, nullptr);
  chi2 = r.squaredNorm();
  return valid;
}

PoseOptimizationResult optimizePoseCoarseToFine(const Eigen::Isometry3d& T_cam_world_initial,
                                                const geometry::PinholeCamera& camera,
                                                const std::vector<PoseObservation>& observations,
                                                const std::vector<std::shared_ptr<const PhotometricPoseFactor>>& direct,
                                                int coarsestLevel, const PoseOptimizationParams& params,
                                                const std::vector<std::shared_ptr<const PoseFactor>>& otherFactors) {
  require(coarsestLevel >= 0, "optimizePoseCoarseToFine", "coarsestLevel must be >= 0");
  for (std::size_t i = 0; i < direct.size(); ++i)
    require(direct[i] != nullptr, "optimizePoseCoarseToFine", "direct factor " + std::to_string(i) + " is null");
  Eigen::Isometry3d T = T_cam_world_initial;
  PoseOptimizationResult result;
  for (int level = coarsestLevel; level >= 0; --level) {
    std::vector<std::shared_ptr<const PoseFactor>> factors;
    factors.reserve(direct.size() + otherFactors.size());
    for (const auto& f : direct) {
      if (f->level() == level)
        factors.push_back(f);
      else if (level == 0 || f->point().usableAt(level))
        factors.push_back(f->atLevel(level));  // level 0 keeps every factor, so that indices match `direct`
    }
    factors.insert(factors.end(), otherFactors.begin(), otherFactors.end());
    // The coarse levels only bring the estimate into the basin of the finer ones: one robust round each (no
    // outlier re-classification, which the full rounds at level 0 do).
    PoseOptimizationParams levelParams = params;
    if (level > 0) {
      levelParams.rounds = 1;
      levelParams.robustRounds = std::min(1, params.robustRounds);
    }
    result = optimizePose(T, camera, observations, levelParams, {}, factors);
    T = result.T_cam_world;
  }
  return result;
}

}  // namespace pslam::optimize
