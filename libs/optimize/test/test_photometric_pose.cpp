// PhotometricPoseFactor: the analytic Jacobian against central differences, motion-only optimization with
// photometric factors alone on a textured plane seen from two poses (one level, and coarse to fine from a
// larger error), occluded patches flagged by the chi2_P = 0.05 N_P threshold, and the cost of one evaluation.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>

#include "SyntheticProblem.h"
#include "SyntheticTexture.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/PhotometricPoseFactor.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

namespace {

struct TwoViews {
  pslam::geometry::PinholeCamera cam = textureCamera();
  Eigen::Isometry3d T_host = cameraAt({0, 0, 0}, {0, 0, 0});
  Eigen::Isometry3d T_target = cameraAt({0.3, -0.05, 0.1}, {0.01, -0.04, 0.02});
  AffineBrightness hostAffine{0.0, 0.0}, targetAffine{0.15, 0.03};
  cv::Mat hostImage, targetImage;
  std::vector<std::shared_ptr<const DirectLandmark>> points;
  std::vector<bool> occluded;  ///< per point: its patch is covered in the target image

  /// `occludeEvery` > 0: the target patch of every n-th point without another point within 12 pixels (so that the
  /// square covers its pattern and no other) is covered by a 15 x 15 square of the opposite brightness.
  explicit TwoViews(int levels = 4, int occludeEvery = 0) {
    hostImage = renderPlane(T_host, cam, hostAffine);
    targetImage = renderPlane(T_target, cam, targetAffine);
    const ImagePyramid hostPyr(hostImage, levels);
    const auto samples = pickHostPixels(hostImage, T_host, cam, 28, 20);
    std::vector<Eigen::Vector2d> projected;
    for (const auto& sample : samples)
      projected.push_back(cam.project(T_target * T_host.inverse() * (cam.unprojectToBearing(sample.pixel) / sample.inverseDepth)));
    for (std::size_t i = 0; i < samples.size(); ++i) {
      points.push_back(std::make_shared<DirectLandmark>(
          DirectLandmark::create(0, samples[i].pixel, samples[i].inverseDepth, cam, hostPyr)));
      bool isolated = true;
      for (std::size_t j = 0; j < samples.size(); ++j)
        isolated = isolated && (j == i || (projected[j] - projected[i]).lpNorm<Eigen::Infinity>() > 12.0);
      const int x = static_cast<int>(std::lround(projected[i].x())), y = static_cast<int>(std::lround(projected[i].y()));
      const bool occlude = occludeEvery > 0 && i % static_cast<std::size_t>(occludeEvery) == 3 && isolated &&
                           x >= 10 && y >= 10 && x < cam.width - 10 && y < cam.height - 10;
      occluded.push_back(occlude);
      if (occlude)
        targetImage(cv::Rect(x - 7, y - 7, 15, 15)).setTo(targetImage.at<unsigned char>(y, x) < 128 ? 255 : 0);
    }
  }

  std::vector<std::shared_ptr<const PhotometricPoseFactor>> factors(int levels, int level = 0) const {
    auto target = std::make_shared<const ImagePyramid>(targetImage, levels);
    std::vector<std::shared_ptr<const PhotometricPoseFactor>> out;
    for (const auto& p : points)
      out.push_back(std::make_shared<PhotometricPoseFactor>(p, T_host, hostAffine, target, targetAffine, cam, level));
    return out;
  }
  static std::vector<std::shared_ptr<const PoseFactor>> asPoseFactors(
      const std::vector<std::shared_ptr<const PhotometricPoseFactor>>& f) {
    return {f.begin(), f.end()};
  }
};

}  // namespace

