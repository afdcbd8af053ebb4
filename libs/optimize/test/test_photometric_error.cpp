// The photometric error of direct points (PhotometricError.h, ImagePyramid.h): the Table 3.2 constants in
// whitened units, the pyramid and its intrinsics, the bilinear interpolant and its derivative, host
// intensities, and the invariance of the residual to an affine exposure change when (a, b) are right.
#include <gtest/gtest.h>

#include "SyntheticTexture.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/ImagePyramid.h"
#include "pslam/optimize/PhotometricError.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

TEST(PhotometricParams, TableThreeTwoConstantsInWhitenedUnits) {
  const PhotometricParams p;
  EXPECT_DOUBLE_EQ(p.etaP, 0.5 / 9.0);  // eta_P = 0.5 / N_P
  EXPECT_DOUBLE_EQ(p.etaR, 0.5);
  // r = sqrt(eta_P / eta_R) e: a unit intensity difference over the 9 pixels weighs 1/9 of a whitened pixel^2.
  EXPECT_NEAR(p.whiteningScale(), 1.0 / 3.0, 1e-15);
  // delta_P = 0.4 sqrt(eta_P) on sqrt(eta_P)|e|: Huber switches at |e| = 0.4, i.e. |r| = 0.4 / 3.
  EXPECT_NEAR(p.whitenedHuberDelta(), 0.4 * std::sqrt(p.etaP) / std::sqrt(p.etaR), 1e-15);
  EXPECT_NEAR(p.whitenedHuberDelta() / p.whiteningScale(), 0.4, 1e-15);
  // chi2_P = 0.05 N_P on |e|^2: an outlier beyond |e|^2 = 0.45.
  EXPECT_NEAR(p.whitenedChi2Threshold() / (p.whiteningScale() * p.whiteningScale()), 0.45, 1e-14);
  PhotometricParams bad;
  bad.etaP = 0.0;
  EXPECT_THROW(bad.check(), pslam::Error);
}

TEST(PhotometricPattern, NinePixelsOfDsoSpreadPattern) {
  // DSO's residual pattern 8 (8 pixels) plus (+1, +1): the 9 pixels of N_P (Table 3.2).
  const std::vector<std::array<int, 2>> dso8{{0, -2}, {-1, -1}, {1, -1}, {-2, 0}, {0, 0}, {2, 0}, {-1, 1}, {0, 2}};
  ASSERT_EQ(kDirectPattern.size(), 9u);
  int found = 0, sx = 0, sy = 0;
  for (const auto& o : kDirectPattern) {
    for (const auto& d : dso8) found += (o == d) ? 1 : 0;
    sx += o[0];
    sy += o[1];
    EXPECT_LE(std::max(std::abs(o[0]), std::abs(o[1])), kPatternPadding);
  }
  EXPECT_EQ(found, 8);
  EXPECT_EQ(sx, 0);  // symmetric: the pattern centre is the point
  EXPECT_EQ(sy, 0);
}

TEST(ImagePyramid, BoxMeanLevelsAndLevelIntrinsics) {
  const auto cam = textureCamera();
  const cv::Mat img = renderPlane(cameraAt({0, 0, 0}, {0, 0, 0}), cam);
  const ImagePyramid pyr(img, 4);
  ASSERT_EQ(pyr.levels(), 4);
  EXPECT_EQ(pyr.level(3).cols, 80);
  EXPECT_EQ(pyr.level(3).rows, 60);
  EXPECT_NEAR(pyr.level(0).at<float>(10, 20), img.at<unsigned char>(10, 20) / 255.0, 1e-6);
  const double mean = (pyr.level(0).at<float>(6, 8) + pyr.level(0).at<float>(6, 9) + pyr.level(0).at<float>(7, 8) +
                       pyr.level(0).at<float>(7, 9)) / 4.0;
  EXPECT_NEAR(pyr.level(1).at<float>(3, 4), mean, 1e-6);
  EXPECT_THROW(pyr.level(4), pslam::Error);
  EXPECT_THROW(ImagePyramid(img, 8), pslam::Error);  // 5 x 3 pixels at level 7
  EXPECT_THROW(ImagePyramid(cv::Mat(), 1), pslam::Error);
  // A point projects to the level pixel of its level-0 projection.
  const Eigen::Vector3d p(0.3, -0.2, 4.0);
  for (int l = 0; l < 4; ++l)
    EXPECT_LT((levelCamera(cam, l).project(p) - levelPixel(cam.project(p), l)).norm(), 1e-12) << l;
}

