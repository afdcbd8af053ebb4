// The observation-kind extension point of pose optimization (PoseFactor) and the translation-only freedom:
// a factor kind joins the same normal equations as keypoints (a problem split between keypoints and an
// equivalent factor kind gives the keypoint-only pose), its Jacobian is checked by central differences, its
// outliers are classified with its own threshold, and PoseFreedom::TranslationOnly keeps the rotation.
#include <gtest/gtest.h>

#include <random>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/PoseOptimizer.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

namespace {

/// A point seen at a bearing instead of a pixel: residual = whitened difference of normalized-plane
/// coordinates scaled by the focal length (the keypoint residual written another way). A stand-in for the
/// landmark kinds of chapters 3 and 4; its analytic Jacobian is written independently of poseOnlyResidual.
class PlaneFactor : public PoseFactor {
 public:
  PlaneFactor(Eigen::Vector3d p_world, Eigen::Vector2d pixel, pslam::geometry::PinholeCamera camera, double invSigma2,
              double chi2 = 5.991)
      : p_(p_world), px_(pixel), cam_(camera), w_(std::sqrt(invSigma2)), chi2_(chi2) {}
  std::string kind() const override { return "plane"; }
  int dimension() const override { return 2; }
  bool evaluate(const Eigen::Isometry3d& T, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    const Eigen::Vector3d pc = T * p_;
    r.resize(2);
    r << w_ * (cam_.fx * pc.x() / pc.z() + cam_.cx - px_.x()), w_ * (cam_.fy * pc.y() / pc.z() + cam_.cy - px_.y());
    if (J) {
      Eigen::Matrix<double, 2, 3> dpi;
      dpi << cam_.fx / pc.z(), 0, -cam_.fx * pc.x() / (pc.z() * pc.z()), 0, cam_.fy / pc.z(),
          -cam_.fy * pc.y() / (pc.z() * pc.z());
      Eigen::Matrix<double, 3, 6> dpc;  // d(Exp(xi) pc)/dxi at 0 = [-[pc]x | I]
      dpc << 0, pc.z(), -pc.y(), 1, 0, 0, -pc.z(), 0, pc.x(), 0, 1, 0, pc.y(), -pc.x(), 0, 0, 0, 1;
      *J = w_ * dpi * dpc;
    }
    return pc.z() > 0;
  }
  double huberDelta() const override { return std::sqrt(chi2_); }
  double chi2Threshold() const override { return chi2_; }

 private:
  Eigen::Vector3d p_;
  Eigen::Vector2d px_;
  pslam::geometry::PinholeCamera cam_;
  double w_, chi2_;
};

struct Scene {
  Eigen::Isometry3d T_true;
  std::vector<PoseObservation> observations;
};

Scene makeScene(int n, unsigned seed, double outlierFraction = 0.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-3, 3), uy(-2, 2), uz(3, 10), u01(0, 1);
  std::normal_distribution<double> g(0, 1);
  Scene s;
  s.T_true = arcPose(1, 4);
  const auto cam = testCamera();
  while (static_cast<int>(s.observations.size()) < n) {
    const Eigen::Vector3d pw = s.T_true.inverse() * Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    const Eigen::Vector2d px = cam.project(s.T_true * pw);
    if (!cam.inImage(px)) continue;
    PoseObservation o;
    o.p_world = pw;
    o.pixel = px + Eigen::Vector2d(g(rng), g(rng)) + (u01(rng) < outlierFraction ? Eigen::Vector2d(40, -35) : Eigen::Vector2d::Zero());
    s.observations.push_back(o);
  }
  return s;
}

std::vector<std::shared_ptr<const PoseFactor>> asFactors(const std::vector<PoseObservation>& obs) {
  std::vector<std::shared_ptr<const PoseFactor>> f;
  for (const auto& o : obs) f.push_back(std::make_shared<PlaneFactor>(o.p_world, o.pixel, testCamera(), o.invSigma2));
  return f;
}

}  // namespace

