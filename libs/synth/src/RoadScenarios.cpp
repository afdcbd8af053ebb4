// The road scenes (doc/synthetic.md): a street with traffic, and the motorway traffic jam of thesis §3.5.5.2.
#include <algorithm>
#include <cmath>
#include <random>

#include "ScenarioParts.h"
#include "pslam/core/Error.h"
#include "pslam/synth/Motion.h"

namespace pslam::synth::detail {

using Eigen::Vector2d;
using Eigen::Vector3d;

// ------------------------------------------------------------------------------------------------ street
struct Vehicle {
  enum Kind { Car, Truck, Bus, Van };
  /// Extent of the body ahead of / behind the object origin along its x axis (m).
  static double front(Kind k) { return k == Car ? 2.1 : k == Truck ? 4.7 : k == Bus ? 5.75 : 2.9; }
  static double rear(Kind k) { return k == Car ? 2.1 : k == Truck ? 4.6 : k == Bus ? 5.75 : 2.4; }
};

/// A vehicle of boxes. `livery` (the jam's vehicles; the street keeps plain ones): printed wraps on car doors
/// and a sticker on the back, advertisement panels under bus windows, cargo sides printed all over with sharp
/// artwork, and cargo rear doors with a logo, locking bars and a plate.
SceneObject makeVehicleObject(Scene& s, Dice& dice, Vehicle::Kind kind, const std::string& name,
                              bool livery = false) {
  SceneObject o;
  o.name = name;
  const float paint = static_cast<float>(dice.uniform(0.08, 0.9));
  const float lv = livery ? 1.f : 0.f;
  if (kind == Vehicle::Car) {
    const int body = s.addMaterial(material(TextureKind::CarBody, TrainId::Car, dice.seed(), paint, 0.05f, {0.f, lv}));
    const int cabin = s.addMaterial(material(TextureKind::CarCabin, TrainId::Car, dice.seed(), paint, 0.05f));
    o.parts.push_back(part({4.2, 1.8, 0.8}, {0, 0, 0.15}, body));
    o.parts.push_back(part({2.3, 1.6, 0.55}, {-0.3, 0, 0.95}, cabin));
  } else if (kind == Vehicle::Truck) {
    const int cab = s.addMaterial(material(TextureKind::BusBody, TrainId::Truck, dice.seed(), paint, 0.05f, {1.f, lv}));
    const int cargo = s.addMaterial(material(TextureKind::BusBody, TrainId::Truck, dice.seed(), 0.75f, 0.05f, {0.f, lv}));
    o.parts.push_back(part({2.0, 2.4, 2.6}, {3.7, 0, 0.4}, cab));
    o.parts.push_back(part({7.2, 2.5, 3.0}, {-1.0, 0, 0.5}, cargo));
  } else if (kind == Vehicle::Van) {
    const int cab = s.addMaterial(material(TextureKind::BusBody, TrainId::Truck, dice.seed(), paint, 0.05f, {1.f, lv}));
    const int box = s.addMaterial(material(TextureKind::BusBody, TrainId::Truck, dice.seed(),
                                           static_cast<float>(dice.uniform(0.55, 0.85)), 0.05f, {0.f, lv}));
    o.parts.push_back(part({1.7, 2.0, 1.9}, {2.05, 0, 0.3}, cab));
    o.parts.push_back(part({3.6, 2.1, 2.4}, {-0.6, 0, 0.3}, box));
  } else {
    const int body = s.addMaterial(material(TextureKind::BusBody, TrainId::Bus, dice.seed(), paint, 0.05f, {1.f, lv}));
    o.parts.push_back(part({11.5, 2.5, 3.0}, {0, 0, 0.3}, body));
  }
  return o;
}

/// Speed keys of a vehicle that cruises at v from s0, brakes over `brake` seconds to stop at `stopAt`,
/// waits until `go` and accelerates over `accel` seconds to `vAfter` (stop-and-go).
SpeedProfile stopAndGo(double s0, double v, double stopAt, double brake, double go, double accel, double vAfter) {
  const double tBrake = (stopAt - s0 - 0.5 * v * brake) / v;
  require(tBrake > 0 && tBrake + brake < go, "street scenario", "inconsistent stop-and-go timing");
  return SpeedProfile({0.0, tBrake, tBrake + brake, go, go + accel}, {v, v, 0.0, 0.0, vAfter}, s0);
}

Scenario makeStreet(std::uint32_t seed, double duration) {
  Dice dice(seed);
  Scenario sc;
  sc.info = scenarioInfo("street");
  Scene& s = sc.scene;
  s.hasSky = true;
  // Layout (x along the street, y left, z up): road |y| < 8 with lanes at y = -4.5, -1.5 (ours, +x) and
  // +1.5, +4.5 (oncoming), parking strips at |y| in [6, 8]; sidewalks |y| in [8, 12]; facades at |y| = 12.
  const double stopLine = 93.0, tGreen = 19.0;
  const double egoCruise = 7.0;
  const SpeedProfile ego = stopAndGo(0.0, egoCruise, 77.6, 4.0, tGreen + 2.5, 5.0, egoCruise);
  const double xStart = -40.0;
  // A fixed 1 km street covers sequences up to ~2 min; longer ones extend it (each kind of content draws
  // from its own random stream, so the extension does not reshuffle what is already there).
  const double xEnd = std::max(1000.0, ego.distance(duration) + 160.0);

  const int roadMat = s.addMaterial(material(TextureKind::Road, TrainId::Road, dice.seed(), 0.28f, 0.25f,
                                             {static_cast<float>(stopLine + 1.0 - xStart),
                                              static_cast<float>(stopLine + 5.0 - xStart),
                                              static_cast<float>(stopLine - xStart)}));
  s.addFloor(xStart, -8, xEnd, 8, 0, roadMat);
  for (int side : {-1, 1}) {
    Dice buildings(seed, side > 0 ? 11U : 12U), furniture(seed, side > 0 ? 13U : 14U);
    const int walk = s.addMaterial(material(TextureKind::Sidewalk, TrainId::Sidewalk, dice.seed(), 0.55f, 0.15f));
    s.addFloor(xStart, side > 0 ? 8 : -12, xEnd, side > 0 ? 12 : -8, 0.15, walk);
    s.addWall({xStart, side * 8.0}, {xEnd, side * 8.0}, 0, 0.15, walk);  // kerb
    // Facades: a row of buildings of varied height and style.
    for (double x = xStart; x < xEnd;) {
      const double len = std::min(buildings.uniform(12, 30), xEnd - x);
      const double h = buildings.uniform(9, 24);
      const int facade = s.addMaterial(material(
          TextureKind::Facade, TrainId::Building, buildings.seed(), static_cast<float>(buildings.uniform(0.35, 0.7)), 0.12f,
          {static_cast<float>(buildings.uniform(3.0, 3.6)), static_cast<float>(buildings.uniform(2.2, 3.2)),
           static_cast<float>(buildings.uniform(0.4, 0.6)), buildings.chance(0.5) ? 1.f : 0.f}));
      if (side > 0) s.addWall({x + len, 12}, {x, 12}, 0, h, facade);
      else s.addWall({x, -12}, {x + len, -12}, 0, h, facade);
      x += len;
    }
    // Street furniture: lamp posts and trees on the sidewalk.
    const int poleMat = s.addMaterial(material(TextureKind::Plaster, TrainId::Pole, furniture.seed(), 0.45f, 0.2f));
    const int leaves = s.addMaterial(material(TextureKind::Foliage, TrainId::Vegetation, furniture.seed(), 0.3f, 0.3f));
    for (double x = xStart + 10; x < xEnd; x += 25) {
      s.addStaticBox("lamp post", {x, side * 8.5, 0.15}, {0.16, 0.16, 6.0}, 0, poleMat);
      if (furniture.chance(0.6)) {
        const double xt = x + furniture.uniform(8, 16);
        s.addStaticBox("trunk", {xt, side * 9.2, 0.15}, {0.3, 0.3, 2.6}, 0, leaves);
        s.addStaticBox("canopy", {xt, side * 9.2, 2.6}, {2.6, 2.4, 2.4}, furniture.uniform(0, 1.5), leaves);
      }
    }
  }
  s.addWall({xEnd, -12}, {xEnd, 12}, 0, 22,
            s.addMaterial(material(TextureKind::Facade, TrainId::Building, dice.seed(), 0.55f, 0.12f, {3.3f, 2.6f, 0.5f, 1.f})));
  // Traffic light and a sign at the stop line.
  const int poleMat = s.addMaterial(material(TextureKind::Plaster, TrainId::Pole, dice.seed(), 0.3f, 0.1f));
  const int lightMat = s.addMaterial(material(TextureKind::PosterWall, TrainId::TrafficLight, dice.seed(), 0.12f, 0.2f));
  const int signMat = s.addMaterial(material(TextureKind::PosterWall, TrainId::TrafficSign, dice.seed(), 0.8f, 0.1f));
  s.addStaticBox("traffic light pole", {stopLine + 0.5, -8.6, 0.15}, {0.18, 0.18, 3.3}, 0, poleMat);
  s.addStaticBox("traffic light", {stopLine + 0.5, -8.6, 3.45}, {0.35, 0.35, 0.95}, 0, lightMat);
  s.addStaticBox("sign pole", {stopLine - 20, -8.7, 0.15}, {0.08, 0.08, 2.2}, 0, poleMat);
  s.addStaticBox("sign", {stopLine - 20, -8.7, 2.35}, {0.05, 0.7, 0.7}, 0, signMat);

  // A vehicle's profile gives dir * x of its centre, so oncoming traffic (dir = -1) uses s0 = -x0.
  auto addVehicle = [&](Dice& looks, Vehicle::Kind kind, double lane, int dir, SpeedProfile profile,
                        const std::string& name, bool moving) {
    SceneObject o = makeVehicleObject(s, looks, kind, name);
    o.moving = moving;
    const double yaw = dir > 0 ? 0.0 : M_PI;
    o.T_world_object = [profile, lane, dir, yaw](double t) { return poseXYYaw(dir * profile.distance(t), lane, yaw); };
    s.addObject(std::move(o));
  };
  // Our direction: a queue at the red light that drives off at green (stop-and-go), and an overtaking car.
  const double qFront = stopLine - 1.0;
  const double q1 = qFront - 2.1, l1 = q1 - 4.2 - 2.0;
  addVehicle(dice, Vehicle::Car, -4.5, 1, stopAndGo(30, 7, q1, 4.0, tGreen, 4.0, 8.5), "queue car 1", true);
  addVehicle(dice, Vehicle::Car, -4.5, 1, stopAndGo(16, 7, l1, 4.0, tGreen + 1.0, 4.5, 8.0), "lead car", true);
  const double truck = qFront - 4.7;
  addVehicle(dice, Vehicle::Truck, -1.5, 1, stopAndGo(40, 6, truck, 4.0, tGreen + 0.5, 6.0, 6.0), "truck", true);
  addVehicle(dice, Vehicle::Car, -1.5, 1, stopAndGo(-25, 11, truck - 4.7 - 2.0 - 2.1, 4.0, tGreen + 1.8, 4.5, 8.5),
             "overtaking car", true);
  // Oncoming traffic, flowing, with a bus.
  for (double lane : {1.5, 4.5}) {
    Dice traffic(seed, lane == 1.5 ? 21U : 22U);
    for (double x = 25 + traffic.uniform(0, 20); x < xEnd + 150; x += traffic.uniform(18, 40)) {
      const Vehicle::Kind kind = (lane == 1.5 && traffic.chance(0.15)) ? Vehicle::Bus : Vehicle::Car;
      const double v = traffic.uniform(7.5, 10.5);
      addVehicle(traffic, kind, lane, -1, SpeedProfile({0.0}, {v}, -x), "oncoming", true);
    }
  }
  // Parked cars on both parking strips: class car (potentially dynamic, Table 3.1) although they never move.
  for (double side : {-7.0, 7.0}) {
    Dice parked(seed, side > 0 ? 31U : 32U);
    for (double x = xStart + 5; x < xEnd - 5; x += parked.uniform(5.2, 7.5)) {
      if (!parked.chance(0.7) || std::abs(x - stopLine - 3) < 8) continue;
      // Mostly parked in the driving direction of their side; the profile holds dir * x (see addVehicle).
      const int dir = parked.chance(0.8) == (side > 0) ? -1 : 1;
      addVehicle(parked, Vehicle::Car, side, dir, SpeedProfile({0.0}, {0.0}, dir * x), "parked car", false);
    }
  }
  // Pedestrians: walkers along the sidewalks and a group crossing at the zebra while the cars wait.
  auto addPerson = [&](Dice& looks, std::function<Eigen::Isometry3d(double)> traj, bool moving) {
    SceneObject o;
    o.name = "person";
    const int m = s.addMaterial(material(TextureKind::Person, TrainId::Person, looks.seed(), 0.5f, 0.1f,
                                         {static_cast<float>(looks.uniform(0.08, 0.5)),
                                          static_cast<float>(looks.uniform(0.1, 0.9))}));
    o.parts.push_back(part({0.32, 0.5, looks.uniform(1.6, 1.9)}, {0, 0, 0}, m));
    o.T_world_object = std::move(traj);
    o.moving = moving;
    s.addObject(std::move(o));
  };
  for (double side : {-1.0, 1.0}) {
    Dice walkers(seed, side > 0 ? 41U : 42U);
    for (double x = xStart; x < xEnd; x += walkers.uniform(3, 10)) {
      const double y = side * walkers.uniform(9.6, 11.4);
      const double v = walkers.chance(0.15) ? 0.0 : walkers.uniform(1.0, 1.6) * (walkers.chance(0.5) ? 1 : -1);
      const double x0 = x;
      addPerson(walkers, [x0, y, v](double t) { return poseXYYaw(x0 + v * t, y, v >= 0 ? 0.0 : M_PI); }, v != 0.0);
    }
  }
  for (int k = 0; k < 5; ++k) {
    const double x = stopLine + 1.5 + dice.uniform(0, 3);
    const double dir = (k % 2 == 0) ? 1.0 : -1.0;
    const double y0 = -dir * dice.uniform(9.5, 11);
    const double start = dir > 0 ? dice.uniform(8, 11) : dice.uniform(3, 6);
    const double v = dice.uniform(1.2, 1.6);
    const double walk = 2 * std::abs(y0) / v;
    const SpeedProfile prof({start, start + 1.0, start + walk, start + walk + 1.0}, {0.0, v, v, 0.0}, 0.0);
    addPerson(dice, [x, y0, dir, prof](double t) { return poseXYYaw(x, y0 + dir * prof.distance(t), dir * M_PI / 2); }, true);
  }

  Jitter j;
  j.angle = 0.003;
  j.position = 0.01;
  j.frequency = 2.0;
  j.seed = dice.seed();
  sc.T_world_cam = [ego, j](double t) {
    const Vector3d pos(ego.distance(t), -4.5, 1.6);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = lookAtRotation(Vector3d(20.0, 0.0, -0.8), Vector3d::UnitZ());
    T.translation() = pos;
    // Road vibration scales with speed, so the camera is still while the car waits.
    Jitter jj = j;
    const double k = std::min(1.0, ego.speed(t) / 7.0);
    jj.angle *= k;
    jj.position *= k;
    return applyJitter(T, jj, t);
  };
  return sc;
}

// ------------------------------------------------------------------------------------------------ jam
// Traffic jam on a two-lane motorway between vegetation (Virtual KITTI 20 as thesis §3.5.5.2 describes it).
// Layout (x along the road, y left, z up): carriageway |y| < 3.5 with the ego lane at y = -1.75 and the left
// lane at +1.75; a hard shoulder y in [-7.2, -3.5] with cars parked along the first stretch; guardrails at
// y = -7 and +3.9; a hedge at y = +4.6 and tree lines beyond it and above an embankment on the right.
//
// Traffic moves in stop-and-go waves: every vehicle of a lane follows the lane's speed profile D shifted in
// time, x(t) = x0 + D(t + tau) - D(tau), vehicles further ahead with a larger tau (the wave reaches them
// earlier). With start positions chained by the stand-still gap plus D(tau_a) - D(tau_b), the gap to the
// vehicle ahead is gapMin + D(t + tau_a) - D(t + tau_b) >= gapMin at all times: nobody collides.

/// Ego lane profile (t, v): drive along the parked cars, brake, stand 7 s, creep, stop-and-go; then 20 s cycles.
const std::vector<std::pair<double, double>> kJamEgoKeys = {{0, 5},  {5, 5},  {9, 0},  {16, 0}, {19, 3},
                                                           {21, 3}, {23, 1}, {24, 1}, {28, 6}};
/// Left lane: crawls while the ego car approaches (it overtakes the queue) and while the ego car stands (the
/// queue, a bus first, passes it), then moves with the ego lane.
const std::vector<std::pair<double, double>> kJamLeftKeys = {{0, 1.0},  {9, 1.0},   {11, 1.6},  {16, 1.6},
                                                            {19, 3.2}, {21, 3.0},  {23, 1.2},  {24, 1.2}, {28, 5.5}};
constexpr double kJamStopBegin = 9.0;  // the ego car stands still in [9, 16] s
constexpr double kJamLeadTau = 4.0;   // the lead truck runs 4 s ahead in the wave: it pulls away at 12 s
constexpr double kJamEgoY = -1.75, kJamLeftY = 1.75, kJamParkedY = -5.0;
constexpr double kJamParkedFrom = -8.0, kJamParkedTo = 34.0;  // ends where the ego car stops: out of view then
constexpr double kJamEgoFront = 1.9;  // ego car's front bumper ahead of the camera (m)

/// Speed profile from scripted keys, continued until `until` with cycles of 20 s: cruise 8 s, brake 3 s,
/// stand 5 s, accelerate 4 s to `cycleSpeed`.
SpeedProfile jamProfile(const std::vector<std::pair<double, double>>& keys, double until, double cycleSpeed) {
  std::vector<double> t, v;
  for (const auto& [tk, vk] : keys) {
    t.push_back(tk);
    v.push_back(vk);
  }
  while (t.back() < until) {
    const double t0 = t.back(), v0 = v.back();
    for (const auto& [dt, vk] : std::initializer_list<std::pair<double, double>>{
             {8.0, v0}, {11.0, 0.0}, {16.0, 0.0}, {20.0, cycleSpeed}}) {
      t.push_back(t0 + dt);
      v.push_back(vk);
    }
  }
  return SpeedProfile(t, v, 0.0);
}

/// `traffic` = false: the control scene "jam-static", identical except that no vehicle moves (the parked
/// cars stay), which measures what the static background alone allows.
Scenario makeJam(std::uint32_t seed, double duration, bool traffic) {
  Dice dice(seed);
  Scenario sc;
  sc.info = scenarioInfo(traffic ? "jam" : "jam-static");
  Scene& s = sc.scene;
  s.hasSky = true;
  // The profiles cover t + tau of the vehicles far ahead. A fixed 1 km road with traffic covers sequences up to
  // about 4 min, so shorter ones share one scene; longer ones extend it (each kind of content that grows with
  // the length draws from its own random stream, so the extension does not reshuffle what is there).
  const double horizon = std::max(duration, 300.0) + 300.0;
  const SpeedProfile ego = jamProfile(kJamEgoKeys, horizon, 5.0);
  const SpeedProfile left = jamProfile(kJamLeftKeys, horizon, 5.5);
  const double xStart = -60.0;
  const double xEnd = std::max(1000.0, ego.distance(duration) + 300.0);

  // ---- static scene: low-contrast asphalt, repetitive markings, guardrails and vegetation
  const int roadMat = s.addMaterial(material(TextureKind::Highway, TrainId::Road, dice.seed(), 0.3f, 0.35f,
                                             {3.5f, 2.f, 6.f, 18.f}));
  s.addFloor(xStart, -3.5, xEnd, 3.5, 0, roadMat);
  const int shoulder = s.addMaterial(material(TextureKind::Plaster, TrainId::Road, dice.seed(), 0.3f, 0.3f));
  s.addFloor(xStart, -7.2, xEnd, -3.5, 0, shoulder);
  const int verge = s.addMaterial(material(TextureKind::Plaster, TrainId::Terrain, dice.seed(), 0.36f, 0.25f));
  s.addFloor(xStart, 3.5, xEnd, 4.6, 0, verge);
  // Embankment rising from the right guardrail to the tree line.
  const Vector3d slope(0, -5.8, 3.4);
  s.addRect({xStart, -7.2, 0}, Vector3d::UnitX(), slope.normalized(), xEnd - xStart, slope.norm(), verge);
  const int hedgeMat = s.addMaterial(material(TextureKind::Hedge, TrainId::Vegetation, dice.seed(), 0.28f, 0.5f, {3.2f}));
  s.addWall({xStart, 4.6}, {xEnd, 4.6}, 0, 2.6, hedgeMat);
  const int treesL = s.addMaterial(material(TextureKind::Hedge, TrainId::Vegetation, dice.seed(), 0.22f, 0.5f, {7.3f}));
  s.addWall({xStart, 11.0}, {xEnd, 11.0}, 0, 12.0, treesL);
  const int treesR = s.addMaterial(material(TextureKind::Hedge, TrainId::Vegetation, dice.seed(), 0.24f, 0.5f, {6.1f}));
  s.addWall({xStart, -13.0}, {xEnd, -13.0}, 3.3, 10.0, treesR);
  const int beam = s.addMaterial(material(TextureKind::Guardrail, TrainId::Fence, dice.seed(), 0.55f, 0.04f, {2.0f}));
  const int post = s.addMaterial(material(TextureKind::Plaster, TrainId::Fence, dice.seed(), 0.4f, 0.05f));
  for (double y : {-7.0, 3.9}) {
    s.addWall({xStart, y}, {xEnd, y}, 0.5, 0.32, beam);
    const double behind = y < 0 ? -0.07 : 0.07;
    for (double x = std::ceil(xStart / 2.0) * 2.0; x < xEnd; x += 2.0)
      s.addStaticBox("guardrail post", {x, y + behind, 0}, {0.12, 0.1, 0.72}, 0, post);
  }

  // ---- traffic
  auto addVehicle = [&](Dice& looks, Vehicle::Kind kind, double lane, const SpeedProfile& profile, double tau,
                        double x0, const std::string& name, bool moving) {
    SceneObject o = makeVehicleObject(s, looks, kind, name, true);
    o.moving = moving;
    const double d0 = profile.distance(tau);
    o.T_world_object = [profile, tau, x0, d0, lane](double t) {
      return poseXYYaw(x0 + profile.distance(t + tau) - d0, lane, 0.0);
    };
    s.addObject(std::move(o));
  };
  auto pickKind = [](Dice& d) {
    const double u = d.uniform(0, 1);
    return u < 0.4 ? Vehicle::Car : u < 0.62 ? Vehicle::Van : u < 0.88 ? Vehicle::Truck : Vehicle::Bus;
  };
  const double reach = xEnd - 60.0;  // vehicles ahead up to here (at their start positions)
  if (traffic) {
    // Ego lane: a truck ahead of the ego car (its rear fills the view; it pulls away while the ego car still
    // waits), then a queue. Stand-still gaps 3 m, bumper to bumper.
    Dice queue(seed, 51U);
    const double gapMin = 3.0, dTau = 1.8;
    double tau = kJamLeadTau, prevTau = 0.0, prevFront = kJamEgoFront;
    Vehicle::Kind kind = Vehicle::Truck;
    for (int k = 0; prevFront < reach; ++k) {
      const double rearPos = prevFront + gapMin + ego.distance(tau) - ego.distance(prevTau);
      const double x0 = rearPos + Vehicle::rear(kind);
      addVehicle(queue, kind, kJamEgoY, ego, tau, x0, k == 0 ? "lead truck" : "queue vehicle", true);
      prevFront = x0 + Vehicle::front(kind);
      prevTau = tau;
      tau += dTau;
      kind = pickKind(queue);
    }
  }
  if (traffic) {
    // Left lane: a crawling queue the ego car overtakes before it stops; a bus of that queue is level with the
    // ego camera when the ego car stops and passes it while it waits, a truck ahead of the bus pulls away.
    Dice lane(seed, 52U);
    const double gapMin = 2.5, dTau = 0.8;
    struct Slot {
      Vehicle::Kind kind;
      double tau, x0;
      std::string name;
    };
    // The bus (tau = 0): its front 1 m behind the camera at the stop.
    const double busX0 = ego.distance(kJamStopBegin) - 1.0 - Vehicle::front(Vehicle::Bus) -
                         (left.distance(kJamStopBegin) - left.distance(0.0));
    std::vector<Slot> slots = {{Vehicle::Bus, 0.0, busX0, "passing bus"}};
    for (double front = busX0 + Vehicle::front(Vehicle::Bus), tau = 0.0; front < reach;) {
      const Vehicle::Kind kind = slots.size() == 1 ? Vehicle::Truck : pickKind(lane);
      const double t2 = tau + dTau;
      const double x0 = front + gapMin + left.distance(t2) - left.distance(tau) + Vehicle::rear(kind);
      slots.push_back({kind, t2, x0, slots.size() == 1 ? "left truck" : "left lane vehicle"});
      front = x0 + Vehicle::front(kind);
      tau = t2;
    }
    for (double rearEdge = busX0 - Vehicle::rear(Vehicle::Bus), tau = 0.0; rearEdge > xStart;) {
      const Vehicle::Kind kind = pickKind(lane);
      const double t2 = tau - dTau;
      const double x0 = rearEdge - gapMin - (left.distance(tau) - left.distance(t2)) - Vehicle::front(kind);
      slots.push_back({kind, t2, x0, "left lane vehicle"});
      rearEdge = x0 - Vehicle::rear(kind);
      tau = t2;
    }
    for (const Slot& sl : slots) addVehicle(lane, sl.kind, kJamLeftY, left, sl.tau, sl.x0, sl.name, true);
  }
  {
    // Parked cars on the hard shoulder along the first stretch: class car/truck (potentially dynamic, so
    // masking discards them) but static, close and well textured.
    Dice parked(seed, 31U);
    const SpeedProfile still({0.0}, {0.0}, 0.0);
    for (double x = kJamParkedFrom; x < kJamParkedTo; x += parked.uniform(5.4, 7.2)) {
      if (!parked.chance(0.85)) continue;
      const Vehicle::Kind kind = parked.chance(0.15) ? Vehicle::Van : Vehicle::Car;
      addVehicle(parked, kind, kJamParkedY + parked.uniform(-0.15, 0.15), still, 0.0, x, "parked car", false);
    }
  }

  Jitter j;
  j.angle = 0.003;
  j.position = 0.01;
  j.frequency = 2.0;
  j.seed = dice.seed();
  sc.T_world_cam = [ego, j](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = lookAtRotation(Vector3d(20.0, 0.0, -0.8), Vector3d::UnitZ());
    T.translation() = Vector3d(ego.distance(t), kJamEgoY, 1.6);
    // Road vibration scales with speed: the camera is exactly still while the car stands.
    Jitter jj = j;
    const double k = std::min(1.0, ego.speed(t) / 5.0);
    jj.angle *= k;
    jj.position *= k;
    return applyJitter(T, jj, t);
  };
  return sc;
}

}  // namespace pslam::synth::detail
