#include "pslam/lines/LineFactors.h"

#include <ceres/autodiff_cost_function.h>

#include "pslam/core/Error.h"

namespace pslam::lines {

LinePoseFactor::LinePoseFactor(const Line3& line, const Eigen::Vector2d& observedStart,
                               const Eigen::Vector2d& observedEnd, const geometry::PinholeCamera& camera,
                               double pixelSigma)
    : world_(line), camera_(camera), invSigma_(1.0 / pixelSigma) {
  require(pixelSigma > 0.0 && std::isfinite(pixelSigma), "LinePoseFactor", "pixelSigma must be > 0");
  require((observedEnd - observedStart).norm() > 1e-9, "LinePoseFactor", "observed segment has coincident endpoints");
  line_ = imageLine(observedStart, observedEnd);
}

bool LinePoseFactor::evaluate(const Eigen::Isometry3d& T, Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian) const {
  residual.setZero(2);
  if (jacobian) jacobian->setZero(2, 6);
  const Eigen::Vector3d ends[2] = {T * world_.start, T * world_.end};
  bool ok = true;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d& pc = ends[i];
    if (!(pc.z() > 1e-12)) {
      ok = false;
      continue;
    }
    const double iz = 1.0 / pc.z();
    const Eigen::Vector2d uv(camera_.fx * pc.x() * iz + camera_.cx, camera_.fy * pc.y() * iz + camera_.cy);
    residual[i] = invSigma_ * lineDistance(line_, uv);
    if (jacobian) {
      // (1/sigma) [l_a l_b] dpi/dX_c, then d(X_c)/d(xi) = [ -[X_c]x | I ].
      const Eigen::RowVector3d g(invSigma_ * line_.x() * camera_.fx * iz, invSigma_ * line_.y() * camera_.fy * iz,
                                 -invSigma_ * (line_.x() * camera_.fx * pc.x() + line_.y() * camera_.fy * pc.y()) * iz * iz);
      Eigen::Matrix3d minusSkew;
      minusSkew << 0.0, pc.z(), -pc.y(), -pc.z(), 0.0, pc.x(), pc.y(), -pc.x(), 0.0;
      jacobian->block<1, 3>(i, 0) = g * minusSkew;
      jacobian->block<1, 3>(i, 3) = g;
    }
  }
  return ok;
}

bool LineEndpointsManifold::basis(const double* x, Eigen::Vector3d& u, Eigen::Vector3d& w) {
  const Eigen::Vector3d P(x[0], x[1], x[2]), Q(x[3], x[4], x[5]);
  const Eigen::Vector3d d = Q - P;
  const double n = d.norm();
  if (!(n > 1e-12)) return false;
  const Eigen::Vector3d dn = d / n;
  // The axis least aligned with d gives a well-conditioned first perpendicular.
  Eigen::Index axis = 0;
  dn.cwiseAbs().minCoeff(&axis);
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
  u = dn.cross(e).normalized();
  w = dn.cross(u);
  return true;
}

bool LineEndpointsManifold::Plus(const double* x, const double* delta, double* out) const {
  Eigen::Vector3d u, w;
  if (!basis(x, u, w)) return false;
  for (int k = 0; k < 3; ++k) {
    out[k] = x[k] + u[k] * delta[0] + w[k] * delta[1];
    out[k + 3] = x[k + 3] + u[k] * delta[2] + w[k] * delta[3];
  }
  return true;
}

bool LineEndpointsManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Vector3d u, w;
  if (!basis(x, u, w)) return false;
  Eigen::Map<Eigen::Matrix<double, 6, 4, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<3, 1>(0, 0) = u;
  J.block<3, 1>(0, 1) = w;
  J.block<3, 1>(3, 2) = u;
  J.block<3, 1>(3, 3) = w;
  return true;
}

bool LineEndpointsManifold::Minus(const double* y, const double* x, double* out) const {
  Eigen::Vector3d u, w;
  if (!basis(x, u, w)) return false;
  const Eigen::Vector3d dP(y[0] - x[0], y[1] - x[1], y[2] - x[2]), dQ(y[3] - x[3], y[4] - x[4], y[5] - x[5]);
  out[0] = u.dot(dP);
  out[1] = w.dot(dP);
  out[2] = u.dot(dQ);
  out[3] = w.dot(dQ);
  return true;
}

bool LineEndpointsManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Vector3d u, w;
  if (!basis(x, u, w)) return false;
  Eigen::Map<Eigen::Matrix<double, 4, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<1, 3>(0, 0) = u.transpose();
  J.block<1, 3>(1, 0) = w.transpose();
  J.block<1, 3>(2, 3) = u.transpose();
  J.block<1, 3>(3, 3) = w.transpose();
  return true;
}

LineBAFactor::LineBAFactor(std::shared_ptr<LineLandmark> landmark, map::KeyFrameId keyframe,
                           const Eigen::Vector2d& observedStart, const Eigen::Vector2d& observedEnd,
                           const geometry::PinholeCamera& camera, double pixelSigma)
    : landmark_(std::move(landmark)), keyframe_(keyframe) {
  require(landmark_ != nullptr, "LineBAFactor", "null landmark");
  require(pixelSigma > 0.0 && std::isfinite(pixelSigma), "LineBAFactor", "pixelSigma must be > 0");
  require((observedEnd - observedStart).norm() > 1e-9, "LineBAFactor", "observed segment has coincident endpoints");
  cost_ = {imageLine(observedStart, observedEnd), camera.fx, camera.fy, camera.cx, camera.cy, 1.0 / pixelSigma};
}

ceres::CostFunction* LineBAFactor::newCostFunction() const {
  return new ceres::AutoDiffCostFunction<LineReprojectionCost, 2, optimize::kPoseSize, 6>(
      new LineReprojectionCost(cost_));
}

}  // namespace pslam::lines