TEST(PoseFactor, JacobianMatchesCentralDifferences) {
  const Scene s = makeScene(5, 3);
  const Eigen::Isometry3d T = arcPose(2, 4);
  for (const auto& f : asFactors(s.observations)) {
    Eigen::VectorXd r0, rp, rm;
    Eigen::MatrixXd J;
    ASSERT_TRUE(f->evaluate(T, r0, &J));
    ASSERT_EQ(J.rows(), 2);
    ASSERT_EQ(J.cols(), 6);
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      const double h = 1e-6;
      xi[k] = h;
      f->evaluate(retractPoseLeft(xi, T), rp, nullptr);
      xi[k] = -h;
      f->evaluate(retractPoseLeft(xi, T), rm, nullptr);
      const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
      EXPECT_LT((numeric - J.col(k)).norm(), 1e-5 * (1.0 + J.col(k).norm())) << "column " << k;
    }
  }
}

TEST(PoseFactor, FactorsJoinTheKeypointNormalEquations) {
  const Scene s = makeScene(300, 11, 0.1);
  std::mt19937 rng(2);
  const Eigen::Isometry3d start = perturb(s.T_true, 0.03, 0.1, rng);
  const PoseOptimizationResult keypointsOnly = optimizePose(start, testCamera(), s.observations);
  // The same measurements, half as keypoints and half as factors of another kind.
  const std::vector<PoseObservation> firstHalf(s.observations.begin(), s.observations.begin() + 150);
  const std::vector<PoseObservation> secondHalf(s.observations.begin() + 150, s.observations.end());
  const PoseOptimizationResult mixed = optimizePose(start, testCamera(), firstHalf, {}, {}, asFactors(secondHalf));
  EXPECT_LT(rotationErrorRad(keypointsOnly.T_cam_world, mixed.T_cam_world), 1e-9);
  EXPECT_LT(centreError(keypointsOnly.T_cam_world, mixed.T_cam_world), 1e-9);
  EXPECT_EQ(keypointsOnly.inliers, mixed.inliers);
  ASSERT_EQ(mixed.factorOutlier.size(), 150u);
  for (std::size_t i = 0; i < 150; ++i) EXPECT_EQ(mixed.factorOutlier[i], keypointsOnly.outlier[150 + i]) << i;
  // Factors only also solve the pose (no keypoint at all).
  const PoseOptimizationResult factorsOnly = optimizePose(start, testCamera(), {}, {}, {}, asFactors(s.observations));
  EXPECT_LT(centreError(keypointsOnly.T_cam_world, factorsOnly.T_cam_world), 1e-9);
  EXPECT_LT(centreError(s.T_true, factorsOnly.T_cam_world), 0.02);
}

TEST(PoseFactor, NullFactorIsAnError) {
  const Scene s = makeScene(20, 1);
  EXPECT_THROW(optimizePose(s.T_true, testCamera(), s.observations, {}, {}, {nullptr}), pslam::Error);
}

TEST(PoseFreedom, TranslationOnlyKeepsTheRotationAndRecoversTheTranslation) {
  const Scene s = makeScene(200, 5);
  Eigen::Isometry3d start = s.T_true;
  start.translation() += Eigen::Vector3d(0.2, -0.1, 0.15);
  const PoseOptimizationResult r =
      optimizePose(start, testCamera(), s.observations, {}, {}, {}, PoseFreedom::TranslationOnly);
  EXPECT_LT((r.T_cam_world.linear() - s.T_true.linear()).norm(), 1e-12);
  EXPECT_LT(centreError(s.T_true, r.T_cam_world), 0.01);
  // A wrong rotation stays wrong: translation-only does not touch it.
  std::mt19937 rng(9);
  const Eigen::Isometry3d rotated = perturb(s.T_true, 0.02, 0.0, rng);
  const PoseOptimizationResult q =
      optimizePose(rotated, testCamera(), s.observations, {}, {}, {}, PoseFreedom::TranslationOnly);
  EXPECT_LT((q.T_cam_world.linear() - rotated.linear()).norm(), 1e-12);
}
