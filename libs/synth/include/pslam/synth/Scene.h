#pragma once
// Scenes made of textured rectangles (walls, floors, facades) and boxes (furniture, vehicles, pedestrians),
// boxes grouped into objects that move along their own trajectories. World frame: metres, z up.
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "pslam/synth/Texture.h"

namespace pslam::synth {

/// A finite plane: points origin + a*axisS + b*axisT with a in [0,sizeS], b in [0,sizeT]. Seen from both
/// sides; texture coordinates are (a, b), so axisT should point up on vertical surfaces.
struct RectSurface {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axisS = Eigen::Vector3d::UnitX();  ///< unit
  Eigen::Vector3d axisT = Eigen::Vector3d::UnitY();  ///< unit, orthogonal to axisS
  double sizeS = 1, sizeT = 1;
  int material = 0;
};

/// One box of an object, centred at T_object_box's origin, edges along its axes, full edge lengths `size`.
struct BoxPart {
  Eigen::Vector3d size = Eigen::Vector3d::Ones();
  Eigen::Isometry3d T_object_box = Eigen::Isometry3d::Identity();
  int material = 0;
};

/// A rigid object made of boxes; T_world_object(t) gives its pose at time t (seconds).
struct SceneObject {
  std::string name;
  std::vector<BoxPart> parts;
  std::function<Eigen::Isometry3d(double)> T_world_object;
  bool moving = false;  ///< false: the pose never changes (parked car, furniture)
};

/// Lambertian lighting: ambient + key * max(0, n.key) + fill * max(0, n.fill), directions in world frame
/// pointing towards the lights. View-independent, so a surface keeps its brightness as the camera moves.
struct Lighting {
  Eigen::Vector3d keyDirection = Eigen::Vector3d(0.5, 0.2, 0.85).normalized();
  Eigen::Vector3d fillDirection = Eigen::Vector3d(-0.4, -0.8, -0.45).normalized();
  double ambient = 0.3, key = 0.6, fill = 0.35;  // the six Manhattan orientations get distinct shades
  double shade(const Eigen::Vector3d& normalWorld) const;
};

struct Scene {
  std::vector<Material> materials;
  std::vector<RectSurface> rects;
  std::vector<SceneObject> objects;
  Lighting lighting;
  bool hasSky = false;  ///< rays that hit nothing see sky (class sky) instead of "unlabeled"

  int addMaterial(const Material& m);
  void addRect(const Eigen::Vector3d& origin, const Eigen::Vector3d& axisS, const Eigen::Vector3d& axisT,
               double sizeS, double sizeT, int material);
  /// Vertical wall from (x0,y0) to (x1,y1) at heights [z0, z0+height]; texture s runs from p0 to p1, t up.
  void addWall(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, double z0, double height, int material);
  /// Horizontal rectangle [x0,x1]x[y0,y1] at height z; texture (s,t) = (x-x0, y-y0).
  void addFloor(double x0, double y0, double x1, double y1, double z, int material);
  /// A static box with its bottom face centred at `bottomCentre`, rotated by `yaw` about z.
  void addStaticBox(const std::string& name, const Eigen::Vector3d& bottomCentre, const Eigen::Vector3d& size,
                    double yaw, int material);
  void addObject(SceneObject object);
};

}  // namespace pslam::synth
