// PhotometricBAFactor: the analytic Jacobians against ceres::GradientChecker and against automatic
// differentiation of the same cost written with Eigen quaternions and Jets, for every affine layout; the same
// residual as the pose factor; and local BA with photometric factors alone
// on a textured plane seen by four keyframes with different exposures (poses, inverse depths and the free
// affine brightness get closer to the truth; occluded patches are reported as factor outliers).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>

#include <ceres/autodiff_cost_function.h>
#include <ceres/gradient_checker.h>

#include "SyntheticProblem.h"
#include "SyntheticTexture.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/PhotometricBAFactor.h"
#include "pslam/optimize/PhotometricPoseFactor.h"
#include "pslam/optimize/PoseParameterization.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;
using pslam::map::KeyFrameId;

namespace {

struct KeyFrameTruth {
  Eigen::Isometry3d T;
  AffineBrightness exposure;
};

const std::vector<KeyFrameTruth>& truthKeyFrames() {
  static const std::vector<KeyFrameTruth> kfs{
      {cameraAt({0, 0, 0}, {0, 0, 0}), {0.0, 0.0}},
      {cameraAt({0.3, -0.05, 0.1}, {0.01, -0.04, 0.02}), {0.1, 0.02}},
      {cameraAt({-0.25, 0.1, 0.05}, {-0.02, 0.03, -0.01}), {-0.1, 0.05}},
      {cameraAt({0.1, 0.2, -0.1}, {0.03, 0.01, 0.015}), {0.2, -0.03}}};
  return kfs;
}

struct PlaneBA {
  pslam::geometry::PinholeCamera cam = textureCamera();
  std::vector<cv::Mat> images;
  std::vector<std::shared_ptr<const ImagePyramid>> pyramids;
  std::vector<std::shared_ptr<AffineBlock>> affine;
  std::vector<std::shared_ptr<DirectLandmark>> points;
  std::vector<double> trueInverseDepth;
  BAProblem problem;
  std::vector<bool> occludedFactor;

  /// Points hosted in keyframe 0, observed in every other keyframe where their pattern is inside the image at
  /// the truth. Keyframes 0 and 1 fixed (gauge and scale) with their exposure; 2 and 3 free.
  explicit PlaneBA(bool occlude = false) {
    const auto& kfs = truthKeyFrames();
    for (std::size_t k = 0; k < kfs.size(); ++k) {
      images.push_back(renderPlane(kfs[k].T, cam, kfs[k].exposure));
      auto a = std::make_shared<AffineBlock>();
      a->fixed = k < 2;
      a->ab = {kfs[k].exposure.a, kfs[k].exposure.b};
      affine.push_back(a);
      BAKeyFrame kf;
      kf.T_cam_world = kfs[k].T;
      kf.camera = cam;
      kf.fixed = k < 2;
      problem.keyframes[k] = kf;
    }
    const ImagePyramid host(images[0], 1);
    const auto samples = pickHostPixels(images[0], kfs[0].T, cam, 32, 20);
    // Occlude in keyframe 3 the patch of every 8th point without another point within 12 pixels there (a 15 x 15
    // square of the opposite brightness covers its pattern and no other).
    std::vector<bool> occludedPoint(samples.size(), false);
    std::vector<Eigen::Vector2d> inKf3;
    for (const auto& sample : samples)
      inKf3.push_back(cam.project(kfs[3].T * (kfs[0].T.inverse() * (cam.unprojectToBearing(sample.pixel) / sample.inverseDepth))));
    for (std::size_t i = 3; occlude && i < samples.size(); i += 8) {
      bool isolated = true;
      for (std::size_t j = 0; j < samples.size(); ++j)
        isolated = isolated && (j == i || (inKf3[j] - inKf3[i]).lpNorm<Eigen::Infinity>() > 12.0);
      const int x = static_cast<int>(std::lround(inKf3[i].x())), y = static_cast<int>(std::lround(inKf3[i].y()));
      if (!isolated || x < 10 || y < 10 || x >= cam.width - 10 || y >= cam.height - 10) continue;
      images[3](cv::Rect(x - 7, y - 7, 15, 15)).setTo(images[3].at<unsigned char>(y, x) < 128 ? 255 : 0);
      occludedPoint[i] = true;
    }
    for (const cv::Mat& img : images) pyramids.push_back(std::make_shared<const ImagePyramid>(img, 1));
    for (std::size_t i = 0; i < samples.size(); ++i) {
      auto p = std::make_shared<DirectLandmark>(DirectLandmark::create(0, samples[i].pixel, samples[i].inverseDepth, cam, host));
      for (KeyFrameId k = 1; k < kfs.size(); ++k) {
        const PatternError pe = evaluatePattern(*p, 0, patternRays(*p, cam, 0), kfs[k].T * kfs[0].T.inverse(),
                                                p->inverseDepth, cam, pyramids[k]->level(0), kfs[0].exposure,
                                                kfs[k].exposure);
        if (!pe.valid) continue;
        problem.factors.push_back(
            std::make_shared<PhotometricBAFactor>(p, k, pyramids[k], cam, affine[0], affine[k]));
        occludedFactor.push_back(k == 3 && occludedPoint[i]);
      }
      points.push_back(p);
      trueInverseDepth.push_back(samples[i].inverseDepth);
    }
  }

