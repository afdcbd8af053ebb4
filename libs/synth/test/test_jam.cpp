// The jam scenario (Virtual KITTI 20-like traffic jam): choreography (the ego car stands >= 5 s while large
// vehicles pull away or pass, nobody collides), parked cars along a stretch, vehicles labelled with dynamic
// classes in the rendered labels, the vegetation repeats exactly, and the sequence length does not change it.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>

#include "pslam/synth/Renderer.h"
#include "pslam/synth/Scenarios.h"

using namespace pslam::synth;

namespace {

constexpr double kFps = 10.0;

const SceneObject* find(const Scenario& s, const std::string& name) {
  for (const auto& o : s.scene.objects)
    if (o.name == name) return &o;
  return nullptr;
}

bool isVehicle(const SceneObject& o) {
  return o.name == "lead truck" || o.name == "queue vehicle" || o.name == "left truck" || o.name == "passing bus" ||
         o.name == "left lane vehicle" || o.name == "parked car";
}

/// Longest interval (seconds) over which the camera pose does not change at all, and where it starts.
std::pair<double, double> longestStandstill(const Scenario& s, double duration) {
  double best = 0, bestStart = -1, start = 0;
  Eigen::Isometry3d prev = s.T_world_cam(0.0);
  for (int i = 1; i <= static_cast<int>(duration * kFps); ++i) {
    const double t = i / kFps;
    const Eigen::Isometry3d T = s.T_world_cam(t);
    const bool still = (T.matrix() - prev.matrix()).cwiseAbs().maxCoeff() < 1e-12;
    if (!still) start = t;
    else if (t - start > best) {
      best = t - start;
      bestStart = start;
    }
    prev = T;
  }
  return {bestStart, best};
}

/// Front and rear x of an object (parts are axis-aligned boxes; vehicles drive along +x with yaw 0).
std::pair<double, double> extentX(const SceneObject& o, double t) {
  const Eigen::Isometry3d T = o.T_world_object(t);
  double lo = 1e18, hi = -1e18;
  for (const auto& p : o.parts) {
    const double c = (T * p.T_object_box).translation().x();
    lo = std::min(lo, c - 0.5 * p.size.x());
    hi = std::max(hi, c + 0.5 * p.size.x());
  }
  return {lo, hi};
}

}  // namespace

TEST(JamScenario, IsListedWithDrivingConventions) {
  const auto& names = scenarioNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "jam"), names.end());
  const ScenarioInfo i = scenarioInfo("jam");
  EXPECT_DOUBLE_EQ(i.fps, 10.0);  // KITTI / Virtual KITTI rate
  EXPECT_EQ(i.defaultFrames, 300);
  EXPECT_DOUBLE_EQ(i.depthUnit, 1.0 / 1000.0);
}

TEST(JamScenario, EgoCarStandsStillWhileLargeVehiclesPullAwayAndPass) {
  const Scenario s = makeScenario("jam", 1, 30.0);
  const auto [start, length] = longestStandstill(s, 30.0);
  EXPECT_GE(length, 5.0) << "the ego car must stand still for at least 5 s";
  ASSERT_GT(start, 2.0) << "it drives first (initialization needs parallax)";
  const double end = start + length;
  // The camera moves before and after (stop-and-go).
  EXPECT_GT((s.T_world_cam(start).translation() - s.T_world_cam(0.0).translation()).norm(), 10.0);
  EXPECT_GT((s.T_world_cam(30.0).translation() - s.T_world_cam(end).translation()).norm(), 10.0);
  for (const char* name : {"lead truck", "passing bus", "left truck"}) {
    const SceneObject* o = find(s, name);
    ASSERT_NE(o, nullptr) << name;
    EXPECT_TRUE(o->moving) << name;
    const double moved = o->T_world_object(end).translation().x() - o->T_world_object(start).translation().x();
    EXPECT_GT(moved, 5.0) << name << " moves while the ego car waits";
  }
  // The lead truck waits in front of the ego car first (both stand), then pulls away before the ego car moves.
  const SceneObject* lead = find(s, "lead truck");
  EXPECT_NEAR(lead->T_world_object(start).translation().x(), lead->T_world_object(start + 2.0).translation().x(), 1e-9);
  const double gapAtStop = extentX(*lead, start).first - s.T_world_cam(start).translation().x();
  EXPECT_GT(gapAtStop, 3.0);
  EXPECT_LT(gapAtStop, 8.0) << "the truck's rear fills the view while the ego car waits";
  // The bus passes the waiting ego camera: behind it at the stop, its front well ahead at the end.
  const SceneObject* bus = find(s, "passing bus");
  const double egoX = s.T_world_cam(start).translation().x();
  EXPECT_LT(extentX(*bus, start).second, egoX);
  EXPECT_GT(extentX(*bus, end).second, egoX + 5.0);
}

