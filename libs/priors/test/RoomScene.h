#pragma once
// A camera inside an axis-aligned box room: depth and analytic wall normals of every pixel (tests only; shared
// by the normal-estimation tests and the normal-priors app test).
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "pslam/priors/NormalsFromDepth.h"

namespace pslam::priors::test {

struct RoomScene {
  cv::Mat depth;    ///< CV_32FC1 metres
  cv::Mat normals;  ///< CV_32FC3 analytic normal of the wall each pixel sees (facing the camera)
  PinholeIntrinsics K{525.0, 525.0, 319.5, 239.5};
};

inline RoomScene renderRoom(const Eigen::Matrix3d& R_cam_room, const Eigen::Vector3d& halfSize,
                            const Eigen::Vector3d& camInRoom, double noiseStd = 0.0, unsigned seed = 1,
                            int cols = 640, int rows = 480) {
  RoomScene s;
  s.depth = cv::Mat(rows, cols, CV_32FC1, cv::Scalar(0));
  s.normals = cv::Mat(rows, cols, CV_32FC3, cv::Scalar::all(0));
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Matrix3d R_room_cam = R_cam_room.transpose();
  for (int v = 0; v < rows; ++v) {
    for (int u = 0; u < cols; ++u) {
      const Eigen::Vector3d ray((u - s.K.cx) / s.K.fx, (v - s.K.cy) / s.K.fy, 1.0);
      const Eigen::Vector3d rr = R_room_cam * ray;  // ray in room coordinates
      double best = 1e18;
      int bestAxis = -1;
      double bestSign = 0;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(rr(a)) < 1e-12) continue;
        const double wall = rr(a) > 0 ? halfSize(a) : -halfSize(a);
        const double t = (wall - camInRoom(a)) / rr(a);
        if (t > 0 && t < best) {
          best = t;
          bestAxis = a;
          bestSign = rr(a) > 0 ? -1.0 : 1.0;  // the wall's normal points back into the room
        }
      }
      const double z = best + (noiseStd > 0 ? noiseStd * g(rng) : 0.0);
      s.depth.at<float>(v, u) = static_cast<float>(z);
      const Eigen::Vector3d nRoom = Eigen::Vector3d::Unit(bestAxis) * bestSign;
      const Eigen::Vector3d n = R_cam_room * nRoom;
      s.normals.at<cv::Vec3f>(v, u) = cv::Vec3f(float(n.x()), float(n.y()), float(n.z()));
    }
  }
  return s;
}

}  // namespace pslam::priors::test
