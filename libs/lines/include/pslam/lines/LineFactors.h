#pragma once
// The point-to-line reprojection error of a 3D line observed as an image segment (thesis eq. 2.59, PL-SLAM):
// the two world endpoints X_s, X_e of the line are projected with the camera pose and their distances to the
// observed infinite image line l (normalized so that l . (u, v, 1) is in pixels, eq. 2.58 through the observed
// endpoints) are the two residuals
//   r = (1 / sigma) * ( l . pi(K T X_s),  l . pi(K T X_e) ),
// whitened by the endpoint noise sigma of the detection level. Huber delta sqrt(5.991) and outlier threshold
// chi2(2 DoF, 95 %) = 5.991, as the keypoints (Table 3.2 chi_R).
//   - LinePoseFactor: the motion-only form (optimize::PoseFactor), analytic Jacobian w.r.t. the left
//     perturbation T <- Exp(xi) T:  dr_i/dxi = (1/sigma) [l_a l_b] dpi/dX_c [ -[X_c]x | I ],  X_c = T X_i.
//   - LineBAFactor: the bundle-adjustment form (optimize::BAFactor) over the keyframe pose block (7,
//     PoseParameterization.h) and the line's endpoint block (6 = [X_s; X_e], world), automatic derivatives.
//     The endpoints move on LineEndpointsManifold: each endpoint only perpendicular to the current line
//     direction (4 DoF, the degrees of freedom of a 3D line), so that the sliding of an endpoint along its
//     line, which no residual sees, is not a free direction of the Schur-eliminated landmark block.
#include <array>
#include <cmath>
#include <memory>

#include <Eigen/Geometry>
#include <ceres/manifold.h>

#include "pslam/lines/LineGeometry.h"
#include "pslam/map/Types.h"
#include "pslam/optimize/BAFactor.h"
#include "pslam/optimize/PoseFactor.h"
#include "pslam/optimize/PoseParameterization.h"

namespace pslam::lines {

inline constexpr double kLineChi2 = 5.991;                ///< chi2 with 2 DoF at 95 %
inline const double kLineHuberDelta = std::sqrt(kLineChi2);


class LinePoseFactor : public optimize::PoseFactor {
 public:
  /// World endpoints of the map line; observed segment endpoints (undistorted pixels); `pixelSigma` > 0.
  LinePoseFactor(const Line3& line, const Eigen::Vector2d& observedStart, const Eigen::Vector2d& observedEnd,
                 const geometry::PinholeCamera& camera, double pixelSigma);
  std::string kind() const override { return "line"; }
  int dimension() const override { return 2; }
  bool evaluate(const Eigen::Isometry3d& T_cam_world, Eigen::VectorXd& residual,
                Eigen::MatrixXd* jacobian) const override;
  double huberDelta() const override { return kLineHuberDelta; }
  double chi2Threshold() const override { return kLineChi2; }

 private:
  Line3 world_;
  Eigen::Vector3d line_;
  geometry::PinholeCamera camera_;
  double invSigma_;
};

/// The parameter block of a map line in BA: [X_s (3), X_e (3)] in world coordinates.
struct LineLandmark {
  std::array<double, 6> endpoints{};
  bool fixed = false;
  Line3 line() const {
    return {Eigen::Vector3d(endpoints[0], endpoints[1], endpoints[2]),
            Eigen::Vector3d(endpoints[3], endpoints[4], endpoints[5])};
  }
  void set(const Line3& l) {
    for (int k = 0; k < 3; ++k) {
      endpoints[static_cast<std::size_t>(k)] = l.start[k];
      endpoints[static_cast<std::size_t>(k + 3)] = l.end[k];
    }
  }
};

/// Endpoints moving perpendicular to the line: x = [P; Q], tangent delta (4) = the displacements of P and Q along
/// the two unit vectors u, w orthogonal to d = (Q - P) / |Q - P| (a fixed function of x).
class LineEndpointsManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 6; }
  int TangentSize() const override { return 4; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
  /// The basis (u, w) orthogonal to the line direction of x; false for coincident endpoints.
  static bool basis(const double* x, Eigen::Vector3d& u, Eigen::Vector3d& w);
};

/// Ceres functor of eq. 2.59 over [pose (7), endpoints (6)]. An endpoint behind the camera gives a constant
/// large residual (the chi-square test then rejects the factor) instead of failing the evaluation.
struct LineReprojectionCost {
  Eigen::Vector3d line;
  double fx, fy, cx, cy, invSigma;
  static constexpr double kBehindResidual = 1e3;

  template <typename T>
  bool operator()(const T* pose, const T* endpoints, T* residual) const {
    for (int i = 0; i < 2; ++i) {
      const Eigen::Matrix<T, 3, 1> X(endpoints[3 * i], endpoints[3 * i + 1], endpoints[3 * i + 2]);
      const Eigen::Matrix<T, 3, 1> pc = optimize::transformPoint(pose, X);
      if (pc.z() < T(1e-6)) {
        residual[0] = residual[1] = T(kBehindResidual);
        return true;
      }
      const T u = T(fx) * pc.x() / pc.z() + T(cx);
      const T v = T(fy) * pc.y() / pc.z() + T(cy);
      residual[i] = T(invSigma) * (T(line.x()) * u + T(line.y()) * v + T(line.z()));
    }
    return true;
  }
};

class LineBAFactor : public optimize::BAFactor {
 public:
  /// `landmark` (updated in place by BA) observed in keyframe `keyframe` as the segment (start, end).
  LineBAFactor(std::shared_ptr<LineLandmark> landmark, map::KeyFrameId keyframe, const Eigen::Vector2d& observedStart,
               const Eigen::Vector2d& observedEnd, const geometry::PinholeCamera& camera, double pixelSigma);
  std::string kind() const override { return "line"; }
  std::vector<map::KeyFrameId> keyframes() const override { return {keyframe_}; }
  std::vector<double*> landmarkBlocks() const override { return {landmark_->endpoints.data()}; }
  ceres::CostFunction* newCostFunction() const override;
  ceres::Manifold* newLandmarkManifold(std::size_t) const override { return new LineEndpointsManifold; }
  bool landmarkFixed() const override { return landmark_->fixed; }
  double huberDelta() const override { return kLineHuberDelta; }
  double chi2Threshold() const override { return kLineChi2; }

 private:
  std::shared_ptr<LineLandmark> landmark_;
  map::KeyFrameId keyframe_;
  LineReprojectionCost cost_;
};

}  // namespace pslam::lines