TEST(ImagePyramid, BilinearInterpolantAndItsGradient) {
  cv::Mat ramp(20, 30, CV_32F);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(y, x) = static_cast<float>(0.01 * x - 0.02 * y + 0.5);
  Eigen::Vector2d g;
  EXPECT_NEAR(sampleBilinear(ramp, 7.25, 3.5, &g), 0.01 * 7.25 - 0.02 * 3.5 + 0.5, 1e-6);
  EXPECT_NEAR(g.x(), 0.01, 1e-6);
  EXPECT_NEAR(g.y(), -0.02, 1e-6);
  // Border: clamped value, zero derivative across it.
  EXPECT_NEAR(sampleBilinear(ramp, -3.0, 2.0, &g), 0.5 - 0.04, 1e-6);
  EXPECT_EQ(g.x(), 0.0);
  EXPECT_FALSE(insideBilinear(ramp, 29.5, 3.0));
  EXPECT_TRUE(insideBilinear(ramp, 29.0, 19.0));
  // Jet overload = value and chain rule.
  using J = ceres::Jet<double, 2>;
  const J v = sampleBilinear(ramp, J(4.3, 0), J(8.6, 1));
  EXPECT_NEAR(v.a, sampleBilinear(ramp, 4.3, 8.6), 1e-15);
  EXPECT_NEAR(v.v[0], 0.01, 1e-6);
  EXPECT_NEAR(v.v[1], -0.02, 1e-6);
  // On a textured image: the derivative of the interpolant is its central difference inside a cell.
  const cv::Mat tex = ImagePyramid(renderPlane(cameraAt({0, 0, 0}, {0, 0, 0}), textureCamera()), 1).level(0);
  const double h = 1e-6;
  sampleBilinear(tex, 100.3, 50.6, &g);
  EXPECT_NEAR(g.x(), (sampleBilinear(tex, 100.3 + h, 50.6) - sampleBilinear(tex, 100.3 - h, 50.6)) / (2 * h), 1e-7);
  EXPECT_NEAR(g.y(), (sampleBilinear(tex, 100.3, 50.6 + h) - sampleBilinear(tex, 100.3, 50.6 - h)) / (2 * h), 1e-7);
}

TEST(DirectLandmark, HostIntensitiesPerLevelAndBorders) {
  const auto cam = textureCamera();
  const ImagePyramid host(renderPlane(cameraAt({0, 0, 0}, {0, 0, 0}), cam), 4);
  const DirectLandmark p = DirectLandmark::create(3, {200.0, 150.0}, 0.25, cam, host);
  EXPECT_EQ(p.host, 3u);
  ASSERT_EQ(p.levels(), 4);
  for (int l = 0; l < 4; ++l) ASSERT_TRUE(p.usableAt(l)) << l;
  EXPECT_NEAR(p.hostIntensities[0][4], host.level(0).at<float>(150, 200), 1e-7);  // the centre pixel
  EXPECT_NEAR(p.bearing.norm(), 1.0, 1e-15);
  // Near the border the coarse levels cannot hold the pattern; level 0 must.
  const DirectLandmark edge = DirectLandmark::create(0, {3.0, 100.0}, 0.25, cam, host);
  EXPECT_TRUE(edge.usableAt(0));
  EXPECT_FALSE(edge.usableAt(2));
  EXPECT_THROW(DirectLandmark::create(0, {1.0, 100.0}, 0.25, cam, host), pslam::Error);
  EXPECT_THROW(DirectLandmark::create(0, {100.0, 100.0}, -0.1, cam, host), pslam::Error);
}

