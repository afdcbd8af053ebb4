#pragma once
// Linear (DLT) triangulation, thesis §2.3.2.1 eq. 2.19-2.23, and the per-point checks that the two-view
// initializer and local mapping apply to a fresh point (positive depth, parallax, re-projection error).
//
// Poses: (R_cam_world, t_cam_world) maps world points into the camera, X_cam = R X_world + t
// (T_cam_world, doc/geometry.md). Pixels are undistorted pixel coordinates of the ideal pinhole camera.
#include <vector>

#include <Eigen/Core>

namespace pslam::geometry {

using Matrix34d = Eigen::Matrix<double, 3, 4>;

/// P = K [R | t] (eq. 2.19), mapping homogeneous world points to homogeneous pixels.
Matrix34d projectionMatrix(const Eigen::Matrix3d& K, const Eigen::Matrix3d& R_cam_world,
                           const Eigen::Vector3d& t_cam_world);

/// Camera centre in world coordinates, -R^T t.
Eigen::Vector3d cameraCenter(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world);

/// N-view DLT (eq. 2.21-2.23): stacks the first two rows of [x_i]_x P_i for each view (2N x 4 system),
/// takes the right singular vector of the smallest singular value and de-homogenizes it.
/// Returns false (X_world untouched) for fewer than two views, mismatched sizes, non-finite input, or a
/// solution at infinity (|w| below 1e-12 of the vector norm, e.g. parallel rays).
bool triangulateDLT(const std::vector<Matrix34d>& projections, const std::vector<Eigen::Vector2d>& pixels,
                    Eigen::Vector3d& X_world);
/// Two-view convenience overload of the same DLT.
bool triangulateDLT(const Matrix34d& P1, const Eigen::Vector2d& pixel1, const Matrix34d& P2,
                    const Eigen::Vector2d& pixel2, Eigen::Vector3d& X_world);

/// Depth (z in the camera frame) of a world point.
double depthInCamera(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world,
                     const Eigen::Vector3d& X_world);
/// True when the point lies strictly in front of the camera.
bool hasPositiveDepth(const Eigen::Matrix3d& R_cam_world, const Eigen::Vector3d& t_cam_world,
                      const Eigen::Vector3d& X_world);

/// Cosine of the parallax angle at X between the rays to the two camera centres (ORB-SLAM's
/// cosParallax). 1 means no parallax. Returns 1 when X coincides with a centre.
double parallaxCosine(const Eigen::Vector3d& X_world, const Eigen::Vector3d& center1,
                      const Eigen::Vector3d& center2);
/// The same angle in radians, in [0, pi]. This is the angle that the depth-variance model of §2.3.3
/// (eq. 2.24-2.29, implemented in libs/landmarks) builds on.
double parallaxAngle(const Eigen::Vector3d& X_world, const Eigen::Vector3d& center1,
                     const Eigen::Vector3d& center2);

/// Squared pixel distance between the ideal projection of X_world (K, pose) and the observed pixel.
/// Returns +infinity when the point is not in front of the camera.
double reprojectionErrorSquared(const Eigen::Matrix3d& K, const Eigen::Matrix3d& R_cam_world,
                                const Eigen::Vector3d& t_cam_world, const Eigen::Vector3d& X_world,
                                const Eigen::Vector2d& pixel);

/// chi^2 test of a squared re-projection error for a keypoint with positional variance sigma2 (pixels^2,
/// the pyramid level's sigma^2). Default 5.991 = chi^2(2 dof, 95 %), as ORB-SLAM's local mapping.
bool passesReprojectionTest(double errorSquared, double sigma2, double chi2Threshold = 5.991);

}  // namespace pslam::geometry
