// LineFrontEnd on rendered room views with their true poses: lines triangulated between two keyframes lie on
// the rendered surfaces (depth map), a frame between them matches them by projection with small residuals at
// its true pose, inlier matches become the next keyframe's observations, BA factors need two window
// observations, culling and reset.
#include <gtest/gtest.h>

#include "pslam/core/Error.h"
#include "pslam/lines/LineFrontEnd.h"
#include "pslam/synth/Renderer.h"
#include "pslam/synth/Scenarios.h"
#include "pslam/tracking/Frame.h"

using namespace pslam;
using namespace pslam::lines;

namespace {
struct View {
  cv::Mat grey, depth;
  Eigen::Isometry3d T_cam_world;
};

class LineFrontEndTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scenario_ = new synth::Scenario(synth::makeScenario("room", 1, 10.0));
    const synth::Renderer renderer(synth::defaultRenderCamera(), synth::RenderOptions{});
    for (double t : {0.0, 0.5, 1.0}) {
      const Eigen::Isometry3d T_world_cam = scenario_->T_world_cam(t);
      const synth::RenderedView v = renderer.render(scenario_->scene, T_world_cam, t);
      View view;
      v.radiance.convertTo(view.grey, CV_8U);
      view.depth = v.depth;
      view.T_cam_world = T_world_cam.inverse();
      views_.push_back(view);
    }
  }
  static void TearDownTestSuite() {
    delete scenario_;
    views_.clear();
  }

  static geometry::PinholeCamera camera() { return geometry::PinholeCamera(525, 525, 319.5, 239.5, 640, 480); }
  map::KeyFrameId addMapKeyFrame(map::Map& m, const View& v, double t) const {
    map::KeyFrame kf;
    kf.timestamp = t;
    kf.T_cam_world = v.T_cam_world;
    kf.camera = camera().withoutDistortion();
    kf.descriptors = cv::Mat(0, 32, CV_8U);
    kf.setPyramid(1, 1.2);
    return m.addKeyFrame(kf);
  }
  /// Keyframes at views 0 and 2, in `m` and (their segments) in `fe`.
  std::pair<map::KeyFrameId, map::KeyFrameId> twoKeyFrames(LineFrontEnd& fe, map::Map& m) const {
    const map::KeyFrameId k0 = addMapKeyFrame(m, views_[0], 0.0);
    const map::KeyFrameId k2 = addMapKeyFrame(m, views_[2], 1.0);
    fe.addKeyFrame(k0, views_[0].grey, false);
    fe.addKeyFrame(k2, views_[2].grey, false);
    return {k0, k2};
  }
  static tracking::Frame frameOf(const View& v, std::size_t index) {
    tracking::Frame f;
    f.index = index;
    f.timestamp = static_cast<double>(index);
    f.grey = v.grey;
    f.camera = camera().withoutDistortion();
    f.T_cam_world = v.T_cam_world;
    f.hasPose = true;
    return f;
  }

  static synth::Scenario* scenario_;
  static std::vector<View> views_;
};
synth::Scenario* LineFrontEndTest::scenario_ = nullptr;
std::vector<View> LineFrontEndTest::views_;
}  // namespace