TEST(PhotometricPoseFactor, JacobianMatchesCentralDifferences) {
  const TwoViews s(3);
  std::mt19937 rng(4);
  const Eigen::Isometry3d T = perturb(s.T_target, 0.002, 0.005, rng);
  const auto factors = s.factors(3);
  int checked = 0, skippedRows = 0;
  for (int level : {0, 2}) {
    for (std::size_t i = 0; i < factors.size(); i += 23) {
      const auto f = factors[i]->atLevel(level);
      Eigen::VectorXd r0, rp, rm;
      Eigen::MatrixXd J;
      if (!f->evaluate(T, r0, &J)) continue;
      ASSERT_EQ(J.rows(), 9);
      ASSERT_EQ(J.cols(), 6);
      // The bilinear interpolant is not differentiable across pixel-cell boundaries: rows whose sample lies within
      // 2e-3 pixels of one (the central difference moves it by < 1e-3 pixels) are not compared.
      const PatternError pe = f->patternError(T);
      Eigen::Matrix<double, 9, 1> compared = Eigen::Matrix<double, 9, 1>::Ones();
      for (int row = 0; row < 9; ++row) {
        const Eigen::Vector2d& u = pe.u[static_cast<std::size_t>(row)];
        const double dx = std::abs(u.x() - std::round(u.x())), dy = std::abs(u.y() - std::round(u.y()));
        if (dx < 2e-3 || dy < 2e-3) compared[row] = 0.0;
      }
      skippedRows += 9 - static_cast<int>(compared.sum());
      for (int k = 0; k < 6; ++k) {
        Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
        const double h = 1e-6;
        xi[k] = h;
        f->evaluate(retractPoseLeft(xi, T), rp, nullptr);
        xi[k] = -h;
        f->evaluate(retractPoseLeft(xi, T), rm, nullptr);
        const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
        EXPECT_LT((numeric - J.col(k)).cwiseProduct(compared).norm(), 1e-5 * (1.0 + J.col(k).norm()))
            << "point " << i << " level " << level << " column " << k << "\n" << numeric.transpose() << "\n"
            << J.col(k).transpose();
      }
      ++checked;
    }
  }
  EXPECT_GE(checked, 20);
  EXPECT_LE(skippedRows, 3);
  // A point at infinity (rho = 0) constrains the rotation only: zero translation columns.
  auto far = std::make_shared<DirectLandmark>(factors[5]->point());
  far->inverseDepth = 0.0;
  const PhotometricPoseFactor atInfinity(far, s.T_host, s.hostAffine, std::make_shared<ImagePyramid>(s.targetImage, 1),
                                         s.targetAffine, s.cam);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  ASSERT_TRUE(atInfinity.evaluate(T, r, &J));
  EXPECT_EQ(J.rightCols<3>().norm(), 0.0);
  EXPECT_GT(J.leftCols<3>().norm(), 0.0);
}

TEST(PhotometricPoseFactor, ResidualIsZeroAtTheTruthUpToRendering) {
  const TwoViews s(1);
  const auto factors = s.factors(1);
  ASSERT_GE(factors.size(), 200u);
  ASSERT_LE(factors.size(), 500u);
  int valid = 0, inliers = 0;
  for (const auto& f : factors) {
    Eigen::VectorXd r;
    if (!f->evaluate(s.T_target, r, nullptr)) continue;
    ++valid;
    inliers += r.squaredNorm() <= f->chi2Threshold() ? 1 : 0;
    EXPECT_LT(r.norm() / f->huberDelta(), 0.3);  // far inside the quadratic part of the Huber loss
  }
  EXPECT_GE(valid, 200);
  EXPECT_EQ(inliers, valid);
  EXPECT_EQ(factors[0]->kind(), "direct");
  EXPECT_EQ(factors[0]->dimension(), 9);
}

