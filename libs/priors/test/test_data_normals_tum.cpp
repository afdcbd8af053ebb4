// Normals from real Kinect depth (TUM fr3_cabinet): without ground-truth normals, the floor is the check.
// The largest plane of the first frame, rotated into the world with the ground-truth camera orientation,
// must be found again (same world direction) in frames seen from other viewpoints.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Trajectory.h"
#include "pslam/priors/NormalsFromDepth.h"

namespace fs = std::filesystem;
using namespace pslam::priors;

TEST(DataNormalsTum, FloorNormalIsStableInTheWorldFrame) {
  const fs::path dir = fs::path(PRIORSLAM_SHARED_DATA_DIR) / "tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th";
  if (!fs::is_directory(dir)) GTEST_SKIP() << "shared data not found: " << dir;
  // depth.txt and groundtruth.txt of this subset share their timestamps line by line.
  std::vector<std::pair<double, std::string>> depthFiles;
  {
    std::ifstream in(dir / "depth.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      double t;
      std::string f;
      ASSERT_TRUE(static_cast<bool>(ss >> t >> f)) << line;
      depthFiles.emplace_back(t, f);
    }
  }
  const pslam::Trajectory gt = pslam::readTumTrajectory(dir / "groundtruth.txt");
  ASSERT_EQ(gt.size(), depthFiles.size());
  const PinholeIntrinsics K{535.4, 539.2, 320.1, 247.6};  // fr3
  const DepthNormalEstimator estimator;

  Eigen::Vector3d worldNormal0 = Eigen::Vector3d::Zero();
  int checked = 0;
  for (std::size_t i = 0; i < depthFiles.size(); i += 10) {
    ASSERT_NEAR(gt[i].timestamp, depthFiles[i].first, 1e-3);
    const cv::Mat depth = cv::imread((dir / depthFiles[i].second).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(depth.empty()) << depthFiles[i].second;
    const NormalMap nm = estimator.computeFromRaw(depth, 1.0 / 5000.0, K);
    ASSERT_GE(nm.planeCount, 2) << "frame " << i;
    EXPECT_GT(cv::countNonZero(nm.planarMask), 0.3 * depth.total()) << "frame " << i;
    // Plane normals (one per label) in the world frame.
    std::vector<int> area(static_cast<std::size_t>(nm.planeCount), 0);
    std::vector<Eigen::Vector3d> normals(static_cast<std::size_t>(nm.planeCount));
    for (int v = 0; v < depth.rows; ++v)
      for (int u = 0; u < depth.cols; ++u) {
        const int l = nm.planeLabels.at<int>(v, u);
        if (l < 0) continue;
        ++area[static_cast<std::size_t>(l)];
        const cv::Vec3f n = nm.normals.at<cv::Vec3f>(v, u);
        normals[static_cast<std::size_t>(l)] = gt[i].orientation * Eigen::Vector3d(n[0], n[1], n[2]);
      }
    if (i == 0) {
      worldNormal0 = normals[static_cast<std::size_t>(std::max_element(area.begin(), area.end()) - area.begin())];
      continue;
    }
    double best = 180.0;
    for (const auto& n : normals) best = std::min(best, std::acos(std::clamp(n.dot(worldNormal0), -1.0, 1.0)) * 180 / M_PI);
    std::cout << "frame " << i << ": " << nm.planeCount << " planes, closest to frame-0 floor " << best << " deg\n";
    // Bound: a few degrees covers Kinect depth bias and the ground-truth orientation error.
    EXPECT_LT(best, 4.0) << "frame " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}
