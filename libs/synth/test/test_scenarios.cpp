// Scenario presets: camera paths start with parallax and stay smooth, the corridor loop closes, the street's
// traffic stops at the light and drives off.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/synth/Scenarios.h"

using namespace pslam::synth;

TEST(Scenarios, StartWithParallaxAndLoopsClose) {
  for (const std::string& name : scenarioNames()) {
    const Scenario s = makeScenario(name, 1, 10.0);
    // Monocular initialization needs translation from the start, not a rotation on the spot.
    const Eigen::Isometry3d T0 = s.T_world_cam(0.0), T1 = s.T_world_cam(1.0);
    EXPECT_GT((T1.translation() - T0.translation()).norm(), 0.2) << name;
    // Smooth: no jumps between consecutive frames anywhere in the default length.
    const ScenarioInfo info = scenarioInfo(name);
    double maxStep = 0;
    for (int i = 1; i < info.defaultFrames; ++i)
      maxStep = std::max(maxStep, (s.T_world_cam(i / info.fps).translation() - s.T_world_cam((i - 1) / info.fps).translation()).norm());
    EXPECT_LT(maxStep, info.fps <= 10 ? 1.0 : 0.1) << name;  // driving at 10 Hz (street, jam) vs walking
  }
  // The corridor walk returns to its start after one loop (drift becomes visible), up to the shake.
  const Scenario c = makeScenario("corridor", 1, 70.0);
  double best = 1e9;
  for (double t = 55; t < 65; t += 1.0 / 15) best = std::min(best, (c.T_world_cam(t).translation() - c.T_world_cam(0).translation()).norm());
  EXPECT_LT(best, 0.05);
}

TEST(Scenarios, StreetTrafficStopsAndGoes) {
  const Scenario s = makeScenario("street", 1, 30.0);
  auto x = [&](const std::string& name, double t) {
    for (const auto& o : s.scene.objects)
      if (o.name == name) return o.T_world_object(t).translation().x();
    ADD_FAILURE() << "no object " << name;
    return 0.0;
  };
  for (const char* name : {"lead car", "queue car 1", "truck"}) {
    EXPECT_NEAR(x(name, 14.0), x(name, 18.5), 1e-9) << name << " waits at the red light";
    EXPECT_GT(x(name, 26.0) - x(name, 18.5), 5.0) << name << " drives off";
    EXPECT_GT(x(name, 10.0) - x(name, 0.0), 5.0) << name << " arrives moving";
  }
  // The ego camera stops behind the lead car, without touching it, and follows it off.
  const double ego14 = s.T_world_cam(14.0).translation().x(), ego20 = s.T_world_cam(20.0).translation().x();
  EXPECT_NEAR(ego14, ego20, 0.02);
  EXPECT_GT(x("lead car", 14.0) - 2.1 - ego14, 2.0);
  EXPECT_GT(s.T_world_cam(29.0).translation().x() - ego20, 20.0);
  int parked = 0;
  for (const auto& o : s.scene.objects) parked += o.name == "parked car" && !o.moving;
  EXPECT_GT(parked, 50);
}

namespace {
/// The pose part of the TUM line of T_world_cam(t) (what slam-synth writes as ground truth).
std::string tumPose(const Scenario& s, double t) {
  const std::string line = pslam::formatTumLine(pslam::StampedPose(1000.0, s.T_world_cam(t)));
  return line.substr(line.find(' ') + 1);
}
}  // namespace

TEST(PathVariants, VariantZeroIsThePresetPathBitForBit) {
  // Ground truth written by slam-synth before path variants existed (seed 2, frame 11).
  EXPECT_EQ(tumPose(makeScenario("corridor", 2, 1.0, 0), 11 / 15.0),
            "3.06004051 -0.00222383219 1.30002628 -0.511094989 0.511673163 -0.488030953 0.488669903");
  EXPECT_EQ(tumPose(makeScenario("room", 2, 1.0, 0), 11 / 30.0),
            "1.03279198 0.937721176 1.49447967 -0.663416721 0.337730278 -0.301528182 0.595732548");
  EXPECT_EQ(tumPose(makeScenario("corridor", 2, 1.0), 7.0), tumPose(makeScenario("corridor", 2, 1.0, 0), 7.0));
}

TEST(PathVariants, SameWorldOtherPath) {
  for (const std::string name : {"room", "corridor"}) {
    ASSERT_EQ(scenarioInfo(name).pathVariants, 3) << name;
    const Scenario a = makeScenario(name, 5, 20.0, 0);
    for (int v : {1, 2}) {
      const Scenario b = makeScenario(name, 5, 20.0, v);
      // Same scene: the same primitives with the same materials (texture seeds included).
      ASSERT_EQ(a.scene.materials.size(), b.scene.materials.size()) << name << v;
      for (std::size_t m = 0; m < a.scene.materials.size(); ++m)
        EXPECT_EQ(a.scene.materials[m].seed, b.scene.materials[m].seed) << name << v;
      EXPECT_EQ(a.scene.objects.size(), b.scene.objects.size());
      // Another camera path, still moving from the start (parallax for initialization).
      EXPECT_GT((a.T_world_cam(1.0).translation() - b.T_world_cam(1.0).translation()).norm(), 0.1) << name << v;
      EXPECT_GT((b.T_world_cam(1.0).translation() - b.T_world_cam(0.0).translation()).norm(), 0.2) << name << v;
    }
  }
}

TEST(PathVariants, CorridorVariantsStayInTheCorridor) {
  // The corridor is 2.4 m wide around the centre line y = 0 on the first straight (x from 0.9 to 23.1).
  const Scenario offset = makeScenario("corridor", 1, 20.0, 1), back = makeScenario("corridor", 1, 20.0, 2);
  for (double t = 0; t < 14; t += 0.5) {
    const Eigen::Vector3d p = offset.T_world_cam(t).translation();
    EXPECT_NEAR(p.y(), -0.35, 0.02) << t;  // right of the walking direction (+x)
    EXPECT_NEAR(p.z(), 1.45, 0.02) << t;
    const Eigen::Vector3d q = back.T_world_cam(t).translation();
    EXPECT_NEAR(q.y(), 0.0, 0.02) << t;
    // Walking back towards -x, looking along -x.
    EXPECT_LT(back.T_world_cam(t).linear().col(2).x(), -0.9) << t;
    if (t > 2) {
      EXPECT_LT(q.x(), back.T_world_cam(t - 1).translation().x() - 0.5) << t;
    }
  }
  EXPECT_GT(offset.T_world_cam(0).translation().x(), makeScenario("corridor", 1, 20.0).T_world_cam(0).translation().x() + 0.9);
}

TEST(PathVariants, UnsupportedVariantIsAClearError) {
  try {
    makeScenario("street", 1, 10.0, 1);
    ADD_FAILURE() << "no error";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "scenario 'street' has no path variant 1 (it has only 0)");
  }
  try {
    requirePathVariant("corridor", 3);
    ADD_FAILURE() << "no error";
  } catch (const pslam::Error& e) {
    EXPECT_STREQ(e.what(), "scenario 'corridor' has no path variant 3 (it has 0 to 2)");
  }
  EXPECT_THROW(requirePathVariant("room", -1), pslam::Error);
  EXPECT_NO_THROW(requirePathVariant("jam", 0));
}
