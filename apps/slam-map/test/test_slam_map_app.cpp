// unit: slam-map's app class on small synthetic maps (libs/map/test/SyntheticMap.h): info counts and point-model
// statistics, the top-view "up", the PLY and PNG exports, and bad inputs (nothing written).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "SyntheticMap.h"
#include "pslam/apps/SlamMapApp.h"
#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/landmarks/KeypointModel.h"
#include "pslam/map/MapIO.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
struct TempDir : test_support::TempDir {
  TempDir() : test_support::TempDir("pslam_slam_map_app") {}
};

map::Map syntheticMap() {
  map::testing::SyntheticScene scene;
  return map::testing::buildSyntheticMap(6, 150, scene);
}

/// Gives every other good point a keypoint-model state with inlier counts (a, b).
std::size_t addModelStates(map::Map& m, double a, double b) {
  std::size_t n = 0, k = 0;
  for (const auto& [id, p] : m.mapPoints()) {
    if (k++ % 2) continue;
    landmarks::KeypointState st;
    st.mu = 0.2;
    st.sigma2 = 0.01;
    st.aObs = a;
    st.bObs = b;
    st.semanticUpdates = 1;
    st.depthUpdates = 3;
    m.mutableMapPoint(id).landmarkState = mapping::encodeKeypointState(st);
    ++n;
  }
  return n;
}

using test_support::errorOf;

std::size_t countLines(const fs::path& p) {
  std::ifstream in(p);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}
}  // namespace

TEST(SlamMapApp, InfoCountsTheMapAndItsFile) {
  TempDir tmp;
  const map::Map m = syntheticMap();
  const fs::path file = tmp.path / "m.slammap";
  map::saveMap(m, file);
  const apps::MapInfo info = apps::mapInfo(file);
  EXPECT_EQ(info.keyFrames, 6u);
  EXPECT_EQ(info.mapPoints, m.numMapPoints());
  EXPECT_EQ(info.fileBytes, fs::file_size(file));
  EXPECT_EQ(info.formatVersion, map::CSlamMapArchive::kFormatVersion);
  EXPECT_TRUE(info.camera == map::testing::testCamera());
  std::size_t obs = 0;
  for (const auto& [id, p] : m.mapPoints()) obs += p.numObservations();
  EXPECT_EQ(info.observations, obs);
  // Keyframes 0.3 m apart along x (plus 0.02 in y): five steps.
  EXPECT_NEAR(info.keyFramePathLength, 5 * std::hypot(0.3, 0.02), 1e-9);
  EXPECT_EQ(info.pointsWithModel, 0u);
  const nlohmann::json j = info.toJson();
  EXPECT_EQ(j["keyframes"], 6);
  EXPECT_EQ(j["file_bytes"], info.fileBytes);
  EXPECT_EQ(j["point_model"]["points_with_model"], 0);
  EXPECT_NE(info.toText().find("point model:  none"), std::string::npos) << info.toText();
}

TEST(SlamMapApp, InfoSummarizesThePointModel) {
  map::Map m = syntheticMap();
  // a = 30, b = 10 without semantic prior mass beyond the static class: phi is the model's, not a / (a + b).
  const std::size_t withState = addModelStates(m, 30.0, 10.0);
  const apps::MapInfo info = apps::mapInfo(m);
  EXPECT_EQ(info.pointsWithModel, withState);
  EXPECT_EQ(info.invalidModelStates, 0u);
  landmarks::KeypointState st;
  st.mu = 0.2;
  st.sigma2 = 0.01;
  st.aObs = 30;
  st.bObs = 10;
  st.semanticUpdates = 1;
  st.depthUpdates = 3;
  const double phi = landmarks::KeypointModel(landmarks::KeypointModelParams{}).inlierRatio(st);
  EXPECT_NEAR(info.inlierRatio.mean, phi, 1e-12);
  EXPECT_NEAR(info.inlierRatio.median, phi, 1e-12);
  EXPECT_EQ(info.activePoints, phi >= 0.6 ? withState : 0u);
  EXPECT_NEAR(info.depthUpdates.mean, 3.0, 1e-12);
  EXPECT_EQ(apps::inlierRatios(m).size(), withState);
  // A state of the wrong length is counted, not fatal.
  m.mutableMapPoint(m.mapPoints().rbegin()->first).landmarkState = {1.0, 2.0};
  EXPECT_EQ(apps::mapInfo(m).invalidModelStates, 1u);
}