  /// Free poses perturbed, inverse depths scaled by 1 +- 3 %, free affine parameters reset to (0, 0).
  void perturb() {
    std::mt19937 rng(21);
    for (KeyFrameId k : {2, 3}) problem.keyframes[k].T_cam_world = pslam::optimize::testing::perturb(truthKeyFrames()[k].T, 0.003, 0.01, rng);
    for (std::size_t i = 0; i < points.size(); ++i) points[i]->inverseDepth *= 1.0 + 0.03 * std::sin(1.7 * i + 0.4);
    for (std::size_t k = 2; k < affine.size(); ++k) affine[k]->ab = {0.0, 0.0};
  }

  double medianInverseDepthError() const {
    std::vector<double> e;
    for (std::size_t i = 0; i < points.size(); ++i)
      e.push_back(std::abs(points[i]->inverseDepth / trueInverseDepth[i] - 1.0));
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    return e[e.size() / 2];
  }
};

/// The cost of PhotometricError.h written independently for automatic differentiation over all five blocks
/// [pose_i, pose_j, rho, affine_i, affine_j] (quaternion products, the Jet overload of the interpolant).
struct AutoDiffPhotometricCost {
  std::array<Eigen::Vector3d, kPatternSize> rays;
  std::vector<double> host;
  double bearingZ;
  pslam::geometry::PinholeCamera camera;  // of the level
  const cv::Mat* target;
  double whitening;

  AutoDiffPhotometricCost(const DirectLandmark& p, const ImagePyramid& image, const pslam::geometry::PinholeCamera& cam, int level)
      : rays(patternRays(p, cam, level)),
        host(p.hostIntensities[static_cast<std::size_t>(level)]),
        bearingZ(p.bearing.z()),
        camera(levelCamera(cam, level)),
        target(&image.level(level)),
        whitening(PhotometricParams().whiteningScale()) {}

  template <typename T>
  bool operator()(const T* pi, const T* pj, const T* rho, const T* ai, const T* aj, T* r) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> qi(pi), qj(pj);
    const Eigen::Map<const V3> ti(pi + 4), tj(pj + 4);
    const T rhoZ = rho[0] / T(bearingZ);
    for (int k = 0; k < kPatternSize; ++k) {
      const V3 q = qj * (qi.conjugate() * (rays[static_cast<std::size_t>(k)].cast<T>() - rhoZ * ti)) + rhoZ * tj;
      const T ux = T(camera.fx) * q.x() / q.z() + T(camera.cx), uy = T(camera.fy) * q.y() / q.z() + T(camera.cy);
      r[k] = T(whitening) * (sampleBilinear(*target, ux, uy) - aj[1] -
                             ceres::exp(aj[0] - ai[0]) * (T(host[static_cast<std::size_t>(k)]) - ai[1]));
    }
    return true;
  }
};