TEST(PhotometricResidual, InvariantToAffineExposureWhenTheParametersAreRight) {
  const auto cam = textureCamera();
  const Eigen::Isometry3d T0 = cameraAt({0, 0, 0}, {0, 0, 0});
  const cv::Mat hostImg = renderPlane(T0, cam);
  const ImagePyramid host(hostImg, 3);
  const auto samples = pickHostPixels(hostImg, T0, cam, 40, 16);
  ASSERT_GE(samples.size(), 100u);

  // (1) Same pose, target = e^a I_host + b exactly (float image): e_k = 0 with the right (a, b).
  const AffineBrightness hostAffine{0.05, 0.02}, targetAffine{0.25, 0.1};
  cv::Mat hostF = host.level(0), targetF;
  // I_j = e^{a_j - a_i} (I_i - b_i) + b_j: the same radiance seen with the target's exposure.
  hostF.convertTo(targetF, CV_32F, std::exp(targetAffine.a - hostAffine.a),
                  targetAffine.b - std::exp(targetAffine.a - hostAffine.a) * hostAffine.b);
  const ImagePyramid target(targetF, 3);
  double maxRight = 0.0, minWrong = 1e9;
  for (const auto& s : samples) {
    const DirectLandmark p = DirectLandmark::create(0, s.pixel, s.inverseDepth, cam, host);
    for (int l = 0; l < 3; ++l) {
      if (!p.usableAt(l)) continue;
      const auto rays = patternRays(p, cam, l);
      const PatternError right = evaluatePattern(p, l, rays, Eigen::Isometry3d::Identity(), p.inverseDepth, cam,
                                                 target.level(l), hostAffine, targetAffine);
      ASSERT_TRUE(right.valid);
      maxRight = std::max(maxRight, right.e.cwiseAbs().maxCoeff());
      EXPECT_LT(patternSsd(right, targetAffine), 1e-10);  // Delta Phi of eq. 3.5 -> alpha_dir = 1 (eq. 3.4)
      const PatternError wrong = evaluatePattern(p, l, rays, Eigen::Isometry3d::Identity(), p.inverseDepth, cam,
                                                 target.level(l), {}, {});
      minWrong = std::min(minWrong, wrong.e.cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LT(maxRight, 1e-5);  // float rounding of the images only
  EXPECT_GT(minWrong, 0.02);

  // (2) Another pose rendered with another exposure: the residual with the right (a, b) is what the 8-bit
  // rendering leaves (well below the Huber threshold), the wrong one is large.
  const Eigen::Isometry3d T1 = cameraAt({0.3, -0.05, 0.1}, {0.01, -0.04, 0.02});
  const AffineBrightness exposure1{0.15, 0.03};
  const ImagePyramid view1(renderPlane(T1, cam, exposure1), 1);
  const Eigen::Isometry3d T10 = T1 * T0.inverse();
  double sumRight = 0.0, sumWrong = 0.0;
  int n = 0;
  for (const auto& s : samples) {
    const DirectLandmark p = DirectLandmark::create(0, s.pixel, s.inverseDepth, cam, host);
    const auto rays = patternRays(p, cam, 0);
    const PatternError right = evaluatePattern(p, 0, rays, T10, p.inverseDepth, cam, view1.level(0), {}, exposure1);
    if (!right.valid) continue;
    const PatternError wrong = evaluatePattern(p, 0, rays, T10, p.inverseDepth, cam, view1.level(0), {}, {});
    sumRight += right.e.squaredNorm();
    sumWrong += wrong.e.squaredNorm();
    ++n;
  }
  ASSERT_GT(n, 80);
  const double rmsRight = std::sqrt(sumRight / (9.0 * n)), rmsWrong = std::sqrt(sumWrong / (9.0 * n));
  EXPECT_LT(rmsRight, 0.01) << "RMS intensity difference with the right exposure";
  EXPECT_GT(rmsWrong, 5 * rmsRight);
}
