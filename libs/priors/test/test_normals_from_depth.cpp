// Normals and planar mask from synthetic depth of known planes, and the normal-priors app on a small rawlog.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <unistd.h>

#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalPriorsApp.h"
#include "pslam/priors/NormalsFromDepth.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

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

using namespace pslam::priors;
using pslam::priors::test::renderRoom;
namespace fs = std::filesystem;

namespace {

const Eigen::Matrix3d kRoomRotation =
    (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX())).toRotationMatrix();
const Eigen::Vector3d kHalfSize(2.0, 1.3, 3.0);
const Eigen::Vector3d kCamInRoom(0.3, -0.2, -1.0);

struct Stats {
  double planarShare = 0, medianErrDeg = 0, maxErrDeg = 0, p99ErrDeg = 0, shareOver1Deg = 0;
  std::size_t count = 0;
};

Stats compare(const NormalMap& est, const cv::Mat& truth, bool planarOnly) {
  NormalErrorAccumulator acc;
  std::vector<double> errs;
  double maxErr = 0;
  std::size_t planar = 0;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      if (est.planarMask.at<uchar>(v, u)) ++planar;
      if (planarOnly && !est.planarMask.at<uchar>(v, u)) continue;
      const cv::Vec3f n = est.normals.at<cv::Vec3f>(v, u);
      if (n == cv::Vec3f(0, 0, 0)) continue;
      const double e = normalAngleDeg(n, truth.at<cv::Vec3f>(v, u));
      acc.add(e);
      errs.push_back(e);
      maxErr = std::max(maxErr, e);
    }
  Stats s;
  s.planarShare = planar / double(truth.total());
  s.medianErrDeg = acc.summary().medianDeg;
  s.maxErrDeg = maxErr;
  s.count = acc.summary().count;
  std::sort(errs.begin(), errs.end());
  s.p99ErrDeg = errs.empty() ? 180.0 : errs[errs.size() * 99 / 100];
  s.shareOver1Deg = errs.empty() ? 1.0
                                 : double(errs.end() - std::upper_bound(errs.begin(), errs.end(), 1.0)) / errs.size();
  std::cout << "planar share " << s.planarShare << " median " << s.medianErrDeg << " p99 " << s.p99ErrDeg << " max "
            << s.maxErrDeg << " deg, share > 1 deg " << s.shareOver1Deg << " over " << s.count << " px\n";
  return s;
}

}  // namespace

TEST(NormalsFromDepth, NoiseFreeRoomMatchesAnalyticNormals) {
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom);
  const DepthNormalEstimator estimator;
  const NormalMap nm = estimator.compute(scene.depth, scene.K);
  EXPECT_GE(nm.planeCount, 3);
  const Stats planar = compare(nm, scene.normals, true);
  EXPECT_GT(planar.planarShare, 0.9);
  EXPECT_LT(planar.p99ErrDeg, 0.1);  // exact planes: the plane fit is exact up to float rounding
  // Pixels on the fold lines themselves see two walls at once (ambiguous ground truth): one pixel column
  // per fold, well under 1 % of the image.
  EXPECT_LT(planar.shareOver1Deg, 0.01);
  // Per-pixel PCA normals (no plane replacement) away from the edges.
  DepthNormalParams p;
  p.usePlaneNormals = false;
  const Stats pixel = compare(DepthNormalEstimator(p).compute(scene.depth, scene.K), scene.normals, false);
  EXPECT_LT(pixel.medianErrDeg, 0.1);
  // Windows within windowRadius of a fold mix two walls: a band of ~2r px per fold (~5 % of this image).
  EXPECT_LT(pixel.shareOver1Deg, 0.05);
}

TEST(NormalsFromDepth, NoisyQuantizedDepthStillGivesAccuratePlaneNormals) {
  // Kinect-like: 3 mm noise, then stored as TUM u16 (5000 = 1 m).
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom, 0.003, 7);
  cv::Mat raw;
  scene.depth.convertTo(raw, CV_16U, 5000.0);
  const NormalMap nm = DepthNormalEstimator().computeFromRaw(raw, 1.0 / 5000.0, scene.K);
  const Stats planar = compare(nm, scene.normals, true);
  EXPECT_GT(planar.planarShare, 0.7);
  EXPECT_LT(planar.medianErrDeg, 1.0);
  EXPECT_LT(planar.shareOver1Deg, 0.01);
}

