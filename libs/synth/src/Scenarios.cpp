#include "pslam/synth/Scenarios.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "pslam/core/Error.h"
#include "pslam/synth/Motion.h"
#include "ScenarioParts.h"

namespace pslam::synth {

namespace {

using namespace detail;
using Eigen::Vector2d;
using Eigen::Vector3d;

// ------------------------------------------------------------------------------------------------ room
/// Seed of a path variant's hand shake: derived from the preset's, so variant 0 keeps its exact path.
std::uint32_t variantJitterSeed(std::uint32_t seed, int pathVariant) {
  return pathVariant == 0 ? seed : seed ^ (0x9E3779B9U * static_cast<std::uint32_t>(pathVariant));
}

Scenario makeRoom(std::uint32_t seed, bool lowTextureVariant, int pathVariant) {
  Dice dice(seed);
  Scenario sc;
  Scene& s = sc.scene;
  if (!lowTextureVariant) {
    sc.info = scenarioInfo("room");
    const double X = 6.0, Y = 5.0, Z = 2.8;
    const int floor = s.addMaterial(material(TextureKind::Tiles, TrainId::Road, dice.seed(), 0.55f, 0.12f));
    const int ceiling = s.addMaterial(material(TextureKind::Ceiling, TrainId::Wall, dice.seed(), 0.8f, 0.03f));
    const int walls[4] = {
        s.addMaterial(material(TextureKind::PosterWall, TrainId::Wall, dice.seed(), 0.7f, 0.16f)),
        s.addMaterial(material(TextureKind::Bricks, TrainId::Wall, dice.seed(), 0.5f, 0.15f)),
        s.addMaterial(material(TextureKind::PosterWall, TrainId::Wall, dice.seed(), 0.65f, 0.18f)),
        s.addMaterial(material(TextureKind::CorridorWall, TrainId::Wall, dice.seed(), 0.72f, 0.12f, {2.5f}))};
    addRoomShell(s, X, Y, Z, floor, walls, ceiling);
    // Furniture (static, labelled building = "other static structure"; Cityscapes has no furniture class).
    const int wood = s.addMaterial(material(TextureKind::Wood, TrainId::Building, dice.seed(), 0.45f, 0.35f));
    const int wood2 = s.addMaterial(material(TextureKind::Wood, TrainId::Building, dice.seed(), 0.6f, 0.3f));
    const int fabric = s.addMaterial(material(TextureKind::Plaster, TrainId::Building, dice.seed(), 0.35f, 0.5f));
    const int screen = s.addMaterial(material(TextureKind::PosterWall, TrainId::Building, dice.seed(), 0.15f, 0.3f));
    s.addStaticBox("table", {2.9, 2.6, 0}, {1.4, 0.8, 0.75}, 0.0, wood);
    s.addStaticBox("box on table", {2.6, 2.5, 0.75}, {0.35, 0.25, 0.2}, 0.3, fabric);
    s.addStaticBox("cabinet", {0.3, 4.0, 0}, {0.5, 1.2, 1.8}, 0.0, wood2);
    s.addStaticBox("sofa", {4.5, 0.5, 0}, {2.0, 0.9, 0.8}, 0.0, fabric);
    s.addStaticBox("shelf", {5.72, 3.5, 0}, {0.45, 2.0, 2.0}, 0.0, wood);
    s.addStaticBox("screen", {3.0, 4.95, 1.0}, {1.4, 0.06, 0.8}, 0.0, screen);
    // A loop through the room: translation first (parallax for initialization), then fast turns.
    std::vector<CameraPath::Key> keys = {
        {0, {1.0, 1.0, 1.5}, {4.5, 3.5, 1.0}},   {2, {1.7, 0.8, 1.45}, {4.8, 3.2, 1.0}},
        {4, {2.6, 1.0, 1.5}, {5.9, 2.4, 1.3}},   {5, {3.0, 1.2, 1.5}, {3.6, 4.9, 1.4}},
        {7, {4.2, 1.8, 1.55}, {1.8, 4.9, 1.0}},  {8, {4.6, 2.4, 1.5}, {0.1, 3.0, 1.2}},
        {10, {4.0, 3.7, 1.4}, {0.1, 1.2, 1.0}},  {12, {2.8, 4.0, 1.45}, {3.0, 0.1, 1.0}},
        {14, {1.5, 3.2, 1.5}, {5.9, 1.2, 1.2}},  {16, {1.0, 1.0, 1.5}, {4.5, 3.5, 1.0}}};
    if (pathVariant == 1) {
      // The same loop 15 % closer to the room centre and 0.15 m lower: it stays clear of the furniture (the
      // camera is above the table and sofa, further from the cabinet and shelf) and sees the same walls.
      const Vector2d centre(X / 2, Y / 2);
      for (auto& k : keys) {
        const Vector2d xy = centre + 0.85 * (k.position.head<2>() - centre);
        k.position = Vector3d(xy.x(), xy.y(), k.position.z() - 0.15);
      }
    }
    Jitter j;
    j.angle = 0.01;
    j.position = 0.008;
    j.frequency = 1.2;
    j.seed = variantJitterSeed(dice.seed(), pathVariant);
    CameraPath path(keys, j, true);
    if (pathVariant == 2) {
      // The loop backwards (the spline is periodic: pose(16 - t) is as smooth as pose(t)).
      const double period = keys.back().t - keys.front().t;
      sc.T_world_cam = [path, period](double t) { return path.pose(period - t); };
    } else {
      sc.T_world_cam = [path](double t) { return path.pose(t); };
    }
    return sc;
  }
  // lowtexture: a hall with a Manhattan structure of near-uniform boards in the middle.
  sc.info = scenarioInfo("lowtexture");
  const double X = 14.0, Y = 13.0, Z = 4.0;
  const int floor = s.addMaterial(material(TextureKind::Uniform, TrainId::Road, dice.seed(), 0.5f, 0.06f));
  const int ceiling = s.addMaterial(material(TextureKind::Uniform, TrainId::Wall, dice.seed(), 0.75f, 0.03f));
  int walls[4];
  for (int& w : walls) w = s.addMaterial(material(TextureKind::Uniform, TrainId::Wall, dice.seed(), 0.7f, 0.04f));
  addRoomShell(s, X, Y, Z, floor, walls, ceiling);
  const int board = s.addMaterial(material(TextureKind::Uniform, TrainId::Building, dice.seed(), 0.85f, 0.03f));
  s.addStaticBox("platform", {7.0, 6.4, 0}, {2.4, 0.8, 0.4}, 0.0, board);
  s.addStaticBox("block", {6.3, 5.8, 0}, {0.8, 0.8, 1.2}, 0.0, board);
  s.addStaticBox("step", {7.9, 5.6, 0}, {1.2, 0.6, 0.8}, 0.0, board);
  s.addStaticBox("panel", {7.0, 7.2, 0}, {2.6, 0.1, 1.3}, 0.0, board);
  s.addStaticBox("low box", {8.6, 6.9, 0}, {0.6, 0.9, 0.5}, 0.0, board);
  // Near first (about 1.5 m), sliding sideways for parallax, then backing off to 4-5 m around the structure.
  std::vector<CameraPath::Key> keys = {
      {0.0, {5.4, 4.4, 1.2}, {7.0, 6.2, 0.5}},  {1.5, {6.0, 4.2, 1.25}, {7.2, 6.2, 0.5}},
      {3.0, {7.4, 4.3, 1.3}, {7.0, 6.2, 0.5}},  {4.5, {8.8, 4.9, 1.35}, {7.0, 6.1, 0.5}},
      {6.0, {9.6, 6.8, 1.5}, {7.0, 6.1, 0.5}},  {8.0, {10.8, 9.4, 1.8}, {7.0, 6.0, 0.5}},
      {10.0, {8.0, 10.8, 1.8}, {7.0, 6.0, 0.5}}, {12.0, {4.6, 10.2, 1.7}, {7.0, 6.0, 0.6}},
      {14.0, {3.2, 7.0, 1.6}, {7.0, 6.0, 0.6}}};
  Jitter j;
  j.angle = 0.006;
  j.position = 0.005;
  j.frequency = 1.0;
  j.seed = dice.seed();
  CameraPath path(keys, j, false);
  sc.T_world_cam = [path](double t) { return path.pose(t); };
  return sc;
}

// ------------------------------------------------------------------------------------------------ corridor
/// Point and tangent on the rounded rectangle [0,X]x[0,Y] (corner radius r), arc length s counter-clockwise
/// from (r, 0).
void roundedRectangle(double X, double Y, double r, double s, Vector2d& p, Vector2d& tangent) {
  const double a = X - 2 * r, b = Y - 2 * r, q = 0.5 * M_PI * r;
  const double L = 2 * a + 2 * b + 4 * q;
  s = std::fmod(std::fmod(s, L) + L, L);
  const Vector2d corners[4] = {{X - r, r}, {X - r, Y - r}, {r, Y - r}, {r, r}};
  const Vector2d starts[4] = {{r, 0}, {X, r}, {X - r, Y}, {0, Y - r}};
  const Vector2d dirs[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  const double lens[4] = {a, b, a, b};
  for (int k = 0; k < 4; ++k) {
    if (s <= lens[k]) {
      p = starts[k] + s * dirs[k];
      tangent = dirs[k];
      return;
    }
    s -= lens[k];
    if (s <= q) {
      const double phi = s / r;  // turning left by phi from dirs[k]
      const Vector2d out(dirs[k].y(), -dirs[k].x());  // right of the direction = away from the arc centre
      p = corners[k] + r * (std::cos(phi) * out + std::sin(phi) * dirs[k]);
      tangent = std::cos(phi) * dirs[k] - std::sin(phi) * out;
      return;
    }
    s -= q;
  }
  p = starts[0];
  tangent = dirs[0];
}

double corridorLoopLength() {
  const double X = 24, Y = 12, r = 0.9;
  return 2 * (X - 2 * r) + 2 * (Y - 2 * r) + 2 * M_PI * r;
}

Scenario makeCorridor(std::uint32_t seed, int pathVariant) {
  Dice dice(seed);
  Scenario sc;
  sc.info = scenarioInfo("corridor");
  Scene& s = sc.scene;
  const double X = 24, Y = 12, r = 0.9, w = 2.4, Z = 2.7;
  const int floor = s.addMaterial(material(TextureKind::Tiles, TrainId::Road, dice.seed(), 0.5f, 0.1f));
  const int ceiling = s.addMaterial(material(TextureKind::Ceiling, TrainId::Wall, dice.seed(), 0.8f, 0.03f));
  s.addFloor(-w / 2, -w / 2, X + w / 2, Y + w / 2, 0, floor);
  s.addFloor(-w / 2, -w / 2, X + w / 2, Y + w / 2, Z, ceiling);
  const Vector2d c[4] = {{-w / 2, -w / 2}, {X + w / 2, -w / 2}, {X + w / 2, Y + w / 2}, {-w / 2, Y + w / 2}};
  for (int k = 0; k < 4; ++k) {
    const int m = s.addMaterial(material(TextureKind::CorridorWall, TrainId::Wall, dice.seed(),
                                         static_cast<float>(dice.uniform(0.6, 0.75)), 0.06f,
                                         {static_cast<float>(dice.uniform(3.5, 5.5))}));
    s.addWall(c[k], c[(k + 1) % 4], 0, Z, m);
  }
  const int inner = s.addMaterial(material(TextureKind::CorridorWall, TrainId::Wall, dice.seed(), 0.68f, 0.06f, {4.2f}));
  s.addStaticBox("inner block", {X / 2, Y / 2, 0}, {X - w, Y - w, Z}, 0, inner);
  const double v = 1.2, ramp = 1.5;
  // Where the walk starts (arc length along the loop), its direction, and its offset from the centre line
  // (right of the walking direction) and height. Variant 0: 2 m along the first straight, counter-clockwise.
  double start = 2.0, direction = 1.0, lateral = 0.0, height = 1.3, targetHeight = 1.15;
  if (pathVariant == 1) {
    start = 3.0;
    lateral = 0.35;
    height = 1.45;
    targetHeight = 1.3;
  } else if (pathVariant == 2) {
    start = 21.0;  // near the end of the first straight, walking back towards the preset's start
    direction = -1.0;
  }
  // From rest to walking pace. Forwards the start is the profile's offset (the preset's exact arithmetic).
  const SpeedProfile speed({0.0, ramp}, {0.0, v}, direction > 0 ? start : 0.0);
  Jitter j;
  j.angle = 0.004;
  j.position = 0.003;
  j.frequency = 1.0;
  j.seed = variantJitterSeed(dice.seed(), pathVariant);
  sc.T_world_cam = [=](double t) {
    const double travelled = speed.distance(std::max(t, 0.0));
    const double sNow = direction > 0 ? travelled : start - travelled;
    Vector2d p, tan, pAhead, tanAhead;
    roundedRectangle(X, Y, r, sNow, p, tan);
    roundedRectangle(X, Y, r, sNow + direction * 1.5, pAhead, tanAhead);  // look ahead: turns start before the corner
    tan *= direction;
    tanAhead *= direction;
    const Vector2d right(tan.y(), -tan.x());
    p += lateral * right;
    pAhead += lateral * Vector2d(tanAhead.y(), -tanAhead.x());
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const Vector3d pos(p.x(), p.y(), height);
    const Vector3d target(pAhead.x() + 2.0 * tanAhead.x(), pAhead.y() + 2.0 * tanAhead.y(), targetHeight);
    T.linear() = lookAtRotation(target - pos, Vector3d::UnitZ());
    T.translation() = pos;
    return applyJitter(T, j, t);
  };
  return sc;
}

}  // namespace

const std::vector<std::string>& scenarioNames() {
  static const std::vector<std::string> names = {"room", "lowtexture", "street", "corridor", "jam", "jam-static"};
  return names;
}

ScenarioInfo scenarioInfo(const std::string& name) {
  ScenarioInfo i;
  i.name = name;
  if (name == "room") {
    i.description = "textured Manhattan room (6 x 5 x 2.8 m), posters, bricks, tiles, furniture; handheld loop "
                    "with fast turns (ICL-NUIM-like)";
    i.fps = 30;
    i.depthUnit = 1.0 / 5000.0;
    i.focalAt640 = 481.2;
    i.defaultFrames = 300;
    i.pathVariants = 3;
  } else if (name == "lowtexture") {
    i.description = "near-uniform Manhattan structure of boxes in a plain hall, seen from ~1.5 m then 4-5 m "
                    "(TUM structure_notexture-like)";
    i.fps = 30;
    i.depthUnit = 1.0 / 5000.0;
    i.focalAt640 = 525.0;
    i.defaultFrames = 420;
  } else if (name == "street") {
    i.description = "street canyon with facades, parked cars, walking and crossing pedestrians, oncoming traffic "
                    "and a queue at a red light that stops and drives off (stop-and-go)";
    i.fps = 10;
    i.depthUnit = 1.0 / 1000.0;
    i.focalAt640 = 400.0;
    i.defaultFrames = 300;
  } else if (name == "corridor") {
    i.description = "70 m corridor loop (24 x 12 m) around an inner block with doors and notice boards; the "
                    "camera returns to its start, so drift is visible (HRBB4-like)";
    i.fps = 15;
    i.depthUnit = 1.0 / 2000.0;  // the 20 m straights exceed the 13 m range of 1/5000 m units
    i.focalAt640 = 450.0;
    i.defaultFrames = static_cast<int>(std::ceil((corridorLoopLength() / 1.2 + 0.75 + 1.0) * 15));
    i.pathVariants = 3;
  } else if (name == "jam" || name == "jam-static") {
    i.description = name == "jam"
                        ? "stop-and-go traffic jam on a motorway between homogeneous vegetation, guardrails and dashed "
                          "lanes; well-textured trucks, vans and buses around the ego car, which stands 7 s while "
                          "they pull away or pass; a stretch of parked cars (Virtual KITTI 20-like)"
                        : "the jam without its moving traffic (same road, vegetation, parked cars and ego motion): "
                          "the control for what the static background alone allows";
    i.fps = 10;
    i.depthUnit = 1.0 / 1000.0;
    i.focalAt640 = 375.0;
    i.defaultFrames = 300;
  } else {
    std::string known;
    for (const auto& n : scenarioNames()) known += (known.empty() ? "" : ", ") + n;
    throw Error("scenario '" + name + "' is unknown (known: " + known + ")");
  }
  return i;
}

void requirePathVariant(const std::string& name, int pathVariant) {
  const ScenarioInfo info = scenarioInfo(name);  // validates the name
  if (pathVariant >= 0 && pathVariant < info.pathVariants) return;
  throw Error("scenario '" + name + "' has no path variant " + std::to_string(pathVariant) + " (it has " +
              (info.pathVariants == 1 ? std::string("only 0") : "0 to " + std::to_string(info.pathVariants - 1)) + ")");
}

Scenario makeScenario(const std::string& name, std::uint32_t seed, double duration, int pathVariant) {
  requirePathVariant(name, pathVariant);  // validates the name too
  if (name == "room") return makeRoom(seed, false, pathVariant);
  if (name == "lowtexture") return makeRoom(seed, true, pathVariant);
  if (name == "street") return detail::makeStreet(seed, duration);
  if (name == "jam" || name == "jam-static") return detail::makeJam(seed, duration, name == "jam");
  return makeCorridor(seed, pathVariant);
}

}  // namespace pslam::synth