bool checkGradients(const BAFactor& f, const std::vector<double*>& blocks, std::string& log) {
  std::unique_ptr<ceres::CostFunction> cost(f.newCostFunction());
  PoseManifold poseManifold;
  std::vector<const ceres::Manifold*> manifolds(blocks.size(), nullptr);
  manifolds[0] = manifolds[1] = &poseManifold;
  // Ridders' extrapolation (GradientChecker) from a small first step: the bilinear interpolant is smooth only
  // inside a pixel cell, so the default 1 % first step (a 0.01 change of q_w is a ~5 pixel move) crosses cells.
  ceres::NumericDiffOptions options;
  options.ridders_relative_initial_step_size = 1e-5;
  const ceres::GradientChecker checker(cost.get(), &manifolds, options);
  ceres::GradientChecker::ProbeResults results;
  const bool ok = checker.Probe(blocks.data(), 1e-6, &results);
  log = results.error_log;
  return ok;
}

}  // namespace

TEST(PhotometricBAFactor, GradientCheckerForEveryAffineLayout) {
  const auto& kfs = truthKeyFrames();
  const auto cam = textureCamera();
  const ImagePyramid host(renderPlane(kfs[0].T, cam, kfs[0].exposure), 1);
  auto target = std::make_shared<const ImagePyramid>(renderPlane(kfs[1].T, cam, kfs[1].exposure), 1);
  std::mt19937 rng(3);
  PoseParameters poseHost = toPoseParameters(pslam::optimize::testing::perturb(kfs[0].T, 0.001, 0.004, rng));
  PoseParameters poseTarget = toPoseParameters(pslam::optimize::testing::perturb(kfs[1].T, 0.002, 0.006, rng));
  int checked = 0;
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(200.3, 150.7), Eigen::Vector2d(412.6, 301.2), Eigen::Vector2d(90.1, 380.4)}) {
    auto p = std::make_shared<DirectLandmark>(DirectLandmark::create(
        0, px, 1.0 / (kfs[0].T * planePoint(kfs[0].T, cam, px)).norm() * 1.02, cam, host));
    for (int layout = 0; layout < 4; ++layout) {
      auto ah = std::make_shared<AffineBlock>(), at = std::make_shared<AffineBlock>();
      ah->ab = {0.03, 0.01};
      at->ab = {0.12, 0.015};
      ah->fixed = !(layout & 1);
      at->fixed = !(layout & 2);
      const PhotometricBAFactor f(p, 1, target, cam, ah, at);
      std::vector<double*> blocks{poseHost.data(), poseTarget.data()};
      for (double* b : f.landmarkBlocks()) blocks.push_back(b);
      for (double* b : f.sharedBlocks()) blocks.push_back(b);
      ASSERT_EQ(blocks.size(), 3u + (layout & 1 ? 1u : 0u) + (layout & 2 ? 1u : 0u));
      std::string log;
      EXPECT_TRUE(checkGradients(f, blocks, log)) << "layout " << layout << "\n" << log;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 12);
}