TEST(NormalsFromDepth, DepthDiscontinuityDoesNotBlendNormals) {
  // A plane at 2 m facing the camera, with a raised square at 1 m: no normal may tilt across the step.
  cv::Mat depth(240, 320, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(100, 60, 120, 120)).setTo(1.0f);
  const PinholeIntrinsics K{300, 300, 159.5, 119.5};
  DepthNormalParams p;
  p.usePlaneNormals = false;
  p.minPlaneCells = 10;
  const NormalMap nm = DepthNormalEstimator(p).compute(depth, K);
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u) {
      const cv::Vec3f n = nm.normals.at<cv::Vec3f>(v, u);
      if (n == cv::Vec3f(0, 0, 0)) continue;
      ASSERT_LT(normalAngleDeg(n, cv::Vec3f(0, 0, -1)), 1.0) << "pixel " << u << "," << v;
    }
  EXPECT_GE(nm.planeCount, 2);
}

TEST(NormalsFromDepth, RejectsBadInputAndParameters) {
  const DepthNormalEstimator e;
  EXPECT_THROW(e.compute(cv::Mat(), {500, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.compute(cv::Mat(10, 10, CV_64FC1, cv::Scalar(1)), {500, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.compute(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1)), {0, 500, 320, 240}), pslam::Error);
  EXPECT_THROW(e.computeFromRaw(cv::Mat(10, 10, CV_16UC1, cv::Scalar(1)), 0.0, {500, 500, 5, 5}), pslam::Error);
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("NormalsFromDepth", "cellSize", 1);
  DepthNormalParams p;
  try {
    p.loadFromConfigFile(cfg, "NormalsFromDepth");
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find("cellSize"), std::string::npos);
  }
}

TEST(NormalPriorsApp, AddsNormalsChannelFromDepthAndCopiesGroundTruth) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_normal_priors_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  struct Cleanup {
    fs::path p;
    ~Cleanup() { fs::remove_all(p); }
  } cleanup{dir};
  const auto scene = renderRoom(kRoomRotation, kHalfSize, kCamInRoom, 0.0, 1, 320, 240);
  {
    pslam::datasets::RawlogWriter w(dir / "room.rawlog");
    for (int i = 0; i < 2; ++i) {
      pslam::datasets::Frame f;
      f.timestamp = 10.0 + i;
      f.image = cv::Mat(240, 320, CV_8UC3, cv::Scalar(90, 120, 150));
      f.camera.ncols = 320;
      f.camera.nrows = 240;
      f.camera.fx(scene.K.fx);
      f.camera.fy(scene.K.fy);
      f.camera.cx(scene.K.cx);
      f.camera.cy(scene.K.cy);
      scene.depth.convertTo(f.depth, CV_16U, 5000.0);
      f.depthUnits = 1.0 / 5000.0;
      w.write(f);
    }
    w.commit();
  }
  { std::ofstream(dir / "room_groundtruth.txt") << "10 0 0 0 0 0 0 1\n11 0 0 0 0 0 0 1\n"; }
  NormalPriorsOptions o;
  o.input = dir / "room.rawlog";
  o.output = dir / "out" / "room_n.rawlog";
  o.progress = false;
  const NormalPriorsResult r = runNormalPriors(o);
  EXPECT_EQ(r.frames, 2u);
  EXPECT_GT(r.meanPlanarShare, 0.8);
  EXPECT_TRUE(fs::exists(dir / "out" / "room_n_groundtruth.txt"));
  pslam::datasets::RawlogReader reader(o.output);
  pslam::datasets::Frame f;
  std::size_t n = 0;
  while (reader.next(f)) {
    ASSERT_TRUE(f.hasNormals());
    ASSERT_TRUE(f.hasDepth());
    const cv::Mat dec = decodeNormalMap(f.normals);
    NormalErrorAccumulator acc;
    acc.addMaps(dec, scene.normals);
    EXPECT_GT(acc.summary().count, 0.8 * 320 * 240);
    EXPECT_LT(acc.summary().medianDeg, 0.5);  // 8-bit quantization only
    ++n;
  }
  EXPECT_EQ(n, 2u);
  // Bad input names the file.
  o.input = dir / "missing.rawlog";
  try {
    runNormalPriors(o);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& err) {
    EXPECT_NE(std::string(err.what()).find("missing.rawlog"), std::string::npos);
  }
  o.input = dir / "room.rawlog";
  o.source = "magic";
  EXPECT_THROW(runNormalPriors(o), pslam::Error);
}