TEST(SlamMapApp, UpIsAgainstTheCamerasYAxis) {
  // The synthetic keyframes turn about the camera y axis only: world "up" is -y.
  const Eigen::Vector3d up = apps::mapUpDirection(syntheticMap());
  EXPECT_NEAR(up.y(), -1.0, 1e-9) << up.transpose();
}

TEST(SlamMapApp, ExportsPlyAndPng) {
  TempDir tmp;
  map::Map m = syntheticMap();
  addModelStates(m, 30.0, 10.0);
  const fs::path file = tmp.path / "m.slammap";
  map::saveMap(m, file);
  apps::MapExportOptions o;
  o.map = file;
  o.ply = tmp.path / "out" / "m.ply";
  o.png = tmp.path / "out" / "top.png";
  o.pngWidth = 640;
  o.pngHeight = 480;
  const apps::MapExportSummary s = apps::exportMap(o);
  EXPECT_EQ(s.points, m.numMapPoints());
  EXPECT_EQ(s.keyFrames, 6u);
  EXPECT_TRUE(s.colouredByInlierRatio);
  // Header (11 lines with the two comments) + one vertex line per point and keyframe.
  std::ifstream in(o.ply);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "ply");
  EXPECT_EQ(countLines(o.ply), 12 + m.numMapPoints() + 6);
  std::stringstream all;
  all << std::ifstream(o.ply).rdbuf();
  EXPECT_NE(all.str().find("element vertex " + std::to_string(m.numMapPoints() + 6)), std::string::npos);
  const cv::Mat png = cv::imread(o.png.string());
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 640);
  EXPECT_EQ(png.rows, 480);
  // Only the requested outputs, no temporaries left.
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(tmp.path / "out")) files += e.is_regular_file();
  EXPECT_EQ(files, 2u);
}

TEST(SlamMapApp, BadInputsNameTheFileAndWriteNothing) {
  TempDir tmp;
  apps::MapExportOptions o;
  o.map = tmp.path / "missing.slammap";
  o.ply = tmp.path / "out" / "m.ply";
  EXPECT_NE(errorOf([&] { apps::exportMap(o); }).find("missing.slammap"), std::string::npos);
  EXPECT_FALSE(fs::exists(o.ply));
  EXPECT_NE(errorOf([&] { apps::mapInfo(o.map); }).find("missing.slammap: map file not found"), std::string::npos);
  // Corrupt: not gzip.
  const fs::path corrupt = tmp.path / "corrupt.slammap";
  std::ofstream(corrupt) << "not a map";
  o.map = corrupt;
  EXPECT_NE(errorOf([&] { apps::exportMap(o); }).find("corrupt.slammap"), std::string::npos);
  EXPECT_FALSE(fs::exists(o.ply));
  // Nothing to export; the map as its own output.
  o.ply.clear();
  EXPECT_NE(errorOf([&] { apps::exportMap(o); }).find("nothing to export"), std::string::npos);
  map::saveMap(syntheticMap(), tmp.path / "m.slammap");
  o.map = tmp.path / "m.slammap";
  o.ply = o.map;
  EXPECT_NE(errorOf([&] { apps::exportMap(o); }).find("input"), std::string::npos);
  EXPECT_NO_THROW(map::loadMap(o.map));  // untouched
}