TEST_F(LineFrontEndTest, TriangulatesLinesOnTheRenderedSurfacesAndTracksThem) {
  LinesParams p;
  p.enabled = true;
  LineFrontEnd fe(p, camera());
  map::Map m;
  const auto [k0, k2] = twoKeyFrames(fe, m);
  EXPECT_EQ(fe.keyFrames().at(k0).features.size(), 40u);
  const LineCreationReport rep = fe.createLines(m, k2);
  EXPECT_GT(rep.created, 5) << "candidates " << rep.candidates;
  ASSERT_EQ(fe.numLines(), static_cast<std::size_t>(rep.created));

  // Endpoints lie on the rendered surfaces: depth at their pixel in keyframe k2 (their own view) agrees.
  int onSurface = 0, total = 0;
  for (const auto& [id, l] : fe.lines()) {
    for (const Eigen::Vector3d& X : {l.landmark->line().start, l.landmark->line().end}) {
      const Eigen::Vector3d pc = views_[2].T_cam_world * X;
      const Eigen::Vector2d uv = camera().withoutDistortion().project(pc);
      const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
      if (u < 2 || v < 2 || u >= 638 || v >= 478) continue;
      ++total;
      // The nearest surface among the neighbouring pixels (an edge separates two depths).
      double best = 1e9;
      for (int dv = -2; dv <= 2; ++dv)
        for (int du = -2; du <= 2; ++du) {
          const float z = views_[2].depth.at<float>(v + dv, u + du);
          if (z > 0) best = std::min(best, std::abs(z - pc.z()) / z);
        }
      onSurface += best < 0.05 ? 1 : 0;
    }
  }
  ASSERT_GT(total, 0);
  EXPECT_GE(onSurface, total * 8 / 10) << onSurface << " of " << total << " endpoints within 5 % of the depth";

  // The frame between the keyframes matches them at its true pose; residuals there are small.
  const tracking::Frame f = frameOf(views_[1], 7);
  fe.prepareFrame(f);
  EXPECT_GT(fe.lastExtractionMs(), 0.0);
  const auto factors = fe.lineFactors(f);
  ASSERT_GT(factors.size(), 3u);
  std::vector<bool> outliers;
  int inliers = 0;
  for (const auto& factor : factors) {
    Eigen::VectorXd r;
    const bool ok = factor->evaluate(f.T_cam_world, r, nullptr) && r.squaredNorm() <= factor->chi2Threshold();
    outliers.push_back(!ok);
    inliers += ok ? 1 : 0;
  }
  EXPECT_GE(inliers, static_cast<int>(factors.size()) * 7 / 10);
  const lines::LineFrameCounts counts = fe.afterTracking(f, outliers);
  EXPECT_EQ(counts.detected, 40);
  EXPECT_EQ(counts.factors, static_cast<int>(factors.size()));
  EXPECT_EQ(counts.inliers, inliers);
  EXPECT_GE(counts.visible, counts.factors);

  // The frame becomes a keyframe: its inlier matches are observations.
  const map::KeyFrameId k1 = addMapKeyFrame(m, views_[1], 0.5);
  fe.addKeyFrame(k1, f.grey, true);
  int observedInK1 = 0;
  for (const auto& [id, l] : fe.lines()) observedInK1 += l.observations.count(k1) ? 1 : 0;
  EXPECT_EQ(observedInK1, inliers);

  // BA factors: one per observation of lines seen twice or more in the window (one free keyframe).
  optimize::BAProblem problem;
  for (map::KeyFrameId k : {k0, k1, k2}) {
    optimize::BAKeyFrame b;
    b.T_cam_world = m.keyFrame(k).T_cam_world;
    b.camera = m.keyFrame(k).camera;
    b.fixed = k != k1;
    problem.keyframes[k] = b;
  }
  const auto baFactors = fe.bundleAdjustmentFactors(m, problem);
  std::size_t expected = 0;
  for (const auto& [id, l] : fe.lines()) expected += l.observations.size() >= 2 ? l.observations.size() : 0;
  EXPECT_GT(baFactors.size(), 0u);
  EXPECT_LE(baFactors.size(), expected);  // lines behind a window keyframe stay out
  std::vector<bool> baOutliers(baFactors.size(), false);
  if (!baOutliers.empty()) baOutliers[0] = true;
  EXPECT_GT(fe.applyBundleAdjustment(baOutliers), 0);

  // A keyframe leaving the map takes its observations; lines left with one are erased by prune.
  m.eraseKeyFrame(k2);
  fe.prune(m);
  EXPECT_FALSE(fe.keyFrames().count(k2));
  for (const auto& [id, l] : fe.lines()) {
    EXPECT_FALSE(l.observations.count(k2));
    EXPECT_GE(l.observations.size(), 2u);
  }
  fe.reset();
  EXPECT_EQ(fe.numLines(), 0u);
  EXPECT_TRUE(fe.keyFrames().empty());
}

