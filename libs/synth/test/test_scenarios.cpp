// Scenario presets: camera paths start with parallax and stay smooth, the corridor loop closes, the street's
// traffic stops at the light and drives off.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

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
