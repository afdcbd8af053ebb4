// RotationPriorFactor: its residual is the known rotation error over sigma, its automatic Jacobian agrees with
// ceres::GradientChecker through the PoseManifold, in BA a correct prior keeps a keyframe whose points cannot fix
// its rotation at the true one, and a wrong one (20 deg off) is classified as an outlier.
#include <gtest/gtest.h>

#include <ceres/gradient_checker.h>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/BundleAdjustment.h"
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
