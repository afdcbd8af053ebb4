#pragma once
// The observation-kind extension point of pose optimization. ORB keypoint reprojections are the built-in
// kind (PoseObservation); any other landmark kind -- a DSO-style direct patch with its photometric error
// (thesis Table 3.2, eq. 3.4), a line segment with its point-to-line error (eq. 2.59) -- joins the same
// motion-only optimization by implementing PoseFactor: its whitened residual and Jacobian are stacked into
// the same 6x6 normal equations, robustified with its own Huber delta and classified with its own
// chi-square threshold in every round, exactly like a keypoint.
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pslam::optimize {

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
};

}  // namespace pslam::optimize
