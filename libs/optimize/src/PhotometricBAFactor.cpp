#include "pslam/optimize/PhotometricBAFactor.h"

#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <ceres/cost_function.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/PoseParameterization.h"

namespace pslam::optimize {

namespace {

/// R(q) v for a quaternion block (x, y, z, w) with the unit-quaternion formula Eigen uses for q * v and
/// toRotationMatrix(): f(q, v) = v + 2 w (u x v) + 2 u (u . v) - 2 |u|^2 v, u = (x, y, z) -- and its
/// derivative w.r.t. (x, y, z, w): df/du = -2 w [v]x + 2 ((u . v) I + u v^T) - 4 v u^T, df/dw = 2 u x v.
Eigen::Vector3d rotate(const Eigen::Vector3d& u, double w, const Eigen::Vector3d& v, Eigen::Matrix<double, 3, 4>* d) {
  const Eigen::Vector3d uxv = u.cross(v);
  const double uv = u.dot(v);
  if (d) {
    Eigen::Matrix3d skewV;
    skewV << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
    d->leftCols<3>() = -2.0 * w * skewV + 2.0 * (uv * Eigen::Matrix3d::Identity() + u * v.transpose()) -
                       4.0 * v * u.transpose();
    d->col(3) = 2.0 * uxv;
  }
  return v + 2.0 * w * uxv + 2.0 * uv * u - 2.0 * u.squaredNorm() * v;
}

/// The photometric cost of PhotometricError.h over [pose_i 7, pose_j 7, rho 1, (affine_i 2), (affine_j 2)] with
/// analytic Jacobians w.r.t. those (ambient) parameters. With
///   y_k = m_k - rho_z t_i,  w_k = R_i^T y_k,  q_k = R_j w_k + rho_z t_j,  u_k = pi(q_k),
///   e_k = I_j(u_k) - b_j - e^{a_j - a_i} (I_i,k - b_i),   r_k = sqrt(eta_P / eta_R) e_k:
///   dr/dq_k = w g_k^T dpi/dq;  dq/dq_j = df(q_j, w_k);  dq/dt_j = rho_z I;  dq/dw = R_j;
///   dw/du_i = -df/du(q_i*, y_k), dw/dw_i = df/dw(q_i*, y_k) (R_i^T = R(q_i*), q_i* = (-u_i, w_i));
///   dw/dt_i = -rho_z R_i^T;  dq/drho = (R_j R_i^T (-t_i) + t_j) / b_z.
class PhotometricBACost : public ceres::CostFunction {
 public:
  std::array<Eigen::Vector3d, kPatternSize> rays;  ///< m_k at the level
  std::array<double, kPatternSize> host{};         ///< I_i at the pattern
  double bearingZ = 1.0;
  geometry::PinholeCamera camera;                    ///< of the level
  std::shared_ptr<const ImagePyramid> image;       ///< keeps the target image alive
  const cv::Mat* target = nullptr;                 ///< the level of `image`
  AffineBrightness hostFixed, targetFixed;
  bool hostFree = false, targetFree = false;
  double whitening = 1.0;