TEST(JamScenario, VehiclesMoveWithTheEgoCarAtTimes) {
  // Stop-and-go waves: some vehicles in view move at the ego car's speed for a while (zero image motion).
  const Scenario s = makeScenario("jam", 1, 30.0);
  const SceneObject* lead = find(s, "lead truck");
  ASSERT_NE(lead, nullptr);
  int together = 0;
  for (int i = 1; i < 300; ++i) {
    const double t0 = (i - 1) / kFps, t1 = i / kFps;
    const double ego = s.T_world_cam(t1).translation().x() - s.T_world_cam(t0).translation().x();
    const double veh = lead->T_world_object(t1).translation().x() - lead->T_world_object(t0).translation().x();
    together += ego > 0.2 && std::abs(ego - veh) < 0.02;
  }
  EXPECT_GT(together, 10) << "frames where the lead truck keeps its distance while the ego car drives";
}

TEST(JamScenario, NoVehicleEverOverlapsTheOneAhead) {
  const Scenario s = makeScenario("jam", 4, 60.0);
  std::map<long, std::vector<const SceneObject*>> lanes;  // by lateral position in cm
  for (const auto& o : s.scene.objects)
    if (isVehicle(o) && o.moving) lanes[std::lround(o.T_world_object(0).translation().y() * 100)].push_back(&o);
  ASSERT_EQ(lanes.size(), 2u) << "ego lane and left lane";
  for (int i = 0; i <= 600; ++i) {
    const double t = i / kFps;
    for (auto& [y, vehicles] : lanes) {
      std::vector<std::pair<double, double>> ext;
      for (const SceneObject* o : vehicles) ext.push_back(extentX(*o, t));
      std::sort(ext.begin(), ext.end());
      for (std::size_t k = 1; k < ext.size(); ++k)
        ASSERT_GT(ext[k].first - ext[k - 1].second, 2.0) << "lane y=" << y / 100.0 << " t=" << t;
      if (y < 0) {  // the ego lane: the ego car's front bumper is 1.9 m ahead of the camera
        const double egoFront = s.T_world_cam(t).translation().x() + 1.9;
        double nearestRear = 1e18;
        for (const auto& e : ext)
          if (e.second > egoFront) nearestRear = std::min(nearestRear, e.first);
        ASSERT_GT(nearestRear - egoFront, 2.9) << "t=" << t;
      }
    }
  }
}

TEST(JamScenario, ParkedCarsLineAStretchOfTheEgoPath) {
  const Scenario s = makeScenario("jam", 1, 30.0);
  const double x0 = s.T_world_cam(0).translation().x(), x9 = s.T_world_cam(9.0).translation().x();
  int parked = 0;
  for (const auto& o : s.scene.objects) {
    if (o.name != "parked car") continue;
    ++parked;
    EXPECT_FALSE(o.moving);
    EXPECT_EQ((o.T_world_object(0).matrix() - o.T_world_object(25.0).matrix()).cwiseAbs().maxCoeff(), 0.0);
    const Eigen::Vector3d p = o.T_world_object(0).translation();
    EXPECT_GT(p.x(), x0 - 10.0);
    EXPECT_LT(p.x(), x9 + 5.0) << "the stretch ends where the ego car stops";
    EXPECT_LT(std::abs(p.y() - s.T_world_cam(0).translation().y()), 4.0) << "next to the ego lane";
    for (const auto& part : o.parts) {
      const auto id = s.scene.materials[static_cast<std::size_t>(part.material)].trainId;
      EXPECT_EQ(semanticGroupOfTrainId(id), 1) << "parked cars are of a dynamic class (masking drops them)";
    }
  }
  EXPECT_GE(parked, 4);
}

TEST(JamScenario, RenderedVehiclesAreLabelledDynamic) {
  const Scenario s = makeScenario("jam", 2, 20.0);
  PinholeCamera cam;
  cam.width = 160;
  cam.height = 120;
  cam.fx = cam.fy = 375.0 * 160 / 640;
  cam.cx = 79.5;
  cam.cy = 59.5;
  RenderOptions ro;
  ro.supersampling = 1;
  const Renderer r(cam, ro);
  const int rects = static_cast<int>(s.scene.rects.size());
  for (double t : {1.0, 12.0}) {
    const RenderedView v = r.render(s.scene, s.T_world_cam(t), t);
    int vehiclePixels = 0, parkedPixels = 0, staticPixels = 0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const int id = v.objectId.at<int>(y, x);
        const int group = semanticGroupOfTrainId(v.trainId.at<std::uint8_t>(y, x));
        if (id >= rects && isVehicle(s.scene.objects[static_cast<std::size_t>(id - rects)])) {
          ASSERT_EQ(group, 1) << "vehicle pixel " << x << "," << y << " at t=" << t;
          ++vehiclePixels;
          parkedPixels += s.scene.objects[static_cast<std::size_t>(id - rects)].name == "parked car";
        } else {
          ASSERT_NE(group, 1) << "only vehicles are dynamic, pixel " << x << "," << y << " at t=" << t;
          staticPixels += group == 0;
        }
      }
    const double n = cam.width * cam.height;
    EXPECT_GT(vehiclePixels / n, 0.15) << "dense traffic at t=" << t;
    EXPECT_GT(staticPixels / n, 0.3) << "road and vegetation at t=" << t;
    if (t < 5) {
      EXPECT_GT(parkedPixels, 50) << "parked cars in view at the start";
    }
  }
}