TEST(PhotometricPoseFactor, PoseOptimizationConvergesOnATexturedPlane) {
  const TwoViews s(1);
  const auto factors = s.factors(1);
  std::mt19937 rng(7);
  const Eigen::Isometry3d start = perturb(s.T_target, 0.004, 0.02, rng);  // ~2-3 pixels
  const PoseOptimizationResult r = optimizePose(start, s.cam, {}, {}, {}, TwoViews::asPoseFactors(factors));
  std::printf("one level: start %.4f rad %.4f m -> %.2e rad %.2e m, %d of %zu inliers\n",
              rotationErrorRad(start, s.T_target), centreError(start, s.T_target),
              rotationErrorRad(r.T_cam_world, s.T_target), centreError(r.T_cam_world, s.T_target), r.inliers,
              factors.size());
  EXPECT_LT(rotationErrorRad(r.T_cam_world, s.T_target), 2e-4);
  EXPECT_LT(centreError(r.T_cam_world, s.T_target), 2e-3);
  EXPECT_GE(r.inliers, 200);
}

TEST(PhotometricPoseFactor, CoarseToFineConvergesFromALargerError) {
  const TwoViews s(4);
  const auto factors = s.factors(4);
  std::mt19937 rng(11);
  const Eigen::Isometry3d start = perturb(s.T_target, 0.02, 0.08, rng);  // ~10-20 pixels
  const PoseOptimizationResult r = optimizePoseCoarseToFine(start, s.cam, {}, factors, 3);
  std::printf("coarse to fine (levels 3..0): start %.4f rad %.4f m -> %.2e rad %.2e m, %d of %zu inliers\n",
              rotationErrorRad(start, s.T_target), centreError(start, s.T_target),
              rotationErrorRad(r.T_cam_world, s.T_target), centreError(r.T_cam_world, s.T_target), r.inliers,
              factors.size());
  EXPECT_LT(rotationErrorRad(r.T_cam_world, s.T_target), 2e-4);
  EXPECT_LT(centreError(r.T_cam_world, s.T_target), 2e-3);
  EXPECT_EQ(r.factorOutlier.size(), factors.size());
  // For reference only (not asserted): the same start at level 0 alone.
  const PoseOptimizationResult fine = optimizePose(start, s.cam, {}, {}, {}, TwoViews::asPoseFactors(factors));
  std::printf("level 0 alone from the same start: %.2e rad %.2e m\n", rotationErrorRad(fine.T_cam_world, s.T_target),
              centreError(fine.T_cam_world, s.T_target));
}

TEST(PhotometricPoseFactor, OccludedPatchesAreFlaggedByTheOutlierThreshold) {
  const TwoViews s(1, 10);
  const auto factors = s.factors(1);
  std::mt19937 rng(5);
  const Eigen::Isometry3d start = perturb(s.T_target, 0.003, 0.015, rng);
  const PoseOptimizationResult r = optimizePose(start, s.cam, {}, {}, {}, TwoViews::asPoseFactors(factors));
  EXPECT_LT(rotationErrorRad(r.T_cam_world, s.T_target), 3e-4);
  EXPECT_LT(centreError(r.T_cam_world, s.T_target), 3e-3);
  int occluded = 0, flaggedOccluded = 0, visible = 0, flaggedVisible = 0;
  for (std::size_t i = 0; i < factors.size(); ++i) {
    Eigen::VectorXd res;
    const bool valid = factors[i]->evaluate(s.T_target, res, nullptr);
    if (!valid) continue;  // outside the target image: an outlier whatever its error
    const double sumSquaredIntensity = factors[i]->patternError(r.T_cam_world).e.squaredNorm();
    if (s.occluded[i]) {
      ++occluded;
      flaggedOccluded += r.factorOutlier[i] ? 1 : 0;
      EXPECT_GT(sumSquaredIntensity, 0.05 * 9) << i;  // chi2_P = 0.05 N_P (Table 3.2)
    } else {
      ++visible;
      flaggedVisible += r.factorOutlier[i] ? 1 : 0;
    }
  }
  std::printf("occluded: %d of %d flagged; visible: %d of %d flagged\n", flaggedOccluded, occluded, flaggedVisible,
              visible);
  ASSERT_GE(occluded, 15);
  EXPECT_EQ(flaggedOccluded, occluded);
  EXPECT_EQ(flaggedVisible, 0);
}

