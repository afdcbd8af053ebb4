#pragma once
// Identifiers and the pinhole camera shared by keyframes, map points and the optimizer.
// Objects refer to each other only by id (no pointers), so the map is plain, copyable and versionable.
#include <cstdint>
#include <limits>
#include <string>

#include <Eigen/Core>

namespace pslam::map {

using KeyFrameId = std::uint64_t;
using MapPointId = std::uint64_t;
inline constexpr KeyFrameId kNoKeyFrame = std::numeric_limits<KeyFrameId>::max();
inline constexpr MapPointId kNoMapPoint = std::numeric_limits<MapPointId>::max();

/// Pinhole intrinsics of undistorted keypoints (keypoints stored in keyframes are already undistorted).
struct CameraIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;  ///< image size in pixels

  /// Pixel of a camera-frame point (z must be > 0).
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const {
    return {fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy};
  }
  /// Unit bearing of a pixel in the camera frame.
  Eigen::Vector3d bearing(const Eigen::Vector2d& pixel) const {
    return Eigen::Vector3d((pixel.x() - cx) / fx, (pixel.y() - cy) / fy, 1.0).normalized();
  }
  /// The 3x3 calibration matrix.
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
    return k;
  }
  bool inImage(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < width && pixel.y() < height;
  }
  /// Throws pslam::Error("<context>: ...") on non-positive/non-finite focal lengths or image size.
  void check(const std::string& context) const;

  bool operator==(const CameraIntrinsics& o) const {
    return fx == o.fx && fy == o.fy && cx == o.cx && cy == o.cy && width == o.width && height == o.height;
  }
  bool operator!=(const CameraIntrinsics& o) const { return !(*this == o); }
};

}  // namespace pslam::map