TEST(SlamMapApp, ResidualsRecoverAnOffsetPerLevelAndAScaleAboutThePrincipalPoint) {
  // The synthetic keypoints are the exact projections of their points: shifting those of level l by (0.1 l,
  // -0.05 l) px must give exactly these means on level l; scaling level 7's about the principal point by 1 + e
  // gives a radial mean of e times their mean distance from it.
  map::Map m = syntheticMap();
  for (const auto& [id, p] : m.mapPoints()) ASSERT_FALSE(p.bad) << "the residuals count good points only";
  const apps::MapResiduals exact = apps::mapResiduals(m);
  ASSERT_FALSE(exact.levels.empty());
  EXPECT_LT(exact.all.rms, 1e-3);
  const double e = 0.01;
  double radiusSum = 0.0;
  std::size_t level7 = 0;
  for (const auto& [id, kf] : m.keyFrames()) {
    map::KeyFrame& k = m.mutableKeyFrame(id);
    for (std::size_t i = 0; i < k.keypoints.size(); ++i) {
      if (k.mapPointIds[i] == map::kNoMapPoint) continue;
      cv::KeyPoint& kp = k.keypoints[i];
      if (kp.octave == 7) {
        const cv::Point2f c(static_cast<float>(k.camera.cx), static_cast<float>(k.camera.cy));
        radiusSum += cv::norm(kp.pt - c);
        ++level7;
        kp.pt = c + (kp.pt - c) * static_cast<float>(1.0 + e);
      } else {
        kp.pt.x += static_cast<float>(0.1 * kp.octave);
        kp.pt.y -= static_cast<float>(0.05 * kp.octave);
      }
    }
  }
  ASSERT_GT(level7, 10u);
  const apps::MapResiduals r = apps::mapResiduals(m);
  std::size_t total = 0;
  for (const apps::LevelResiduals& l : r.levels) {
    total += l.count;
    if (l.level == 7) {
      EXPECT_NEAR(l.meanRadial, e * radiusSum / static_cast<double>(level7), 1e-3) << "level 7";
      continue;
    }
    EXPECT_NEAR(l.meanX, 0.1 * l.level, 1e-4) << "level " << l.level;
    EXPECT_NEAR(l.meanY, -0.05 * l.level, 1e-4) << "level " << l.level;
    EXPECT_NEAR(l.rms, std::hypot(0.1, 0.05) * l.level, 1e-4) << "level " << l.level;
    // Every residual of the level has the same norm: median and 90th percentile are it.
    EXPECT_NEAR(l.median, std::hypot(0.1, 0.05) * l.level, 1e-4) << "level " << l.level;
    EXPECT_NEAR(l.p90, std::hypot(0.1, 0.05) * l.level, 1e-4) << "level " << l.level;
  }
  EXPECT_EQ(total, r.all.count);
  EXPECT_EQ(r.toJson()["levels"].size(), r.levels.size());
}

namespace {
/// The synthetic map's keyframe poses as a ground-truth trajectory in another frame: p_gt = s R p_map + t.
Trajectory groundTruthOf(const map::Map& m, double s, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Trajectory gt;
  for (const auto& [id, kf] : m.keyFrames()) {
    const Eigen::Isometry3d T = kf.T_world_cam();
    Eigen::Isometry3d G = Eigen::Isometry3d::Identity();
    G.linear() = R * T.linear();
    G.translation() = s * R * T.translation() + t;
    gt.emplace_back(kf.timestamp, G);
  }
  return gt;
}
}  // namespace

map::Map curvedMap() {
  map::testing::SyntheticScene scene;
  return map::testing::buildSyntheticMap(6, 150, scene, 7, map::testing::poseOnCurve);
}

TEST(SlamMapApp, OptimumOfExactObservationsIsTheGroundTruth) {
  // The keypoints are the exact projections of the points from the true poses, which the ground truth holds (in
  // another frame and scale). With the keyframes moved off them, the map is wrong, the truth is the BA's optimum:
  // a BA from the truth stays there at zero cost, and a BA from the moved map goes back to it.
  map::Map m = curvedMap();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Trajectory gt = groundTruthOf(m, 2.5, R, Eigen::Vector3d(10, -4, 2));
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const map::Map truthMap = m;
  for (const auto& [id, kf] : truthMap.keyFrames()) {
    if (id == m.rootKeyFrame()) continue;
    Eigen::Isometry3d T = kf.T_cam_world;
    T.pretranslate(Eigen::Vector3d(n(rng), n(rng), n(rng)) * 0.02);
    T.prerotate(Eigen::AngleAxisd(0.004, Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized()));
    m.setKeyFramePose(id, T);
  }
  apps::OptimumOptions o;
  o.segments = 2;
  const apps::MapOptimum r = apps::mapOptimum(m, gt, o);
  ASSERT_EQ(r.stages.size(), 4u);
  EXPECT_EQ(r.keyFrames, 6u);
  EXPECT_GT(r.observations, 300u);
  const apps::OptimumStage &saved = r.stages[0], &fromSaved = r.stages[1], &truth = r.stages[2],
                           &fromTruth = r.stages[3];
  EXPECT_EQ(saved.name, "saved");
  EXPECT_EQ(fromTruth.name, "ba_from_groundtruth");
  EXPECT_GT(saved.ate, 0.02) << "the moved keyframes, in ground-truth units";
  EXPECT_GT(saved.cost, 1.0);
  EXPECT_LT(truth.ate, 1e-9);
  EXPECT_LT(truth.cost, 1e-4) << "exact observations: the refit depths fit them";
  EXPECT_LT(fromTruth.ate, 1e-5);
  EXPECT_LT(fromTruth.cost, 1e-4);
  EXPECT_LT(fromSaved.ate, 0.05 * saved.ate) << "the BA from the moved map returns to the truth";
  EXPECT_LT(fromSaved.cost, 1e-3);
  EXPECT_GT(fromSaved.iterations, 0);
  EXPECT_EQ(r.toJson()["stages"].size(), 4u);
  EXPECT_NE(r.toText().find("ba_from_groundtruth"), std::string::npos);
}