TEST_F(LineFrontEndTest, LinesTheOptimizationsRejectAreCulled) {
  LinesParams p;
  p.enabled = true;
  p.cullMinVisible = 3;
  LineFrontEnd fe(p, camera());
  map::Map m;
  const auto [k0, k2] = twoKeyFrames(fe, m);
  fe.createLines(m, k2);
  const std::size_t before = fe.numLines();
  ASSERT_GT(before, 0u);
  std::size_t rejected = 0;
  for (int k = 0; k < 3; ++k) {
    const tracking::Frame f = frameOf(views_[1], 10 + static_cast<std::size_t>(k));
    const auto factors = fe.lineFactors(f);
    rejected = factors.size();
    fe.afterTracking(f, std::vector<bool>(factors.size(), true));
  }
  ASSERT_GT(rejected, 0u);
  EXPECT_LE(fe.numLines(), before - rejected);
}

TEST_F(LineFrontEndTest, TheLineStoreSavedWithTheMapComesBackByteForByteAndABadOneIsRefused) {
  // LineFrontEnd::serialize / restore (the map extension "lines"): lines with observations and counters, after a
  // frame's tracking updated them, restored into another front end, give the same lines and the same bytes.
  LinesParams p;
  p.enabled = true;
  LineFrontEnd fe(p, camera());
  map::Map m;
  const auto [k0, k2] = twoKeyFrames(fe, m);
  fe.createLines(m, k2);
  const tracking::Frame f = frameOf(views_[1], 5);
  const auto factors = fe.lineFactors(f);
  fe.afterTracking(f, std::vector<bool>(factors.size(), false));
  ASSERT_GT(fe.numLines(), 3u);
  const std::string bytes = fe.serialize();

  LineFrontEnd restored(p, camera());
  restored.restore(bytes, m);
  EXPECT_EQ(restored.serialize(), bytes);
  ASSERT_EQ(restored.lines().size(), fe.lines().size());
  for (const auto& [id, l] : fe.lines()) {
    const MapLine& r = restored.lines().at(id);
    EXPECT_EQ(r.landmark->endpoints, l.landmark->endpoints);
    EXPECT_EQ(r.observations, l.observations);
    EXPECT_EQ(r.visible, l.visible);
    EXPECT_EQ(r.found, l.found);
    EXPECT_EQ(cv::norm(r.descriptor, l.descriptor, cv::NORM_HAMMING), 0.0);
  }
  EXPECT_EQ(restored.keyFrames().size(), 2u);
  // The restored lines are tracked like the originals.
  EXPECT_EQ(restored.lineFactors(f).size(), fe.lineFactors(f).size());

  auto errorOf = [&](const std::string& b, const map::Map& against) {
    LineFrontEnd target(p, camera());
    try {
      target.restore(b, against);
    } catch (const Error& e) {
      EXPECT_TRUE(target.keyFrames().empty()) << "a refused store leaves the front end empty";
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(errorOf(bytes.substr(0, bytes.size() / 2), m).find("lines: truncated"), std::string::npos);
  EXPECT_NE(errorOf("XXXX" + bytes.substr(4), m).find("bad magic"), std::string::npos);
  EXPECT_NE(errorOf(bytes + "x", m).find("unexpected bytes"), std::string::npos);
  map::Map other;  // a map without those keyframes
  addMapKeyFrame(other, views_[0], 0.0);
  EXPECT_NE(errorOf(bytes, other).find("is not in the map"), std::string::npos) << errorOf(bytes, other);
}

TEST(LinesParams, DefaultsAndChecks) {
  LinesParams p;
  EXPECT_FALSE(p.enabled);
  EXPECT_EQ(p.extractor.maxLines, 40);  // Table 4.1
  EXPECT_NO_THROW(p.check());
  p.ratio = 1.5;
  EXPECT_THROW(p.check(), std::exception);
}
