// Translation with known rotation on real data (TUM fr3_cabinet): ORB matches between consecutive frames,
// rotation from the ground truth, translation from eq. 2.34 (direction, 2D-2D) and from depth-backed 3D-2D
// correspondences (metric), both in RANSAC, compared with the ground-truth relative translation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/manhattan/TranslationSolver.h"
#include "pslam/priors/NormalsFromDepth.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
std::vector<std::string> column(const fs::path& list) {
  std::vector<std::string> out;
  std::ifstream in(list);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t;
    std::string f;
    if (ss >> t >> f) out.push_back(f);
  }
  return out;
}
}  // namespace

TEST(DataTranslationTum, KnownRotationTranslationAgainstGroundTruth) {
  const fs::path dir = fs::path(PRIORSLAM_SHARED_DATA_DIR) / "tum_rgbd/rgbd_dataset_freiburg3_cabinet_every20th";
  if (!fs::is_directory(dir)) GTEST_SKIP() << "shared data not found: " << dir;
  const auto rgb = column(dir / "rgb.txt"), depth = column(dir / "depth.txt");
  const Trajectory gt = readTumTrajectory(dir / "groundtruth.txt");  // same stamps as rgb/depth in this subset
  ASSERT_EQ(rgb.size(), gt.size());
  const double fx = 535.4, fy = 539.2, cx = 320.1, cy = 247.6;
  auto orb = cv::ORB::create(2000);
  cv::BFMatcher matcher(cv::NORM_HAMMING, true);
  manhattan::TranslationRansacParams params;
  params.inlierThreshold = 2.0 / fx;  // 2 px

  std::vector<double> metricErr, dirErr, gtNorm, mwMetricErr, mwRotErr;
  const priors::DepthNormalEstimator normalEstimator;
  const priors::PinholeIntrinsics K{fx, fy, cx, cy};
  auto planarNormals = [&](const cv::Mat& d) {
    const priors::NormalMap nm = normalEstimator.computeFromRaw(d, 1.0 / 5000.0, K);
    cv::Mat planar(nm.normals.size(), CV_32FC3, cv::Scalar::all(0));
    nm.normals.copyTo(planar, nm.planarMask);
    return priors::collectNormals(planar, 2);
  };
  for (std::size_t i = 0; i + 1 < rgb.size(); i += 3) {
    const cv::Mat a = cv::imread((dir / rgb[i]).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat b = cv::imread((dir / rgb[i + 1]).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat da = cv::imread((dir / depth[i]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(a.empty() || b.empty() || da.empty());
    std::vector<cv::KeyPoint> ka, kb;
    cv::Mat descA, descB;
    orb->detectAndCompute(a, cv::noArray(), ka, descA);
    orb->detectAndCompute(b, cv::noArray(), kb, descB);
    std::vector<cv::DMatch> matches;
    if (!descA.empty() && !descB.empty()) matcher.match(descA, descB, matches);
    std::vector<Eigen::Vector3d> fPrev, fCur, Xprev;
    std::vector<Eigen::Vector2d> xCur;
    for (const auto& m : matches) {
      const cv::Point2f pa = ka[static_cast<std::size_t>(m.queryIdx)].pt, pb = kb[static_cast<std::size_t>(m.trainIdx)].pt;
      const Eigen::Vector3d fa((pa.x - cx) / fx, (pa.y - cy) / fy, 1.0), fb((pb.x - cx) / fx, (pb.y - cy) / fy, 1.0);
      fPrev.push_back(fa);
      fCur.push_back(fb);
      const double z = da.at<uint16_t>(cvRound(pa.y), cvRound(pa.x)) / 5000.0;
      if (z > 0.3) {
        Xprev.push_back(fa * z);
        xCur.push_back(fb.head<2>());
      }
    }
    if (fPrev.size() < 20 || Xprev.size() < 20) continue;
    // T_cur_prev = T_w_cur^-1 T_w_prev
    const Eigen::Isometry3d T_cur_prev = gt[i + 1].T_world_cam().inverse() * gt[i].T_world_cam();
    const Eigen::Matrix3d R = T_cur_prev.linear();
    const Eigen::Vector3d t = T_cur_prev.translation();
    const auto met = manhattan::ransacTranslationMetric(Xprev, xCur, R, params);
    const auto dirE = manhattan::ransacTranslationDirection(fPrev, fCur, R, params);
    if (!met.valid || !dirE.valid) continue;
    metricErr.push_back((met.t_cur_prev - t).norm());
    dirErr.push_back(std::acos(std::clamp(dirE.t_cur_prev.dot(t.normalized()), -1.0, 1.0)) * 180 / M_PI);
    gtNorm.push_back(t.norm());
    // The thesis' decoupled pipeline (§4.4.1): rotation from the Manhattan frames of both images instead of GT.
    manhattan::ManhattanTracker tracker;
    const auto e0 = tracker.initialize(planarNormals(da));
    const cv::Mat db = cv::imread((dir / depth[i + 1]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(db.empty());
    if (e0.valid) {
      const auto e1 = tracker.track(planarNormals(db));
      if (e1.valid) {
        const Eigen::Matrix3d R_mw = e1.R_cam_mf * e0.R_cam_mf.transpose();  // R_cur_prev via the MF
        mwRotErr.push_back(manhattan::rotationAngleDeg(R_mw, R));
        const auto mw = manhattan::ransacTranslationMetric(Xprev, xCur, R_mw, params);
        if (mw.valid) mwMetricErr.push_back((mw.t_cur_prev - t).norm());
      }
    }
    std::cout << "pair " << i << ": |t_gt| " << t.norm() << " m, metric error " << metricErr.back() << " m ("
              << met.inlierCount << "/" << Xprev.size() << " inliers), direction error " << dirErr.back() << " deg ("
              << dirE.inlierCount << "/" << fPrev.size() << ")\n";
  }
  ASSERT_GE(metricErr.size(), 8u);  // low texture: some pairs have < 20 depth-backed matches
  const double medMetric = percentile(metricErr, 50), medDir = percentile(dirErr, 50), medNorm = percentile(gtNorm, 50);
  std::cout << "median |t_gt| " << medNorm << " m, median metric error " << medMetric << " m, median direction error "
            << medDir << " deg over " << metricErr.size() << " pairs\n";
  if (!mwMetricErr.empty())
    std::cout << "with the Manhattan rotation: median rotation error " << percentile(mwRotErr, 50)
              << " deg, median metric translation error " << percentile(mwMetricErr, 50) << " m over "
              << mwMetricErr.size() << " pairs\n";
  ASSERT_GE(mwMetricErr.size(), 8u);
  // The translation is recovered to a fraction of its length: far better than ignoring it (error = |t|).
  EXPECT_LT(medMetric, 0.25 * medNorm);
  EXPECT_LT(medDir, 20.0);
  EXPECT_LT(percentile(mwMetricErr, 50), 0.25 * medNorm);
}
