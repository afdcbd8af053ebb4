#pragma once
// The observation-kind extension point of pose optimization. ORB keypoint reprojections are the built-in
// kind (PoseObservation); any other landmark kind -- a DSO-style direct patch with its photometric error
// (thesis Table 3.2, eq. 3.4), a line segment with its point-to-line error (eq. 2.59) -- joins the same
// motion-only optimization by implementing PoseFactor: its whitened residual and Jacobian are stacked into
// the same 6x6 normal equations, robustified with its own Huber delta and classified with its own
// chi-square threshold in every round, exactly like a keypoint.
#include <cmath>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pslam::optimize {

/// Robust cost and Gauss-Newton system of a motion-only optimization in xi = (omega, v) (PoseOptimizer).
struct PoseNormalEquations {
  double cost = 0.0;  ///< 0.5 * sum rho(s)
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();

  /// Adds one whitened residual block r (Jacobian J, rows x 6) with the Huber weight of `huberDelta` (as
  /// ceres::HuberLoss: rho(s) = s for s <= d^2, 2 d sqrt(s) - d^2 beyond; weight rho'(s), i.e. IRLS); no robust
  /// loss when huberDelta <= 0.
  template <class Residual, class Jacobian>
  void add(const Residual& r, const Jacobian& J, double huberDelta) {
    const double d2 = huberDelta * huberDelta;
    const double s = r.squaredNorm();
    double w = 1.0, rho = s;
    if (huberDelta > 0.0 && s > d2) {
      const double e = std::sqrt(s);
      rho = 2.0 * huberDelta * e - d2;
      w = huberDelta / e;
    }
    cost += 0.5 * rho;
    H.noalias() += w * J.transpose() * J;
    g.noalias() += w * J.transpose() * r;
  }
};

class PoseFactor {
 public:
  virtual ~PoseFactor() = default;
  /// Name of the observation kind ("direct", "line", ...), for reports.
  virtual std::string kind() const = 0;
  /// Residual dimension (constant per factor).
  virtual int dimension() const = 0;
  /// Whitened residual at T_cam_world (resized to dimension()) and, when `jacobian` is given, its derivative
  /// (dimension() x 6) w.r.t. xi = (omega, v) of the left perturbation T <- Exp(xi) T (retractPoseLeft).
  /// Returns false when the observation is not valid at T (e.g. behind the camera): it then counts as outlier.
  virtual bool evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                        Eigen::MatrixXd* jacobian) const = 0;
  /// Huber delta on the whitened residual norm (robust rounds); <= 0: no robust loss.
  virtual double huberDelta() const = 0;
  /// Squared whitened residual above which the observation is an outlier.
  virtual double chi2Threshold() const = 0;

  /// Adds this factor's robust cost and Gauss-Newton terms at T_cam_world to `eq` (Huber delta `huberDelta`);
  /// false, adding nothing, when it is not valid there. The default goes through evaluate(); a factor with a
  /// fixed residual size overrides it to spare the dynamic-size matrix products.
  virtual bool addTo(PoseNormalEquations& eq, const Eigen::Isometry3d& T_cam_world, double huberDelta) const;
  /// Squared whitened residual at T_cam_world in `chi2`; false when the factor is not valid there. The default
  /// goes through evaluate().
  virtual bool squaredResidual(const Eigen::Isometry3d& T_cam_world, double& chi2) const;
};

}  // namespace pslam::optimize
