// Tests of the direct front end (thesis §3.2.2, §3.4) on a textured fronto-parallel plane seen by cameras that
// translate along x, so that every view is the texture shifted by fx * dx / Z pixels and the truth is exact:
// point creation recovers the plane's depth, tracking uses only the points the model activates, the
// coarse-to-fine pose optimization with the created points converges to the true pose, and every tracked frame
// measures the points it sees (depth update of the keypoint model).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/tracking/PoseSolver.h"

namespace pslam::direct {
namespace {

constexpr double kPlaneDepth = 5.0;
constexpr int kWidth = 640, kHeight = 480;

geometry::PinholeCamera testCamera() { return geometry::PinholeCamera(500.0, 500.0, 320.0, 240.0, kWidth, kHeight); }

/// A smooth random texture larger than the image (blurred noise with a few strong blobs).
const cv::Mat& texture() {
  static const cv::Mat t = [] {
    cv::Mat noise(kHeight + 200, kWidth + 400, CV_32FC1);
    cv::RNG rng(7);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 255.0);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.5);
    cv::normalize(noise, noise, 20, 235, cv::NORM_MINMAX);
    cv::Mat out;
    noise.convertTo(out, CV_8UC1);
    return out;
  }();
  return t;
}

/// The view of the plane z = kPlaneDepth from a camera at (x, 0, 0) looking along +z (sub-pixel shift).
cv::Mat viewAt(double x) {
  const double shift = 500.0 * x / kPlaneDepth;  // a world point moves left by fx * x / Z
  cv::Mat out;
  // out(u, v) = texture(u + 100 + shift, v + 100): the content slides left as the camera moves right.
  cv::warpAffine(texture(), out, cv::Matx23d(1, 0, 100.0 + shift, 0, 1, 100.0), cv::Size(kWidth, kHeight),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  return out;
}

Eigen::Isometry3d poseAt(double x) {  // T_cam_world
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(-x, 0.0, 0.0);
  return T;
}

/// A keyframe at x with a 6 x 4 grid of keypoints on the plane (the depth prior of new direct points).
map::KeyFrameId addKeyFrame(map::Map& map, double x, std::vector<Eigen::Vector3d>* points = nullptr) {
  map::KeyFrame kf;
  kf.timestamp = x;
  kf.T_cam_world = poseAt(x);
  kf.camera = testCamera().withoutDistortion();
  kf.setPyramid(1, 1.2);
  std::mt19937 rng(static_cast<unsigned>(x * 1000));
  std::vector<cv::Mat> rows;
  std::vector<Eigen::Vector3d> world;
  for (int gy = 0; gy < 4; ++gy)
    for (int gx = 0; gx < 6; ++gx) {
      const Eigen::Vector3d pw(-1.5 + 0.6 * gx, -0.9 + 0.6 * gy, kPlaneDepth);
      const Eigen::Vector2d px = kf.camera.project(kf.T_cam_world * pw);
      kf.keypoints.emplace_back(cv::Point2f(float(px.x()), float(px.y())), 31.f, 0.f, 1.f, 0);
      cv::Mat d(1, 32, CV_8UC1);
      for (int b = 0; b < 32; ++b) d.at<uchar>(0, b) = static_cast<uchar>(rng() & 255u);
      rows.push_back(d);
      world.push_back(pw);
    }
  cv::vconcat(rows, kf.descriptors);
  if (points) *points = world;
  return map.addKeyFrame(std::move(kf));
}

/// Two keyframes (x = 0 and 0.3 m) sharing 24 map points, both registered with the front end.
struct TwoViews {
  map::Map map;
  map::KeyFrameId kf0 = map::kNoKeyFrame, kf1 = map::kNoKeyFrame;
};
TwoViews makeTwoViews(DirectFrontEnd& fe, const cv::Mat& semantic0 = cv::Mat(), const cv::Mat& semantic1 = cv::Mat()) {
  TwoViews v;
  std::vector<Eigen::Vector3d> pts;
  v.kf0 = addKeyFrame(v.map, 0.0, &pts);
  v.kf1 = addKeyFrame(v.map, 0.3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const map::MapPointId id = v.map.addMapPoint(v.kf0, i, pts[i]);
    v.map.addObservation(id, v.kf1, i);
  }
  fe.addKeyFrame(v.kf0, viewAt(0.0), semantic0, false);
  fe.addKeyFrame(v.kf1, viewAt(0.3), semantic1, false);
  return v;
}

tracking::Frame frameAt(double x, std::size_t index, const cv::Mat& semantic = cv::Mat()) {
  tracking::Frame f;
  f.index = index;
  f.timestamp = static_cast<double>(index);
  f.camera = testCamera().withoutDistortion();
  f.grey = viewAt(x);
  f.semantic = semantic;
  f.T_cam_world = poseAt(x);
  f.hasPose = true;
  return f;
}

landmarks::PointModelParams model(landmarks::MapPointModel m, bool semantic) {
  landmarks::PointModelParams p;
  p.policy.model = m;
  p.semantic = semantic;
  return p;
}

DirectFeaturesParams enabled() {
  DirectFeaturesParams p;
  p.enabled = true;
  p.selector.targetPoints = 1500;
  return p;
}

TEST(DirectFeaturesParams, DefaultsValidAndCoarsestLevelChecked) {
  DirectFeaturesParams p;
  EXPECT_NO_THROW(p.check());
  EXPECT_FALSE(p.enabled);
  p.coarsestLevel = p.pyramidLevels;
  EXPECT_THROW(p.check(), std::exception);
}

TEST(DirectFrontEnd, CreatedPointsLieOnThePlane) {
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe);
  const DirectCreationReport r = fe.createPoints(v.map, v.kf0);
  EXPECT_EQ(r.partner, v.kf1);
  EXPECT_GT(r.selected, 800);
  EXPECT_GT(r.created, r.selected / 2) << "the 30 px shift of a textured plane should be matched";
  const DirectHost& host = fe.hosts().at(v.kf0);
  ASSERT_EQ(static_cast<int>(host.points.size()), r.created);
  for (const DirectMapPoint& p : host.points) {
    const double z = p.landmark->bearing.z() / p.landmark->inverseDepth;
    ASSERT_NEAR(z, kPlaneDepth, 0.05 * kPlaneDepth) << "at pixel " << p.landmark->pixel.transpose();
    // The filter starts at the triangulated depth (eq. 3.1: inverse depth along the host's z axis).
    EXPECT_NEAR(p.state.mu, 1.0 / z, 1e-6);
  }
  EXPECT_EQ(fe.numPoints(), static_cast<std::size_t>(r.created));
}

