#include "pslam/synth/Scene.h"

#include <algorithm>

#include "pslam/core/Error.h"

namespace pslam::synth {

double Lighting::shade(const Eigen::Vector3d& n) const {
  return ambient + key * std::max(0.0, n.dot(keyDirection)) + fill * std::max(0.0, n.dot(fillDirection));
}

int Scene::addMaterial(const Material& m) {
  materials.push_back(m);
  return static_cast<int>(materials.size()) - 1;
}

void Scene::addRect(const Eigen::Vector3d& origin, const Eigen::Vector3d& axisS, const Eigen::Vector3d& axisT,
                    double sizeS, double sizeT, int material) {
  require(material >= 0 && material < static_cast<int>(materials.size()), "Scene::addRect", "unknown material");
  require(sizeS > 0 && sizeT > 0, "Scene::addRect", "sizes must be positive");
  RectSurface r;
  r.origin = origin;
  r.axisS = axisS.normalized();
  r.axisT = (axisT - r.axisS * r.axisS.dot(axisT)).normalized();
  r.sizeS = sizeS;
  r.sizeT = sizeT;
  r.material = material;
  rects.push_back(r);
}

void Scene::addWall(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, double z0, double height, int material) {
  const Eigen::Vector2d d = p1 - p0;
  addRect(Eigen::Vector3d(p0.x(), p0.y(), z0), Eigen::Vector3d(d.x(), d.y(), 0), Eigen::Vector3d::UnitZ(), d.norm(),
          height, material);
}

void Scene::addFloor(double x0, double y0, double x1, double y1, double z, int material) {
  addRect(Eigen::Vector3d(x0, y0, z), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), x1 - x0, y1 - y0, material);
}

void Scene::addStaticBox(const std::string& name, const Eigen::Vector3d& bottomCentre, const Eigen::Vector3d& size,
                         double yaw, int material) {
  require(material >= 0 && material < static_cast<int>(materials.size()), "Scene::addStaticBox", "unknown material");
  SceneObject o;
  o.name = name;
  BoxPart part;
  part.size = size;
  part.T_object_box.translation() = Eigen::Vector3d(0, 0, 0.5 * size.z());
  part.material = material;
  o.parts.push_back(part);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = bottomCentre;
  o.T_world_object = [T](double) { return T; };
  o.moving = false;
  objects.push_back(std::move(o));
}

void Scene::addObject(SceneObject object) {
  require(static_cast<bool>(object.T_world_object), "Scene::addObject", object.name + " has no trajectory");
  for (const auto& p : object.parts)
    require(p.material >= 0 && p.material < static_cast<int>(materials.size()), "Scene::addObject",
            object.name + " uses an unknown material");
  objects.push_back(std::move(object));
}

}  // namespace pslam::synth
