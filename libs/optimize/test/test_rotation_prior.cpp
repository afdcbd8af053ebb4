// RotationPriorFactor (and its motion-only form RotationPosePriorFactor): its residual is the known rotation
// error over sigma, its automatic Jacobian agrees with
// ceres::GradientChecker through the PoseManifold, in BA a correct prior keeps a keyframe whose points cannot fix
// its rotation at the true one, and a wrong one (20 deg off) is classified as an outlier.
#include <gtest/gtest.h>

#include <ceres/gradient_checker.h>

#include <random>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/PoseOptimizer.h"
#include "pslam/optimize/PoseParameterization.h"
#include "pslam/optimize/RotationPriorFactor.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;

namespace {
constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix3d rot(double angleRad, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angleRad, axis.normalized()).toRotationMatrix();
}
}  // namespace

TEST(RotationPriorFactor, ResidualIsTheRotationErrorOverSigma) {
  const Eigen::Matrix3d R_meas = rot(30 * kDeg, {0.2, 1.0, -0.3});
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rot(2.0 * kDeg, axis) * R_meas;  // left error of 2 deg about `axis`
  T.translation() = Eigen::Vector3d(1, 2, 3);
  const RotationPriorFactor f(7, R_meas, 0.5 * kDeg);
  const PoseParameters p = toPoseParameters(T);
  const Eigen::Vector3d r = f.residual(p.data());
  EXPECT_NEAR(r.norm(), 4.0, 1e-9);
  EXPECT_NEAR(r.normalized().dot(axis), 1.0, 1e-9);
  // The sign of the quaternion does not matter.
  PoseParameters flipped = p;
  for (int k = 0; k < 4; ++k) flipped[static_cast<std::size_t>(k)] = -flipped[static_cast<std::size_t>(k)];
  EXPECT_LT((f.residual(flipped.data()) - r).norm(), 1e-9);
  // No error at the measurement, whatever the translation.
  T.linear() = R_meas;
  EXPECT_LT(f.residual(toPoseParameters(T).data()).norm(), 1e-9);
  EXPECT_EQ(f.keyframes(), std::vector<pslam::map::KeyFrameId>{7});
  EXPECT_TRUE(f.landmarkBlocks().empty());
}

TEST(RotationPriorFactor, JacobianAgreesWithFiniteDifferences) {
  for (const double errDeg : {0.0, 0.3, 5.0, 60.0}) {
    const Eigen::Matrix3d R_meas = rot(70 * kDeg, {1.0, 0.4, 0.1});
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rot(errDeg * kDeg, {0.3, -0.2, 1.0}) * R_meas;
    T.translation() = Eigen::Vector3d(-0.5, 0.1, 2.0);
    const RotationPriorFactor f(1, R_meas, 1.0 * kDeg);
    std::unique_ptr<ceres::CostFunction> cost(f.newCostFunction());
    PoseManifold manifold;
    const std::vector<const ceres::Manifold*> manifolds{&manifold};
    ceres::NumericDiffOptions nd;
    ceres::GradientChecker checker(cost.get(), &manifolds, nd);
    PoseParameters p = toPoseParameters(T);
    const double* blocks[] = {p.data()};
    ceres::GradientChecker::ProbeResults results;
    checker.Probe(blocks, 1e-6, &results);
    ASSERT_TRUE(results.return_value);
    // Compared in the manifold's tangent space, with an absolute floor: at zero error most entries are exactly 0
    // and the checker's relative test divides rounding noise by them.
    const Eigen::MatrixXd& J = results.local_jacobians.at(0);
    const Eigen::MatrixXd& Jn = results.local_numeric_jacobians.at(0);
    ASSERT_EQ(J.rows(), 3);
    ASSERT_EQ(J.cols(), 6);
    EXPECT_LT((J - Jn).cwiseAbs().maxCoeff(), 1e-6 * std::max(1.0, J.cwiseAbs().maxCoeff()))
        << "error " << errDeg << " deg\n" << J << "\n" << Jn;
    EXPECT_LT(J.rightCols<3>().norm(), 1e-12);  // the translation takes no part
  }
}