TEST(DirectFrontEnd, TrackingUsesOnlyActivePointsAndConvergesToTheTruePose) {
  // SEMANTIC: the left half of every image is a dynamic class, the right half static (Table 3.1 channels).
  cv::Mat semantic(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 0, 0));
  semantic(cv::Rect(0, 0, kWidth / 2, kHeight)).setTo(cv::Scalar(0, 255, 0));
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Probabilistic, true), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe, semantic, semantic);
  ASSERT_GT(fe.createPoints(v.map, v.kf0).created, 500);

  // New points start at phi = a / (a + b) = 0.5 < psi_min (a = b = initialCount): a few consistent depth
  // measurements (frames tracked at their true pose) activate the static ones; the dynamic class prior keeps
  // the others inactive longer (§3.3).
  for (int k = 1; k <= 4; ++k) {
    tracking::Frame g = frameAt(0.05 * k, static_cast<std::size_t>(k), semantic);
    const auto fs = fe.photometricFactors(g, v.map, v.kf0);
    fe.afterTracking(g, v.map, std::vector<bool>(fs.size(), false));
  }
  int activeStatic = 0, activeDynamic = 0;
  for (const DirectMapPoint& p : fe.hosts().at(v.kf0).points)
    if (fe.mayUse(p, v.kf0)) (p.landmark->pixel.x() < kWidth / 2 - 3 ? activeDynamic : activeStatic)++;
  EXPECT_GT(activeStatic, 300);
  EXPECT_EQ(activeDynamic, 0);

  // A frame between the keyframes, its pose guess off by 3 cm and 0.5 degree.
  tracking::Frame f = frameAt(0.15, 10, semantic);
  Eigen::Isometry3d guess = f.T_cam_world;
  guess.translation() += Eigen::Vector3d(0.03, -0.02, 0.03);
  guess.linear() = Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()) * guess.linear();
  const Eigen::Isometry3d truth = f.T_cam_world;
  f.T_cam_world = guess;
  const auto factors = fe.photometricFactors(f, v.map, v.kf0);
  ASSERT_GT(factors.size(), 100u);
  int dynamicHost = 0;
  for (const auto& fac : factors) dynamicHost += fac->point().pixel.x() < kWidth / 2 - 3 ? 1 : 0;
  EXPECT_EQ(dynamicHost, 0) << "points of the dynamic half start inactive (phi < psi_min) and must not be used";

  tracking::PoseSolveRequest request;
  request.T_cam_world_initial = guess;
  request.camera = f.camera;
  const auto result = tracking::FullPoseSolver().solveCoarseToFine(request, factors, fe.coarsestLevel());
  EXPECT_LT((result.T_cam_world.translation() - truth.translation()).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(result.T_cam_world.linear() * truth.linear().transpose()).angle(), 0.05 * M_PI / 180.0);
  std::vector<bool> outliers = result.factorOutlier;
  outliers.resize(factors.size());
  int inliers = 0;
  for (bool o : outliers) inliers += o ? 0 : 1;
  EXPECT_GT(inliers, static_cast<int>(factors.size()) * 9 / 10);

  // §3.4.2: the frame measures every point in view, the inactive (dynamic-half) ones included.
  f.T_cam_world = result.T_cam_world;
  const direct::DirectFrameCounts counts = fe.afterTracking(f, v.map, outliers);
  EXPECT_EQ(counts.factors, static_cast<int>(factors.size()));
  EXPECT_EQ(counts.inliers, inliers);
  EXPECT_GT(counts.inactive, 100);
  EXPECT_GT(counts.measured, 500);
  int measuredDynamic = 0;
  for (const DirectMapPoint& p : fe.hosts().at(v.kf0).points)
    measuredDynamic += p.landmark->pixel.x() < kWidth / 2 - 3 && p.updates == 5 ? 1 : 0;
  EXPECT_GT(measuredDynamic, 50);

  // Local BA (§3.4.3) takes the active points of its free keyframes only, each as a residual in the other
  // window keyframe; afterwards their refined inverse depths are the filter means.
  optimize::BAProblem problem;
  problem.keyframes[v.kf0] = {v.map.keyFrame(v.kf0).T_cam_world, v.map.keyFrame(v.kf0).camera, false};
  problem.keyframes[v.kf1] = {v.map.keyFrame(v.kf1).T_cam_world, v.map.keyFrame(v.kf1).camera, true};
  const auto baFactors = fe.bundleAdjustmentFactors(v.map, problem);
  ASSERT_FALSE(baFactors.empty());
  EXPECT_LE(static_cast<int>(baFactors.size()), fe.params().maxBaPoints);
  for (const auto& b : baFactors) {
    const auto* photometric = dynamic_cast<const optimize::PhotometricBAFactor*>(b.get());
    ASSERT_NE(photometric, nullptr);
    EXPECT_EQ(photometric->target(), v.kf1);
    EXPECT_GE(photometric->point().pixel.x(), kWidth / 2 - 3) << "an inactive (dynamic-half) point entered BA";
  }
  auto* first = dynamic_cast<optimize::PhotometricBAFactor*>(baFactors.front().get());
  const double refined = first->point().inverseDepth * 1.01;  // as if BA had moved it
  const_cast<optimize::DirectLandmark&>(first->point()).inverseDepth = refined;
  EXPECT_EQ(fe.applyBundleAdjustment(std::vector<bool>(baFactors.size(), false)), static_cast<int>(baFactors.size()));
  bool found = false;
  for (const DirectMapPoint& p : fe.hosts().at(v.kf0).points)
    if (p.landmark.get() == &first->point()) {
      found = true;
      EXPECT_NEAR(p.state.mu, refined / p.landmark->bearing.z(), 1e-12);
    }
  EXPECT_TRUE(found);
}

