// The observation-kind extension point of bundle adjustment (BAFactor): landmarks of another kind (here a
// world-XYZ point with its own reprojection cost, standing in for direct points and lines) are optimized in
// the same problem as the keypoint observations, their outliers are classified by their own threshold, and a
// problem without factors is unchanged.
#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>

#include "SyntheticProblem.h"
#include "pslam/core/Error.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/optimize/PoseParameterization.h"

using namespace pslam::optimize;
using namespace pslam::optimize::testing;
using pslam::map::KeyFrameId;

namespace {

/// A 3D point (3 doubles, owned by the landmark) seen by one keyframe at a pixel.
struct XyzLandmark {
  std::array<double, 3> xyz;
};

class XyzFactor : public BAFactor {
 public:
  XyzFactor(KeyFrameId kf, std::shared_ptr<XyzLandmark> landmark, Eigen::Vector2d pixel, pslam::geometry::PinholeCamera cam)
      : kf_(kf), landmark_(std::move(landmark)), pixel_(pixel), cam_(cam) {}
  std::string kind() const override { return "xyz"; }
  std::vector<KeyFrameId> keyframes() const override { return {kf_}; }
  std::vector<double*> landmarkBlocks() const override { return {landmark_->xyz.data()}; }
  ceres::CostFunction* newCostFunction() const override {
    return new ceres::AutoDiffCostFunction<Cost, 2, kPoseSize, 3>(new Cost{pixel_, cam_});
  }
  double huberDelta() const override { return 2.448; }
  double chi2Threshold() const override { return 5.991; }

 private:
  struct Cost {
    Eigen::Vector2d pixel;
    pslam::geometry::PinholeCamera cam;
    template <typename T>
    bool operator()(const T* pose, const T* xyz, T* r) const {
      const Eigen::Matrix<T, 3, 1> pc = transformPoint(pose, Eigen::Matrix<T, 3, 1>(xyz[0], xyz[1], xyz[2]));
      r[0] = T(cam.fx) * pc.x() / pc.z() + T(cam.cx) - T(pixel.x());
      r[1] = T(cam.fy) * pc.y() / pc.z() + T(cam.cy) - T(pixel.y());
      return true;
    }
  };
  KeyFrameId kf_;
  std::shared_ptr<XyzLandmark> landmark_;
  Eigen::Vector2d pixel_;
  pslam::geometry::PinholeCamera cam_;
};

}  // namespace

TEST(BAFactor, OtherLandmarkKindsAreOptimizedWithTheKeypoints) {
  SyntheticOptions opt;
  opt.points = 150;
  opt.outlierFraction = 0.0;
  opt.noisePixels = 0.0;
  SyntheticBA s = makeSyntheticBA(opt);
  // 80 landmarks of the other kind, seen by every keyframe, perturbed by 10 cm; one gross outlier observation.
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 0.1);
  std::vector<std::shared_ptr<XyzLandmark>> landmarks;
  std::vector<Eigen::Vector3d> truth;
  std::uniform_real_distribution<double> ux(-2.0, 2.0), uy(-1.5, 1.5), uz(5.0, 8.0);
  while (landmarks.size() < 80) {
    const Eigen::Vector3d pw(ux(rng), uy(rng), uz(rng));
    std::vector<std::pair<KeyFrameId, Eigen::Vector2d>> seen;
    for (const auto& [id, kf] : s.truth.keyframes) {
      const Eigen::Vector3d pc = kf.T_cam_world * pw;
      const Eigen::Vector2d px = kf.camera.project(pc);
      if (pc.z() > 0.5 && kf.camera.inImage(px)) seen.emplace_back(id, px);
    }
    if (seen.size() < 3) continue;
    auto lm = std::make_shared<XyzLandmark>();
    lm->xyz = {pw.x() + g(rng), pw.y() + g(rng), pw.z() + g(rng)};
    for (const auto& [kf, px] : seen)
      s.problem.factors.push_back(std::make_shared<XyzFactor>(kf, lm, px, testCamera()));
    landmarks.push_back(lm);
    truth.push_back(pw);
  }
  const std::size_t outlierIndex = s.problem.factors.size();
  {
    const auto& [kf0, k] = *s.truth.keyframes.rbegin();
    s.problem.factors.push_back(std::make_shared<XyzFactor>(kf0, landmarks[0],
                                                            k.camera.project(k.T_cam_world * truth[0]) + Eigen::Vector2d(60, 40),
                                                            testCamera()));
  }
  double before = 0.0;
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    before += (Eigen::Vector3d(landmarks[i]->xyz.data()) - truth[i]).norm();
  const BAResult r = localBundleAdjustment(s.problem);
  double after = 0.0;
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    after += (Eigen::Vector3d(landmarks[i]->xyz.data()) - truth[i]).norm();
  EXPECT_LT(after, 0.02 * before) << before / landmarks.size() << " -> " << after / landmarks.size() << " m";
  for (const auto& [id, T] : r.poses)
    EXPECT_LT(centreError(T, s.truth.keyframes.at(id).T_cam_world), 1e-3) << "keyframe " << id;
  ASSERT_EQ(r.factorOutliers.size(), 1u);
  EXPECT_EQ(r.factorOutliers[0], outlierIndex);
}

TEST(BAFactor, WithoutFactorsTheResultIsUnchangedAndBadFactorsAreRefused) {
  SyntheticOptions opt;
  opt.points = 100;
  const SyntheticBA s = makeSyntheticBA(opt);
  const BAResult a = localBundleAdjustment(s.problem);
  const BAResult b = localBundleAdjustment(s.problem);
  EXPECT_EQ(a.finalCost, b.finalCost);
  EXPECT_TRUE(a.factorOutliers.empty());
  BAProblem bad = s.problem;
  auto lm = std::make_shared<XyzLandmark>();
  bad.factors.push_back(std::make_shared<XyzFactor>(12345, lm, Eigen::Vector2d(1, 1), testCamera()));
  EXPECT_THROW(localBundleAdjustment(bad), pslam::Error);
  bad.factors = {nullptr};
  EXPECT_THROW(localBundleAdjustment(bad), pslam::Error);
}