TEST(SlamMapApp, OptimumOfBiasedObservationsIsNotTheGroundTruth) {
  // The keypoints of levels 4-7 scaled about the principal point by 2 % (a focal length of their own): the truth no
  // longer fits them, and both BAs end at the same optimum away from it, with a lower cost than the truth's.
  map::Map m = curvedMap();
  const Trajectory gt = groundTruthOf(m, 1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  for (const auto& [id, kf] : m.keyFrames()) {
    map::KeyFrame& k = m.mutableKeyFrame(id);
    for (std::size_t i = 0; i < k.keypoints.size(); ++i) {
      cv::KeyPoint& kp = k.keypoints[i];
      if (k.mapPointIds[i] == map::kNoMapPoint || kp.octave < 4) continue;
      const cv::Point2f c(static_cast<float>(k.camera.cx), static_cast<float>(k.camera.cy));
      kp.pt = c + (kp.pt - c) * 1.02f;
    }
  }
  apps::OptimumOptions o;
  o.segments = 0;
  const apps::MapOptimum r = apps::mapOptimum(m, gt, o);
  const apps::OptimumStage &truth = r.stages[2], &fromSaved = r.stages[1], &fromTruth = r.stages[3];
  EXPECT_GT(truth.cost, 1.1 * fromTruth.cost) << r.toText();
  EXPECT_GT(fromTruth.ate, 1e-3) << "the optimum of biased observations is off the truth";
  EXPECT_NEAR(fromTruth.ate, fromSaved.ate, 0.05 * fromSaved.ate) << "one optimum, from either start";
  EXPECT_NEAR(fromTruth.cost, fromSaved.cost, 0.01 * fromSaved.cost);
}

TEST(SlamMapApp, OptimumNamesWhatIsMissing) {
  TempDir tmp;
  const map::Map m = curvedMap();
  Trajectory gt = groundTruthOf(m, 1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  apps::OptimumOptions o;
  o.segments = 0;
  o.groundTruth = "gt.txt";
  Trajectory lacking = gt;
  lacking.erase(lacking.begin() + 3);  // the keyframe at 1.5 s
  EXPECT_NE(errorOf([&] { apps::mapOptimum(m, lacking, o); })
                .find("keyframe 3 (stamp 1.500000 s) has no pose within 0.010 s in gt.txt"),
            std::string::npos);
  o.segments = 3;  // 6 keyframes: 2 per stretch
  EXPECT_NE(errorOf([&] { apps::mapOptimum(m, gt, o); }).find("--segments 3 needs at least 3 keyframes per stretch"),
            std::string::npos);
  o.segments = 0;
  o.iterations = 0;
  EXPECT_NE(errorOf([&] { apps::mapOptimum(m, gt, o); }).find("--iterations"), std::string::npos);
  o.iterations = 10;
  o.map = tmp.path / "m.slammap";
  map::saveMap(m, o.map);
  o.groundTruth = tmp.path / "missing_gt.txt";
  EXPECT_NE(errorOf([&] { apps::mapOptimum(o); }).find("missing_gt.txt"), std::string::npos);
  writeTumTrajectory(tmp.path / "gt.txt", gt);
  o.groundTruth = tmp.path / "gt.txt";
  EXPECT_LT(apps::mapOptimum(o).stages[3].cost, 1e-4);
}

// Reliability (doc/reliability.md): a static ground truth (every pose at one position) printed 34 lines of solver
// output before its error; it is refused before any bundle adjustment, naming the file.
TEST(SlamMapApp, OptimumRefusesAStaticGroundTruthFirst) {
  TempDir tmp;
  const map::Map m = curvedMap();
  Trajectory gt = groundTruthOf(m, 1.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  for (auto& p : gt) p.position = Eigen::Vector3d(1, 2, 3);
  apps::OptimumOptions o;
  o.segments = 0;
  o.map = tmp.path / "m.slammap";
  map::saveMap(m, o.map);
  o.groundTruth = tmp.path / "static.txt";
  writeTumTrajectory(o.groundTruth, gt);
  EXPECT_NE(errorOf([&] { apps::mapOptimum(o); })
                .find(o.groundTruth.string() + ": all " + std::to_string(gt.size()) + " poses are at one position"),
            std::string::npos);
}