TEST(DirectFrontEnd, HeuristicModelUsesEveryPointAndLearnsNothing) {
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe);
  const int created = fe.createPoints(v.map, v.kf0).created;
  tracking::Frame f = frameAt(0.1, 3);
  const auto factors = fe.photometricFactors(f, v.map, v.kf0);
  EXPECT_EQ(static_cast<int>(factors.size()), std::min(created, fe.params().maxTrackingPoints));
  const auto counts = fe.afterTracking(f, v.map, std::vector<bool>(factors.size(), false));
  EXPECT_EQ(counts.inactive, 0);
  EXPECT_EQ(counts.measured, 0) << "ORB-SLAM* (heuristic) keeps no model to update";
}

TEST(DirectFrontEnd, PruneDropsPointsOfErasedKeyFramesAndOldImages) {
  DirectFeaturesParams p = enabled();
  p.keepImages = 2;
  DirectFrontEnd fe(p, model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe);
  const int created0 = fe.createPoints(v.map, v.kf0).created;
  ASSERT_GT(fe.createPoints(v.map, v.kf1).created, 0);
  const map::KeyFrameId kf2 = addKeyFrame(v.map, 0.6);
  fe.addKeyFrame(kf2, viewAt(0.6), cv::Mat(), false);
  fe.prune(v.map);
  EXPECT_TRUE(fe.hosts().at(v.kf0).grey.empty()) << "only the 2 most recent keyframes keep their image";
  EXPECT_FALSE(fe.hosts().at(kf2).grey.empty());
  v.map.eraseKeyFrame(v.kf1);
  fe.prune(v.map);
  EXPECT_EQ(fe.hosts().count(v.kf1), 0u);
  EXPECT_EQ(fe.numPoints(), static_cast<std::size_t>(created0));
}