TEST(RotationPriorFactor, InBundleAdjustmentACorrectPriorHoldsAndAWrongOneIsAnOutlier) {
  SyntheticOptions opt;
  opt.points = 200;
  opt.outlierFraction = 0.0;
  opt.noisePixels = 1.0;
  opt.poseRotationNoise = 3.0 * kDeg;
  const SyntheticBA s = makeSyntheticBA(opt);
  // Every free keyframe gets a prior at its true rotation (sigma 0.5 deg), except the last, whose prior is
  // 20 deg off.
  BAProblem problem = s.problem;
  std::vector<pslam::map::KeyFrameId> free;
  for (const auto& [id, kf] : problem.keyframes)
    if (!kf.fixed) free.push_back(id);
  ASSERT_GE(free.size(), 3u);
  for (pslam::map::KeyFrameId id : free) {
    Eigen::Matrix3d R = s.truth.keyframes.at(id).T_cam_world.linear();
    if (id == free.back()) R = rot(20 * kDeg, {0, 1, 0}) * R;
    problem.factors.push_back(std::make_shared<RotationPriorFactor>(id, R, 0.5 * kDeg));
  }
  const BAResult r = localBundleAdjustment(problem);
  ASSERT_EQ(r.factorOutliers.size(), 1u);
  EXPECT_EQ(r.factorOutliers[0], problem.factors.size() - 1);
  for (const auto& [id, T] : r.poses)
    EXPECT_LT(rotationErrorRad(T, s.truth.keyframes.at(id).T_cam_world), 0.2 * kDeg) << "keyframe " << id;
}

TEST(RotationPriorFactor, RefusesBadMeasurements) {
  EXPECT_THROW(RotationPriorFactor(1, Eigen::Matrix3d::Identity(), 0.0), pslam::Error);
  EXPECT_THROW(RotationPriorFactor(1, Eigen::Matrix3d::Identity(), std::nan("")), pslam::Error);
  EXPECT_THROW(RotationPriorFactor(1, 2.0 * Eigen::Matrix3d::Identity(), 0.01), pslam::Error);
  Eigen::Matrix3d reflection = Eigen::Matrix3d::Identity();
  reflection(2, 2) = -1.0;
  EXPECT_THROW(RotationPriorFactor(1, reflection, 0.01), pslam::Error);
}

// ---- the motion-only form (RotationPosePriorFactor), the soft Manhattan rotation of tracking

TEST(RotationPosePriorFactor, ResidualIsTheRotationErrorOverSigmaAndAgreesWithTheBAForm) {
  const Eigen::Matrix3d R_meas = rot(30 * kDeg, {0.2, 1.0, -0.3});
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rot(2.0 * kDeg, axis) * R_meas;
  T.translation() = Eigen::Vector3d(1, 2, 3);
  const RotationPosePriorFactor f(R_meas, 0.5 * kDeg);
  Eigen::VectorXd r;
  ASSERT_TRUE(f.evaluate(T, r, nullptr));
  ASSERT_EQ(r.size(), 3);
  EXPECT_NEAR(r.norm(), 4.0, 1e-9);
  EXPECT_NEAR(r.normalized().dot(axis), 1.0, 1e-9);
  const RotationPriorFactor ba(1, R_meas, 0.5 * kDeg);
  EXPECT_LT((ba.residual(toPoseParameters(T).data()) - r).norm(), 1e-9);
  T.linear() = R_meas;
  ASSERT_TRUE(f.evaluate(T, r, nullptr));
  EXPECT_LT(r.norm(), 1e-9);
}

