#pragma once
// Pinhole camera with OpenCV plumb-bob (radtan) distortion (thesis §2.3.1, eq. 2.6-2.9): the one camera type of the
// libraries. A rawlog's camera carries its distortion; keyframes, frames and the optimizer use the ideal camera of
// the undistorted keypoints (withoutDistortion()).
//
// Conventions (see doc/geometry.md):
//  - Camera frame: x right, y down, z forward (optical axis). Pixel (0,0) is the centre of the top-left pixel.
//  - The thesis assumes undistorted images: keypoints are undistorted once with undistortKeyPoints() and
//    from then on every geometric function works on the ideal pinhole model x = pi(K X) (eq. 2.7), i.e.
//    project()/unprojectToBearing() ignore the distortion coefficients.
//  - A bearing is the unit-norm direction of the ray through a pixel, in the camera frame, with z > 0.
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/img/TCamera.h>
#include <opencv2/core.hpp>

namespace pslam::geometry {

/// Axis-aligned bounds of the undistorted image in pixel coordinates (ORB-SLAM's ComputeImageBounds):
/// undistorted keypoints fall inside [minX, maxX] x [minY, maxY].
struct ImageBounds {
  double minX = 0.0, maxX = 0.0, minY = 0.0, maxY = 0.0;
  bool contains(double x, double y) const { return x >= minX && x < maxX && y >= minY && y < maxY; }
};

struct PinholeCamera {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;
  /// OpenCV plumb-bob order: k1 k2 p1 p2 k3.
  std::array<double, 5> distortion{{0.0, 0.0, 0.0, 0.0, 0.0}};

  PinholeCamera() = default;
  PinholeCamera(double fx_, double fy_, double cx_, double cy_, int width_, int height_,
                std::array<double, 5> distortion_ = {{0.0, 0.0, 0.0, 0.0, 0.0}});

  /// From MRPT intrinsics. Accepts DistortionModel::none and ::plumb_bob; plumb_bob coefficients k4..k6
  /// (rational model) and kannala_brandt are refused with a pslam::Error. The result is check()ed.
  static PinholeCamera fromTCamera(const mrpt::img::TCamera& camera);
  mrpt::img::TCamera toTCamera() const;
  /// Reads an MRPT TCamera block (keys resolution, cx, cy, fx, fy, dist, distortion_model) from `section`.
  static PinholeCamera loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);

  /// Throws pslam::Error naming the offending field for NaN/inf values, focal lengths <= 0, sizes <= 0,
  /// or a principal point outside the image.
  void check() const;
  /// The checks of a camera read from a file (a map): finite, positive focal lengths, a finite principal point,
  /// a positive size; pslam::Error "<context>: ..." otherwise.
  void check(const std::string& context) const;
  /// The same camera without distortion: the ideal pinhole camera of the undistorted keypoints.
  PinholeCamera withoutDistortion() const;
  /// "fx ..., fy ..., cx ..., cy ..., WxH" with 10 significant digits (intrinsics that differ in a late digit must
  /// not print alike), for error messages.
  std::string describe() const;
  bool operator==(const PinholeCamera& o) const;
  bool operator!=(const PinholeCamera& o) const { return !(*this == o); }

  bool hasDistortion() const;
  Eigen::Matrix3d K() const;
  Eigen::Matrix3d Kinv() const;
  cv::Mat cvK() const;           ///< CV_64F 3x3
  cv::Mat cvDistortion() const;  ///< CV_64F 1x5

  /// Ideal pinhole projection of a camera-frame point (eq. 2.7), fx X / Z + cx. Requires Z != 0 (not checked: hot
  /// loop; callers test the depth first).
  Eigen::Vector2d project(const Eigen::Vector3d& X_cam) const {
    return {fx * X_cam.x() / X_cam.z() + cx, fy * X_cam.y() / X_cam.z() + cy};
  }
  /// Same, and the 2x3 Jacobian d(pixel)/d(X_cam) = [fx/Z 0 -fx X/Z^2; 0 fy/Z -fy Y/Z^2].
  Eigen::Vector2d project(const Eigen::Vector3d& X_cam, Eigen::Matrix<double, 2, 3>& jacobian) const;
  /// pi^-1 of eq. 2.9: the point on the normalized image plane z = 1 seen at an (undistorted) pixel.
  Eigen::Vector3d unprojectToPlane(const Eigen::Vector2d& pixel) const;
  /// Unit-norm ray direction through an (undistorted) pixel.
  Eigen::Vector3d unprojectToBearing(const Eigen::Vector2d& pixel) const;
  /// Inside [0, width) x [0, height).
  bool inImage(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < width && pixel.y() < height;
  }

  /// Undistorts raw pixel coordinates (cv::undistortPoints with P = K): the result is in pixels of the
  /// ideal pinhole camera with the same K. Returns the input unchanged when there is no distortion.
  std::vector<cv::Point2f> undistortPoints(const std::vector<cv::Point2f>& distorted) const;
  /// Same for keypoints: only `pt` changes; size, angle, octave, response and class_id are kept.
  std::vector<cv::KeyPoint> undistortKeyPoints(const std::vector<cv::KeyPoint>& distorted) const;
  /// Bounds of the undistorted image: the undistorted image corners (full image without distortion).
  ImageBounds undistortedBounds() const;
};

}  // namespace pslam::geometry