TEST(DirectFrontEnd, MissingImagesAreNamed) {
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  EXPECT_THROW(fe.addKeyFrame(3, cv::Mat(), cv::Mat(), false), Error);
  TwoViews v = makeTwoViews(fe);
  fe.createPoints(v.map, v.kf0);
  tracking::Frame f = frameAt(0.1, 4);
  f.grey = cv::Mat();
  try {
    fe.photometricFactors(f, v.map, v.kf0);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 4"), std::string::npos) << e.what();
  }
}

TEST(DirectFrontEnd, TheStoreSavedWithTheMapComesBackAndTracksWithoutItsImages) {
  // map.slammap carries the direct points (extension "direct_points"): what comes back is every point that was not
  // culled, with its landmark, model state and counters, byte for byte; without the host images the points still
  // give a pose (their host intensities travel with them).
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe);
  ASSERT_GT(fe.createPoints(v.map, v.kf0).created, 500);
  tracking::Frame g = frameAt(0.1, 1);
  const auto fs = fe.photometricFactors(g, v.map, v.kf0);
  fe.afterTracking(g, v.map, std::vector<bool>(fs.size(), false));  // counters move
  const_cast<DirectMapPoint&>(fe.hosts().at(v.kf0).points[7]).bad = true;  // culled: not saved
  const std::string bytes = fe.serialize();

  DirectFrontEnd loaded(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  loaded.restore(bytes, v.map);
  EXPECT_EQ(loaded.numPoints(), fe.numPoints());
  EXPECT_EQ(loaded.serialize(), bytes) << "saved again, the same bytes";
  const DirectHost& host = loaded.hosts().at(v.kf0);
  EXPECT_TRUE(host.grey.empty());
  std::size_t compared = 0;
  for (const DirectMapPoint& p : fe.hosts().at(v.kf0).points) {
    if (p.bad) continue;
    const DirectMapPoint& q = host.points.at(compared++);
    EXPECT_EQ(q.landmark->pixel, p.landmark->pixel);
    EXPECT_EQ(q.landmark->inverseDepth, p.landmark->inverseDepth);
    EXPECT_EQ(q.landmark->hostIntensities, p.landmark->hostIntensities);
    EXPECT_EQ(q.landmark->host, v.kf0);
    EXPECT_EQ(q.state.mu, p.state.mu);
    EXPECT_EQ(q.visible, p.visible);
    EXPECT_EQ(q.found, p.found);
  }
  EXPECT_EQ(compared, host.points.size());

  tracking::Frame f = frameAt(0.15, 10);
  const Eigen::Isometry3d truth = f.T_cam_world;
  Eigen::Isometry3d guess = truth;
  guess.translation() += Eigen::Vector3d(0.03, -0.02, 0.03);
  f.T_cam_world = guess;
  const auto factors = loaded.photometricFactors(f, v.map, v.kf0);
  ASSERT_GT(factors.size(), 100u);
  tracking::PoseSolveRequest request;
  request.T_cam_world_initial = guess;
  request.camera = f.camera;
  const auto result = tracking::FullPoseSolver().solveCoarseToFine(request, factors, loaded.coarsestLevel());
  EXPECT_LT((result.T_cam_world.translation() - truth.translation()).norm(), 0.005);
}

