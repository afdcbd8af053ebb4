#include "pslam/optimize/PoseFactor.h"

namespace pslam::optimize {

// Scratch matrices per thread: pose optimizations run on the tracking thread and, for loaded maps and tests,
// elsewhere; the sizes settle after the first factor, so no allocation per evaluation.
bool PoseFactor::addTo(PoseNormalEquations& eq, const Eigen::Isometry3d& T_cam_world, double huberDelta) const {
  thread_local Eigen::VectorXd residual;
  thread_local Eigen::MatrixXd jacobian;
  if (!evaluate(T_cam_world, residual, &jacobian)) return false;
  eq.add(residual, jacobian, huberDelta);
  return true;
}

bool PoseFactor::squaredResidual(const Eigen::Isometry3d& T_cam_world, double& chi2) const {
  thread_local Eigen::VectorXd residual;
  const bool valid = evaluate(T_cam_world, residual, nullptr);
  chi2 = residual.squaredNorm();
  return valid;
}

}  // namespace pslam::optimize