TEST(JamScenario, VegetationRepeatsExactly) {
  // Similar-looking vegetation: the hedge texture repeats every param[0] metres along s.
  Material m;
  m.kind = TextureKind::Hedge;
  m.trainId = static_cast<std::uint8_t>(TrainId::Vegetation);
  m.albedo = 0.3f;
  m.contrast = 0.5f;
  m.seed = 77;
  m.param[0] = 3.2f;
  SurfacePoint p, q;
  p.sizeS = q.sizeS = 100;
  p.sizeT = q.sizeT = 2.6;
  p.footprint = q.footprint = 0.004;
  double spread = 0;
  for (int k = 0; k < 50; ++k) {
    p.s = 0.137 * k;
    p.t = 0.3 + 0.041 * k;
    q = p;
    q.s = p.s + 3.2 * (1 + k % 5);
    EXPECT_NEAR(albedoAt(m, p), albedoAt(m, q), 1e-4) << "s=" << p.s;
    spread = std::max(spread, std::abs(static_cast<double>(albedoAt(m, p) - m.albedo)));
  }
  EXPECT_GT(spread, 0.02) << "but it is not flat";
}

TEST(JamScenario, SequenceLengthDoesNotChangeTheScene) {
  const Scenario a = makeScenario("jam", 9, 0.3), b = makeScenario("jam", 9, 120.0);
  PinholeCamera cam;
  cam.width = 80;
  cam.height = 60;
  cam.fx = cam.fy = 47.0;
  cam.cx = 39.5;
  cam.cy = 29.5;
  const Renderer r(cam, RenderOptions{});
  for (double t : {0.0, 12.0, 25.0}) {
    const RenderedView va = r.render(a.scene, a.T_world_cam(t), t), vb = r.render(b.scene, b.T_world_cam(t), t);
    EXPECT_EQ(cv::countNonZero(va.radiance != vb.radiance), 0) << "t=" << t;
    EXPECT_EQ(cv::countNonZero(va.trainId != vb.trainId), 0) << "t=" << t;
  }
}

TEST(JamScenario, StaticControlIsTheJamWithoutMovingTraffic) {
  const Scenario jam = makeScenario("jam", 3, 30.0), control = makeScenario("jam-static", 3, 30.0);
  int parkedJam = 0, parkedControl = 0;
  for (const auto& o : jam.scene.objects) parkedJam += o.name == "parked car";
  for (const auto& o : control.scene.objects) {
    EXPECT_FALSE(o.moving) << o.name;
    parkedControl += o.name == "parked car";
  }
  EXPECT_EQ(parkedControl, parkedJam);
  PinholeCamera cam;
  cam.width = 80;
  cam.height = 60;
  cam.fx = cam.fy = 47.0;
  cam.cx = 39.5;
  cam.cy = 29.5;
  RenderOptions ro;
  ro.supersampling = 1;  // a pixel sees only its own ray: equal wherever no moving vehicle is hit
  const Renderer r(cam, ro);
  const int rects = static_cast<int>(jam.scene.rects.size());
  for (double t : {1.0, 12.0}) {
    EXPECT_TRUE(jam.T_world_cam(t).isApprox(control.T_world_cam(t), 0.0)) << "same ego motion";
    const RenderedView a = r.render(jam.scene, jam.T_world_cam(t), t), b = r.render(control.scene, control.T_world_cam(t), t);
    auto movingAt = [&](int x, int y) {
      if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) return false;
      const int id = a.objectId.at<int>(y, x);
      return id >= rects && jam.scene.objects[static_cast<std::size_t>(id - rects)].moving;
    };
    int compared = 0;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        bool nearTraffic = false;  // silhouette pixels mix their neighbours' surfaces
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) nearTraffic = nearTraffic || movingAt(x + dx, y + dy);
        if (nearTraffic) continue;
        ++compared;
        ASSERT_EQ(a.radiance.at<float>(y, x), b.radiance.at<float>(y, x)) << x << "," << y << " t=" << t;
        ASSERT_EQ(a.trainId.at<std::uint8_t>(y, x), b.trainId.at<std::uint8_t>(y, x)) << x << "," << y << " t=" << t;
      }
    EXPECT_GT(compared, cam.width * cam.height / 3);
  }
}