TEST(DirectFrontEnd, ADamagedStoreIsRefusedAndLeavesTheStoreAsItWas) {
  DirectFrontEnd fe(enabled(), model(landmarks::MapPointModel::Heuristic, false), testCamera(), 1.0);
  TwoViews v = makeTwoViews(fe);
  ASSERT_GT(fe.createPoints(v.map, v.kf0).created, 500);
  const std::string good = fe.serialize();
  const std::size_t points = fe.numPoints();
  // Offsets: magic 4 + version 1 + hosts 8 | host id 8 + affine 16 + points 8 | first point: pixel 16, ...
  const std::size_t host = 13, firstPoint = host + 32;
  auto withDouble = [&](std::size_t at, double value) {
    std::string b = good;
    std::memcpy(&b[at], &value, sizeof value);
    return b;
  };
  std::string otherHost = good;
  const std::uint64_t missing = 999;
  std::memcpy(&otherHost[host], &missing, sizeof missing);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {good.substr(0, good.size() / 2), "direct points: truncated"},
      {"PSLN" + good.substr(4), "direct points: not a direct point store (bad magic)"},
      {good + "x", "direct points: unexpected bytes after the last host"},
      {otherHost, "direct points: host keyframe 999 is not in the map"},
      {withDouble(host + 8, 5.0), "affine a outside [-1, 1]"},
      {withDouble(firstPoint, -5.0), "pixel outside the keyframe's image"},
      {withDouble(firstPoint + 16, std::nan("")), "direct points: bearing is NaN or Inf"},
      {withDouble(firstPoint + 16, 0.5), "bearing is not a unit vector"},
      {withDouble(firstPoint + 40, -0.2), "inverse depth <= 0"},
  };
  for (const auto& [bytes, message] : cases) {
    try {
      fe.restore(bytes, v.map);
      ADD_FAILURE() << "accepted: " << message;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
    EXPECT_EQ(fe.numPoints(), points) << "the store is kept when the bytes are refused";
  }
  EXPECT_EQ(fe.serialize(), good);
}

}  // namespace
}  // namespace pslam::direct