TEST(PhotometricPoseFactor, InvalidOutsideTheImageAndBadInput) {
  const TwoViews s(2);
  const auto factors = s.factors(2);
  Eigen::Isometry3d away = s.T_target;
  away.translation().x() += 10.0;  // everything leaves the image
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  EXPECT_FALSE(factors[0]->evaluate(away, r, &J));
  EXPECT_TRUE(r.allFinite());
  EXPECT_EQ(J.norm(), 0.0);
  EXPECT_THROW(factors[0]->atLevel(2), pslam::Error);  // the target pyramid has 2 levels
  EXPECT_THROW(PhotometricPoseFactor(nullptr, s.T_host, {}, std::make_shared<ImagePyramid>(s.targetImage, 1), {}, s.cam),
               pslam::Error);
}

TEST(PhotometricPoseFactor, FixedSizeTermsEqualTheGenericOnes) {
  // addTo / squaredResidual (9 x 6 matrices) against what the PoseFactor defaults build from evaluate(), for
  // valid and invalid factors, robust and not: the same normal equations up to rounding, nothing for an invalid one.
  const TwoViews s(2);
  std::mt19937 rng(9);
  const Eigen::Isometry3d T = perturb(s.T_target, 0.003, 0.01, rng);
  Eigen::Isometry3d away = s.T_target;
  away.translation().x() += 10.0;
  int valid = 0;
  for (const bool inView : {true, false}) {
    const Eigen::Isometry3d& pose = inView ? T : away;
    for (int level : {0, 1})
      for (double delta : {0.0, s.factors(2)[0]->huberDelta()}) {
        PoseNormalEquations fixed, generic;
        for (const auto& f : s.factors(2, level)) {
          Eigen::VectorXd r;
          Eigen::MatrixXd J;
          const bool ok = f->evaluate(pose, r, &J);
          if (ok) generic.add(r, J, delta);
          EXPECT_EQ(f->addTo(fixed, pose, delta), ok);
          double chi2 = -1.0;
          EXPECT_EQ(f->squaredResidual(pose, chi2), ok);
          EXPECT_NEAR(chi2, r.squaredNorm(), 1e-12 * (1.0 + r.squaredNorm()));
          valid += ok ? 1 : 0;
        }
        EXPECT_NEAR(fixed.cost, generic.cost, 1e-10 * (1.0 + generic.cost));
        EXPECT_LE((fixed.H - generic.H).norm(), 1e-10 * (1.0 + generic.H.norm()));
        EXPECT_LE((fixed.g - generic.g).norm(), 1e-10 * (1.0 + generic.g.norm()));
        if (!inView) {
          EXPECT_EQ(fixed.H.norm(), 0.0);  // nothing is valid far away
        }
      }
  }
  EXPECT_GE(valid, 400);
}

TEST(PhotometricPoseFactor, TimingOfOneEvaluation) {
  const TwoViews s(1);
  const auto factors = s.factors(1);
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  const int n = 100000;
  double sink = 0.0;
  for (const auto& f : factors) f->evaluate(s.T_target, r, &J);  // warm-up
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    factors[static_cast<std::size_t>(i) % factors.size()]->evaluate(s.T_target, r, &J);
    sink += r[0];
  }
  const auto t1 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    factors[static_cast<std::size_t>(i) % factors.size()]->evaluate(s.T_target, r, nullptr);
    sink += r[0];
  }
  const auto t2 = std::chrono::steady_clock::now();
  std::printf("PhotometricPoseFactor::evaluate (9 residuals): %.2f us with Jacobian, %.2f us without (sink %g)\n",
              std::chrono::duration<double, std::micro>(t1 - t0).count() / n,
              std::chrono::duration<double, std::micro>(t2 - t1).count() / n, sink);
}