TEST(PhotometricBAFactor, AnalyticJacobiansEqualAutomaticDifferentiation) {
  const auto& kfs = truthKeyFrames();
  const auto cam = textureCamera();
  const ImagePyramid host(renderPlane(kfs[0].T, cam, kfs[0].exposure), 2);
  auto target = std::make_shared<const ImagePyramid>(renderPlane(kfs[3].T, cam, kfs[3].exposure), 2);
  std::mt19937 rng(12);
  PoseParameters poseHost = toPoseParameters(pslam::optimize::testing::perturb(kfs[0].T, 0.002, 0.01, rng));
  PoseParameters poseTarget = toPoseParameters(pslam::optimize::testing::perturb(kfs[3].T, 0.002, 0.01, rng));
  poseTarget[3] *= 1.001;  // off the unit sphere: the ambient derivatives must still agree
  int compared = 0;
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(250.4, 180.2), Eigen::Vector2d(380.7, 260.9)}) {
    auto p = std::make_shared<DirectLandmark>(DirectLandmark::create(0, px, 0.24, cam, host));
    for (int level : {0, 1}) {
      const AutoDiffPhotometricCost reference(*p, *target, cam, level);
      ceres::AutoDiffCostFunction<AutoDiffPhotometricCost, 9, 7, 7, 1, 2, 2> autodiff(new AutoDiffPhotometricCost(reference));
      for (int layout = 0; layout < 4; ++layout) {
        auto ah = std::make_shared<AffineBlock>(), at = std::make_shared<AffineBlock>();
        ah->ab = {-0.04, 0.02};
        at->ab = {0.17, -0.02};
        ah->fixed = !(layout & 1);
        at->fixed = !(layout & 2);
        const PhotometricBAFactor f(p, 3, target, cam, ah, at, level);
        std::unique_ptr<ceres::CostFunction> cost(f.newCostFunction());
        std::vector<double*> blocks{poseHost.data(), poseTarget.data(), &p->inverseDepth};
        for (double* b : f.sharedBlocks()) blocks.push_back(b);
        std::vector<std::vector<double>> J;
        std::vector<double*> jac;
        for (int size : cost->parameter_block_sizes()) J.emplace_back(static_cast<std::size_t>(9 * size));
        for (auto& j : J) jac.push_back(j.data());
        double r[9], rRef[9], jRef0[63], jRef1[63], jRef2[9], jRef3[18], jRef4[18];
        double* jacRef[5] = {jRef0, jRef1, jRef2, jRef3, jRef4};
        ASSERT_TRUE(cost->Evaluate(blocks.data(), r, jac.data()));
        const double* all[5] = {poseHost.data(), poseTarget.data(), &p->inverseDepth, ah->ab.data(), at->ab.data()};
        ASSERT_TRUE(autodiff.Evaluate(all, rRef, jacRef));
        std::vector<const double*> refBlocks{jRef0, jRef1, jRef2};
        if (layout & 1) refBlocks.push_back(jRef3);
        if (layout & 2) refBlocks.push_back(jRef4);
        ASSERT_EQ(refBlocks.size(), J.size());
        for (int k = 0; k < 9; ++k) EXPECT_NEAR(r[k], rRef[k], 1e-12);
        for (std::size_t b = 0; b < J.size(); ++b)
          for (std::size_t i = 0; i < J[b].size(); ++i)
            EXPECT_NEAR(J[b][i], refBlocks[b][i], 1e-9 * (1.0 + std::abs(refBlocks[b][i])))
                << "layout " << layout << " level " << level << " block " << b << " entry " << i;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 16);
}

TEST(PhotometricBAFactor, SameResidualAsThePoseFactor) {
  const auto& kfs = truthKeyFrames();
  const auto cam = textureCamera();
  const ImagePyramid host(renderPlane(kfs[0].T, cam, kfs[0].exposure), 2);
  auto target = std::make_shared<const ImagePyramid>(renderPlane(kfs[2].T, cam, kfs[2].exposure), 2);
  std::mt19937 rng(8);
  const Eigen::Isometry3d Th = pslam::optimize::testing::perturb(kfs[0].T, 0.002, 0.01, rng);
  const Eigen::Isometry3d Tt = pslam::optimize::testing::perturb(kfs[2].T, 0.002, 0.01, rng);
  auto ah = std::make_shared<AffineBlock>(), at = std::make_shared<AffineBlock>();
  ah->ab = {0.02, -0.01};
  at->ab = {-0.08, 0.04};
  at->fixed = false;
  const auto p = std::make_shared<DirectLandmark>(DirectLandmark::create(0, {300.2, 200.9}, 0.24, cam, host));
  for (int level : {0, 1}) {
    const PhotometricBAFactor ba(p, 2, target, cam, ah, at, level);
    const PhotometricPoseFactor pose(p, Th, ah->value(), target, at->value(), cam, level);
    PoseParameters ph = toPoseParameters(Th), pt = toPoseParameters(Tt);
    std::vector<double*> blocks{ph.data(), pt.data(), &p->inverseDepth};
    for (double* b : ba.sharedBlocks()) blocks.push_back(b);  // the target's (a, b)
    ASSERT_EQ(blocks.size(), 4u);
    std::unique_ptr<ceres::CostFunction> cost(ba.newCostFunction());
    Eigen::Matrix<double, 9, 1> rBA;
    ASSERT_TRUE(cost->Evaluate(blocks.data(), rBA.data(), nullptr));
    Eigen::VectorXd rPose;
    ASSERT_TRUE(pose.evaluate(Tt, rPose, nullptr));
    EXPECT_LT((rBA - rPose).norm(), 1e-9) << "level " << level;
    EXPECT_EQ(ba.huberDelta(), pose.huberDelta());
    EXPECT_EQ(ba.chi2Threshold(), pose.chi2Threshold());
  }
  EXPECT_THROW(PhotometricBAFactor(p, 0, target, cam), pslam::Error);  // target == host
  EXPECT_THROW(PhotometricBAFactor(p, 2, target, cam, nullptr, nullptr, 2), pslam::Error);
}

TEST(PhotometricBAFactor, LocalBundleAdjustmentReducesTheError) {
  PlaneBA s;
  ASSERT_GE(s.points.size(), 150u);
  s.perturb();
  const auto& kfs = truthKeyFrames();
  double rotBefore = 0.0, centreBefore = 0.0;
  for (KeyFrameId k : {2, 3}) {
    rotBefore += rotationErrorRad(s.problem.keyframes[k].T_cam_world, kfs[k].T);
    centreBefore += centreError(s.problem.keyframes[k].T_cam_world, kfs[k].T);
  }
  const double depthBefore = s.medianInverseDepthError();
  BundleAdjustmentParams params;
  params.firstPassIterations = 10;
  params.secondPassIterations = 10;
  const BAResult r = localBundleAdjustment(s.problem, params);
  double rotAfter = 0.0, centreAfter = 0.0;
  for (KeyFrameId k : {2, 3}) {
    ASSERT_TRUE(r.poses.count(k));
    rotAfter += rotationErrorRad(r.poses.at(k), kfs[k].T);
    centreAfter += centreError(r.poses.at(k), kfs[k].T);
  }
  const double depthAfter = s.medianInverseDepthError();
  std::printf("BA, %zu photometric factors, %d iterations, %.1f ms: cost %.4g -> %.4g; rotation %.2e -> %.2e rad, "
              "centre %.2e -> %.2e m, median |rho/rho_true - 1| %.3f -> %.4f\n",
              s.problem.factors.size(), r.iterations, 1e3 * r.solveSeconds, r.initialCost, r.finalCost, rotBefore,
              rotAfter, centreBefore, centreAfter, depthBefore, depthAfter);
  for (std::size_t k = 2; k < 4; ++k)
    std::printf("  keyframe %zu affine (%.4f, %.4f), truth (%.4f, %.4f)\n", k, s.affine[k]->ab[0], s.affine[k]->ab[1],
                kfs[k].exposure.a, kfs[k].exposure.b);
  EXPECT_LT(r.finalCost, 0.1 * r.initialCost);
  EXPECT_LT(rotAfter, 0.1 * rotBefore);
  EXPECT_LT(centreAfter, 0.1 * centreBefore);
  EXPECT_LT(depthAfter, 0.2 * depthBefore);
  // The affine brightness: the intensity predicted for mid-grey radiance is right; the gain comes out ~1 % low,
  // a bias of the bilinear interpolation of the target (it attenuates the texture's finest component, 14 pixels
  // per period) -- the truth has a higher cost than the estimate.
  for (std::size_t k = 2; k < 4; ++k) {
    EXPECT_NEAR(std::exp(s.affine[k]->ab[0]) * 0.5 + s.affine[k]->ab[1],
                std::exp(kfs[k].exposure.a) * 0.5 + kfs[k].exposure.b, 3e-3) << k;
    EXPECT_NEAR(s.affine[k]->ab[0], kfs[k].exposure.a, 0.02) << k;
  }
  EXPECT_EQ(s.affine[1]->ab[0], kfs[1].exposure.a);  // fixed blocks stay
  EXPECT_TRUE(r.factorOutliers.empty());
}

TEST(PhotometricBAFactor, OccludedPatchesAreFactorOutliers) {
  PlaneBA s(true);
  s.perturb();
  const BAResult r = localBundleAdjustment(s.problem);
  std::vector<bool> flagged(s.problem.factors.size(), false);
  for (std::size_t i : r.factorOutliers) flagged[i] = true;
  int occluded = 0, missed = 0, falseAlarms = 0;
  for (std::size_t i = 0; i < flagged.size(); ++i) {
    occluded += s.occludedFactor[i] ? 1 : 0;
    missed += s.occludedFactor[i] && !flagged[i] ? 1 : 0;
    falseAlarms += !s.occludedFactor[i] && flagged[i] ? 1 : 0;
  }
  std::printf("BA outliers: %zu flagged, %d occluded, %d missed, %d false alarms\n", r.factorOutliers.size(), occluded,
              missed, falseAlarms);
  ASSERT_GE(occluded, 6);
  EXPECT_EQ(missed, 0);
  EXPECT_EQ(falseAlarms, 0);
  EXPECT_LT(rotationErrorRad(r.poses.at(3), truthKeyFrames()[3].T), 5e-4);
}

TEST(PhotometricBAFactor, TimingOfOneCostEvaluation) {
  PlaneBA s;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  std::vector<std::vector<double*>> blocks;
  std::vector<PoseParameters> poses;
  for (std::size_t k = 0; k < 4; ++k) poses.push_back(toPoseParameters(truthKeyFrames()[k].T));
  auto poseParams = [&](std::size_t k) -> const double* { return poses[k].data(); };
  for (const auto& f : s.problem.factors) {
    costs.emplace_back(f->newCostFunction());
    std::vector<double*> b;
    for (KeyFrameId k : f->keyframes()) b.push_back(poses[k].data());
    for (double* x : f->landmarkBlocks()) b.push_back(x);
    for (double* x : f->sharedBlocks()) b.push_back(x);
    blocks.push_back(b);
  }
  double r[9], jPose0[9 * 7], jPose1[9 * 7], jRho[9], jA[9 * 2];
  double* jac[4] = {jPose0, jPose1, jRho, jA};  // the layout here: poses, rho, the target's free affine
  const int n = 100000;
  double sink = 0.0;
  for (std::size_t j = 0; j < costs.size(); ++j) costs[j]->Evaluate(blocks[j].data(), r, jac);  // warm-up
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    const std::size_t j = static_cast<std::size_t>(i) % costs.size();
    costs[j]->Evaluate(blocks[j].data(), r, jac);
    sink += r[0];
  }
  const auto t1 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    const std::size_t j = static_cast<std::size_t>(i) % costs.size();
    costs[j]->Evaluate(blocks[j].data(), r, nullptr);
    sink += r[0];
  }
  const auto t2 = std::chrono::steady_clock::now();
  std::printf("PhotometricBAFactor cost (9 residuals, blocks 7+7+1(+2)): %.2f us with Jacobians, %.2f us without (sink %g)\n",
              std::chrono::duration<double, std::micro>(t1 - t0).count() / n,
              std::chrono::duration<double, std::micro>(t2 - t1).count() / n, sink);
  // The same cost by automatic differentiation (blocks 7+7+1+2+2), for comparison.
  const auto& p = static_cast<const PhotometricBAFactor&>(*s.problem.factors[0]).point();
  ceres::AutoDiffCostFunction<AutoDiffPhotometricCost, 9, 7, 7, 1, 2, 2> autodiff(
      new AutoDiffPhotometricCost(p, *s.pyramids[1], s.cam, 0));
  double rho = p.inverseDepth;
  const double* all[5] = {poseParams(0), poseParams(1), &rho, s.affine[0]->ab.data(), s.affine[1]->ab.data()};
  double jB[18], jC[18];
  double* jacAll[5] = {jPose0, jPose1, jRho, jB, jC};
  const int m = n / 10;
  const auto t3 = std::chrono::steady_clock::now();
  for (int i = 0; i < m; ++i) {
    autodiff.Evaluate(all, r, jacAll);
    sink += r[0];
  }
  const auto t4 = std::chrono::steady_clock::now();
  std::printf("  automatic differentiation of the same cost: %.2f us with Jacobians (sink %g)\n",
              std::chrono::duration<double, std::micro>(t4 - t3).count() / m, sink);
}