TEST(RotationPosePriorFactor, JacobianMatchesCentralDifferencesOfTheLeftPerturbation) {
  for (const double errDeg : {0.0, 0.3, 5.0, 60.0, 170.0}) {
    const Eigen::Matrix3d R_meas = rot(70 * kDeg, {1.0, 0.4, 0.1});
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rot(errDeg * kDeg, {0.3, -0.2, 1.0}) * R_meas;
    T.translation() = Eigen::Vector3d(-0.5, 0.1, 2.0);
    const RotationPosePriorFactor f(R_meas, 1.0 * kDeg);
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    ASSERT_TRUE(f.evaluate(T, r, &J));
    ASSERT_EQ(J.rows(), 3);
    ASSERT_EQ(J.cols(), 6);
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      xi(k) = h;
      Eigen::VectorXd rp, rm;
      f.evaluate(retractPoseLeft(xi, T), rp, nullptr);
      f.evaluate(retractPoseLeft(-xi, T), rm, nullptr);
      const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
      EXPECT_LT((numeric - J.col(k)).norm(), 1e-5 * (1.0 + J.col(k).norm()))
          << "error " << errDeg << " deg, column " << k << "\n" << J << "\nnumeric " << numeric.transpose();
    }
  }
}

TEST(RotationPosePriorFactor, SteersAPoseThatItsPointsCannotFixAndYieldsToPointsThatCan) {
  // Two points (4 equations) cannot fix a 6-DoF pose; with a prior at the true rotation the pose comes back
  // from a 3-deg rotation error exactly. With 200 points the points fix the rotation and a prior 20 deg off is
  // classified as an outlier.
  const auto cam = testCamera();
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = rot(10 * kDeg, {0.1, 1.0, 0.0});
  truth.translation() = Eigen::Vector3d(0.2, -0.1, 0.3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-3, 3), uy(-2, 2), uz(4, 9);
  auto observe = [&](int n) {
    std::vector<PoseObservation> obs;
    while (static_cast<int>(obs.size()) < n) {
      PoseObservation o;
      o.p_world = truth.inverse() * Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
      o.pixel = cam.project(truth * o.p_world);
      if (cam.inImage(o.pixel)) obs.push_back(o);
    }
    return obs;
  };
  Eigen::Isometry3d start = truth;
  start.linear() = rot(3 * kDeg, {1.0, 0.0, 0.2}) * truth.linear();
  PoseOptimizationParams params;
  {
    const auto obs = observe(2);  // 2 points: 4 equations for 6 unknowns; the prior gives the other 3
    const std::vector<std::shared_ptr<const PoseFactor>> prior{
        std::make_shared<RotationPosePriorFactor>(truth.linear(), 0.5 * kDeg)};
    const PoseOptimizationResult r = optimizePose(start, cam, obs, params, {}, prior);
    EXPECT_LT(rotationErrorRad(r.T_cam_world, truth), 0.01 * kDeg);
    EXPECT_LT((r.T_cam_world.translation() - truth.translation()).norm(), 1e-4);
    ASSERT_EQ(r.factorOutlier.size(), 1u);
    EXPECT_FALSE(r.factorOutlier[0]);
  }
  {
    const auto obs = observe(200);
    const std::vector<std::shared_ptr<const PoseFactor>> wrong{
        std::make_shared<RotationPosePriorFactor>(rot(20 * kDeg, {0, 1, 0}) * truth.linear(), 0.5 * kDeg)};
    const PoseOptimizationResult r = optimizePose(start, cam, obs, params, {}, wrong);
    EXPECT_LT(rotationErrorRad(r.T_cam_world, truth), 0.01 * kDeg);
    ASSERT_EQ(r.factorOutlier.size(), 1u);
    EXPECT_TRUE(r.factorOutlier[0]);
  }
  EXPECT_THROW(RotationPosePriorFactor(Eigen::Matrix3d::Identity(), 0.0), pslam::Error);
  EXPECT_THROW(RotationPosePriorFactor(2.0 * Eigen::Matrix3d::Identity(), 0.01), pslam::Error);
}