  void setBlocks() {
    set_num_residuals(kPatternSize);
    std::vector<int32_t>* sizes = mutable_parameter_block_sizes();
    *sizes = {kPoseSize, kPoseSize, 1};
    if (hostFree) sizes->push_back(2);
    if (targetFree) sizes->push_back(2);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* pi = parameters[0];
    const double* pj = parameters[1];
    const double rho = parameters[2][0];
    int next = 3;
    const double* ai = hostFree ? parameters[next++] : nullptr;
    const double* aj = targetFree ? parameters[next++] : nullptr;
    const AffineBrightness A_i = ai ? AffineBrightness{ai[0], ai[1]} : hostFixed;
    const AffineBrightness A_j = aj ? AffineBrightness{aj[0], aj[1]} : targetFixed;
    const Eigen::Vector3d ui(pi[0], pi[1], pi[2]), uj(pj[0], pj[1], pj[2]);
    const Eigen::Map<const Eigen::Vector3d> ti(pi + 4), tj(pj + 4);
    const double wi = pi[3], wj = pj[3];
    const double rhoZ = rho / bearingZ;
    const double ratio = std::exp(A_j.a - A_i.a);  // e^{a_j - a_i}
    const bool wantJ = jacobians != nullptr;
    // R_i^T and R_j as matrices (columns = rotated unit vectors) for the chain rule.
    Eigen::Matrix3d RiT, Rj;
    if (wantJ)
      for (int c = 0; c < 3; ++c) {
        RiT.col(c) = rotate(-ui, wi, Eigen::Vector3d::Unit(c), nullptr);
        Rj.col(c) = rotate(uj, wj, Eigen::Vector3d::Unit(c), nullptr);
      }
    const Eigen::Vector3d tiInTarget = wantJ ? Eigen::Vector3d(rotate(uj, wj, rotate(-ui, wi, ti, nullptr), nullptr)) : Eigen::Vector3d::Zero();
    for (int k = 0; k < kPatternSize; ++k) {
      const std::size_t s = static_cast<std::size_t>(k);
      const Eigen::Vector3d y = rays[s] - rhoZ * ti;
      Eigen::Matrix<double, 3, 4> dWdQi, dQdQj;
      const Eigen::Vector3d w = rotate(-ui, wi, y, wantJ ? &dWdQi : nullptr);  // R_i^T y
      const Eigen::Vector3d q = rotate(uj, wj, w, wantJ ? &dQdQj : nullptr) + rhoZ * tj;
      if (!(q.z() > 1e-12)) return false;
      const double iz = 1.0 / q.z();
      const double ux = camera.fx * q.x() * iz + camera.cx, uy = camera.fy * q.y() * iz + camera.cy;
      Eigen::Vector2d g;
      const double I = sampleBilinear(*target, ux, uy, &g);
      const double hostTerm = host[s] - A_i.b;
      residuals[k] = whitening * (I - A_j.b - ratio * hostTerm);
      if (!wantJ) continue;
      const double gx = whitening * g.x() * camera.fx * iz, gy = whitening * g.y() * camera.fy * iz;
      const Eigen::RowVector3d dRdq(gx, gy, -(gx * q.x() + gy * q.y()) * iz);  // w g^T dpi/dq
      if (jacobians[0]) {  // host pose: (x, y, z) of q_i* are -u_i
        Eigen::Map<Eigen::Matrix<double, kPatternSize, kPoseSize, Eigen::RowMajor>> J(jacobians[0]);
        const Eigen::RowVector3d dRdw = dRdq * Rj;
        J.block<1, 3>(k, 0) = -dRdw * dWdQi.leftCols<3>();
        J(k, 3) = dRdw * dWdQi.col(3);
        J.block<1, 3>(k, 4) = -rhoZ * dRdw * RiT;
      }
      if (jacobians[1]) {
        Eigen::Map<Eigen::Matrix<double, kPatternSize, kPoseSize, Eigen::RowMajor>> J(jacobians[1]);
        J.block<1, 4>(k, 0) = dRdq * dQdQj;
        J.block<1, 3>(k, 4) = rhoZ * dRdq;
      }
      if (jacobians[2]) jacobians[2][k] = dRdq.dot(tj - tiInTarget) / bearingZ;
      int block = 3;
      if (hostFree) {
        if (jacobians[block]) {
          jacobians[block][2 * k] = whitening * ratio * hostTerm;  // d/da_i
          jacobians[block][2 * k + 1] = whitening * ratio;         // d/db_i
        }
        ++block;
      }
      if (targetFree && jacobians[block]) {
        jacobians[block][2 * k] = -whitening * ratio * hostTerm;  // d/da_j
        jacobians[block][2 * k + 1] = -whitening;                 // d/db_j
      }
    }
    return true;
  }
};

bool isFree(const std::shared_ptr<AffineBlock>& a) { return a != nullptr && !a->fixed; }
AffineBrightness valueOf(const std::shared_ptr<AffineBlock>& a) { return a ? a->value() : AffineBrightness{}; }

}  // namespace

PhotometricBAFactor::PhotometricBAFactor(std::shared_ptr<DirectLandmark> point, map::KeyFrameId target,
                                         std::shared_ptr<const ImagePyramid> targetImage,
                                         const geometry::PinholeCamera& camera, std::shared_ptr<AffineBlock> hostAffine,
                                         std::shared_ptr<AffineBlock> targetAffine, int level,
                                         const PhotometricParams& params)
    : point_(std::move(point)),
      target_(target),
      image_(std::move(targetImage)),
      camera_(camera),
      hostAffine_(std::move(hostAffine)),
      targetAffine_(std::move(targetAffine)),
      level_(level),
      params_(params) {
  const std::string ctx = "PhotometricBAFactor";
  require(point_ != nullptr && image_ != nullptr, ctx, "null point or target image");
  require(target_ != point_->host, ctx, "target keyframe " + std::to_string(target) + " is the point's host");
  require(level >= 0 && level < image_->levels() && point_->usableAt(level), ctx,
          "level " + std::to_string(level) + " beyond the target pyramid or the point's host intensities");
  require(hostAffine_ == nullptr || hostAffine_ != targetAffine_, ctx, "host and target share one affine block");
  params_.check();
}

std::vector<double*> PhotometricBAFactor::sharedBlocks() const {
  std::vector<double*> blocks;
  if (isFree(hostAffine_)) blocks.push_back(hostAffine_->ab.data());
  if (isFree(targetAffine_)) blocks.push_back(targetAffine_->ab.data());
  return blocks;
}

ceres::CostFunction* PhotometricBAFactor::newCostFunction() const {
  auto* cost = new PhotometricBACost;
  cost->rays = patternRays(*point_, camera_, level_);
  const std::vector<double>& host = point_->hostIntensities[static_cast<std::size_t>(level_)];
  std::copy(host.begin(), host.end(), cost->host.begin());
  cost->bearingZ = point_->bearing.z();
  cost->camera = levelCamera(camera_, level_);
  cost->image = image_;
  cost->target = &image_->level(level_);
  cost->hostFixed = valueOf(hostAffine_);
  cost->targetFixed = valueOf(targetAffine_);
  cost->hostFree = isFree(hostAffine_);
  cost->targetFree = isFree(targetAffine_);
  cost->whitening = params_.whiteningScale();  // sqrt(eta_P / eta_R), eq. 3.6 with Table 3.2
  cost->setBlocks();
  return cost;
}

}  // namespace pslam::optimize
