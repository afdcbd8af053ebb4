#pragma once
// Epipolar geometry helpers (thesis eq. 2.10-2.12, 2.35, 2.46).
//
// Convention: F12 relates pixels of image 1 and image 2 by x1^T F12 x2 = 0 (homogeneous pixels), so
// l2 = F12^T x1 is the epipolar line of x1 in image 2 and l1 = F12 x2 the line of x2 in image 1.
// With T_12 = T_1w T_2w^-1 (maps camera-2 points into camera 1): F12 = K1^-T [t_12]x R_12 K2^-1.
#include <Eigen/Core>

namespace pslam::geometry {

/// [v]_x of eq. 2.11: skew(v) * w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

/// Essential matrix E12 = [t_12]x R_12 for the relative pose T_12 (x1^T E12 x2 = 0 on normalized points).
Eigen::Matrix3d essentialFromRelativePose(const Eigen::Matrix3d& R_12, const Eigen::Vector3d& t_12);

/// F12 from the two absolute poses T_1w, T_2w (ORB-SLAM's ComputeF12).
Eigen::Matrix3d fundamentalFromPoses(const Eigen::Matrix3d& K1, const Eigen::Matrix3d& R_1w,
                                     const Eigen::Vector3d& t_1w, const Eigen::Matrix3d& K2,
                                     const Eigen::Matrix3d& R_2w, const Eigen::Vector3d& t_2w);

/// Squared distance (pixels^2) of x2 from the epipolar line of x1 in image 2, l2 = F12^T x1 (eq. 2.46).
/// Returns +infinity when the line is degenerate (x1 at the epipole).
double epipolarDistanceSquared(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2, const Eigen::Matrix3d& F12);

/// ORB-SLAM's CheckDistEpipolarLine: accepts a candidate match when its squared distance to the
/// epipolar line is below chi2Threshold * sigma2, where sigma2 is the positional variance of the keypoint
/// in image 2 (its pyramid level's sigma^2). 3.84 = chi^2(1 dof, 95 %): the distance is one-dimensional.
bool checkDistEpipolarLine(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2, const Eigen::Matrix3d& F12,
                           double sigma2, double chi2Threshold = 3.84);

}  // namespace pslam::geometry
