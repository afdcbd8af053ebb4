// Renderer and motion checks against analytic geometry (small images, fast).
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/synth/Motion.h"
#include "pslam/synth/Renderer.h"
#include "pslam/synth/Texture.h"

using namespace pslam::synth;
using Eigen::Vector3d;

namespace {

PinholeCamera smallCamera() {
  PinholeCamera c;
  c.width = 80;
  c.height = 60;
  c.fx = 70.0;
  c.fy = 72.0;
  c.cx = 39.3;
  c.cy = 30.1;
  return c;
}

Material uniform(float albedo, TrainId cls) {
  Material m;
  m.kind = TextureKind::Uniform;
  m.trainId = static_cast<std::uint8_t>(cls);
  m.albedo = albedo;
  m.contrast = 0.0f;
  return m;
}

Eigen::Isometry3d lookFrom(const Vector3d& pos, const Vector3d& target) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = lookAtRotation(target - pos, Vector3d::UnitZ());
  T.translation() = pos;
  return T;
}

Vector3d rayOf(const PinholeCamera& c, double u, double v) { return {(u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0}; }

}  // namespace

TEST(Renderer, PlaneDepthNormalAndClassMatchRayPlaneIntersection) {
  Scene scene;
  const int m = scene.addMaterial(uniform(0.5f, TrainId::Building));
  // A tilted wall, large enough to fill the view.
  const Vector3d origin(4.0, -10.0, -5.0), axisS = Vector3d(0.3, 1.0, 0.0).normalized(), axisT = Vector3d::UnitZ();
  scene.addRect(origin, axisS, axisT, 20.0, 12.0, m);
  const PinholeCamera cam = smallCamera();
  const Renderer renderer(cam, RenderOptions{});
  const Eigen::Isometry3d T_world_cam = lookFrom({0.2, 0.5, 1.0}, {5.0, 0.8, 0.6});
  const RenderedView v = renderer.render(scene, T_world_cam, 0.0);
  const Vector3d n = axisS.cross(axisT).normalized();
  const Vector3d C = T_world_cam.translation();
  const Eigen::Matrix3d R = T_world_cam.linear();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      // Ray C + t * R d meets n.X = n.origin at t; with d.z = 1, t is the depth along the optical axis.
      const Vector3d d = rayOf(cam, x, y);
      const double t = n.dot(origin - C) / n.dot(R * d);
      ASSERT_GT(t, 0);
      EXPECT_NEAR(v.depth.at<float>(y, x), t, 1e-5 * t) << x << "," << y;
      const Vector3d nCam = R.transpose() * n;
      const Vector3d expected = nCam.dot(d) > 0 ? Vector3d(-nCam) : nCam;  // facing the camera
      const cv::Vec3f got = v.normals.at<cv::Vec3f>(y, x);
      EXPECT_NEAR(got[0], expected.x(), 1e-6);
      EXPECT_NEAR(got[1], expected.y(), 1e-6);
      EXPECT_NEAR(got[2], expected.z(), 1e-6);
      EXPECT_EQ(v.trainId.at<std::uint8_t>(y, x), static_cast<int>(TrainId::Building));
    }
}

TEST(Renderer, BoxShowsOnlyItsVisibleFacesWithTheirNormals) {
  Scene scene;
  scene.addStaticBox("box", {6.0, 0.4, 0.0}, {1.5, 2.0, 1.2}, 0.5, scene.addMaterial(uniform(0.6f, TrainId::Car)));
  const PinholeCamera cam = smallCamera();
  const Renderer renderer(cam, RenderOptions{});
  const Eigen::Isometry3d T_world_cam = lookFrom({0.0, -1.0, 2.5}, {6.0, 0.4, 0.6});
  const RenderedView v = renderer.render(scene, T_world_cam, 0.0);
  // Box frame: centre, axes and half sizes in world coordinates.
  const Eigen::Matrix3d Rb = Eigen::AngleAxisd(0.5, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d centre(6.0, 0.4, 0.6), half(0.75, 1.0, 0.6);
  const Vector3d C = T_world_cam.translation();
  int faceCount[6] = {0, 0, 0, 0, 0, 0};
  int boxPixels = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      if (v.objectId.at<int>(y, x) < 0) continue;
      ++boxPixels;
      EXPECT_EQ(v.trainId.at<std::uint8_t>(y, x), static_cast<int>(TrainId::Car));
      const cv::Vec3f nc = v.normals.at<cv::Vec3f>(y, x);
      const Vector3d nWorld = T_world_cam.linear() * Vector3d(nc[0], nc[1], nc[2]);
      const Vector3d X = C + v.depth.at<float>(y, x) * (T_world_cam.linear() * rayOf(cam, x, y));
      int matched = -1;
      for (int f = 0; f < 6; ++f) {
        const Vector3d faceNormal = Rb.col(f / 2) * ((f % 2) ? 1.0 : -1.0);
        if (nWorld.dot(faceNormal) > 1 - 1e-6) matched = f;
      }
      ASSERT_GE(matched, 0) << "normal is not a box face normal at " << x << "," << y;
      const Vector3d faceNormal = Rb.col(matched / 2) * ((matched % 2) ? 1.0 : -1.0);
      const Vector3d faceCentre = centre + half[matched / 2] * faceNormal;
      // The face faces the camera, and the 3-D point lies on it (within its extent).
      EXPECT_GT(faceNormal.dot(C - faceCentre), 0) << "back face rendered at " << x << "," << y;
      EXPECT_NEAR(faceNormal.dot(X - faceCentre), 0.0, 1e-4);
      const Vector3d local = Rb.transpose() * (X - centre);
      for (int a = 0; a < 3; ++a) EXPECT_LE(std::abs(local[a]), half[a] + 1e-4);
      ++faceCount[matched];
    }
  EXPECT_GT(boxPixels, 200);
  // Seen from above-left-front: the top face and two side faces, and nothing else.
  int visibleFaces = 0;
  for (int f = 0; f < 6; ++f) {
    const Vector3d faceNormal = Rb.col(f / 2) * ((f % 2) ? 1.0 : -1.0);
    const bool shouldBeVisible = faceNormal.dot(C - (centre + half[f / 2] * faceNormal)) > 0;
    if (shouldBeVisible) {
      ++visibleFaces;
      EXPECT_GT(faceCount[f], 10) << "face " << f;
    } else {
      EXPECT_EQ(faceCount[f], 0) << "face " << f;
    }
  }
  EXPECT_EQ(visibleFaces, 3);
}

TEST(Renderer, LabelsFollowAMovingObjectsProjection) {
  Scene scene;
  scene.addRect({20.0, -30.0, -10.0}, Vector3d::UnitY(), Vector3d::UnitZ(), 60.0, 30.0,
                scene.addMaterial(uniform(0.4f, TrainId::Building)));
  // A thin plate (car class) facing the camera, sliding along +y at 1.5 m/s; camera looks along +x.
  SceneObject plate;
  plate.name = "plate";
  BoxPart p;
  p.size = Vector3d(0.02, 1.2, 0.8);
  p.material = scene.addMaterial(uniform(0.8f, TrainId::Car));
  plate.parts.push_back(p);
  plate.moving = true;
  plate.T_world_object = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Vector3d(8.0, -2.0 + 1.5 * t, 0.3);
    return T;
  };
  scene.addObject(plate);
  const PinholeCamera cam = smallCamera();
  const Renderer renderer(cam, RenderOptions{});
  const Eigen::Isometry3d T_world_cam = lookFrom({0, 0, 0}, {1, 0, 0});
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  cv::Point2d previous(-1, -1);
  for (double t : {0.0, 1.0, 2.0, 2.5}) {
    const RenderedView v = renderer.render(scene, T_world_cam, t);
    // Projection of the plate's front face centre.
    const Vector3d c = T_cam_world * (plate.T_world_object(t).translation() - Vector3d(0.01, 0, 0));
    const cv::Point2d expected(cam.fx * c.x() / c.z() + cam.cx, cam.fy * c.y() / c.z() + cam.cy);
    const cv::Mat isCar = v.trainId == static_cast<int>(TrainId::Car);
    const cv::Moments mo = cv::moments(isCar, true);
    ASSERT_GT(mo.m00, 50) << "t=" << t;
    EXPECT_NEAR(mo.m10 / mo.m00, expected.x, 0.6) << "t=" << t;
    EXPECT_NEAR(mo.m01 / mo.m00, expected.y, 0.6) << "t=" << t;
    EXPECT_EQ(v.trainId.at<std::uint8_t>(cvRound(expected.y), cvRound(expected.x)), static_cast<int>(TrainId::Car));
    if (previous.x >= 0) {  // where it was a second ago is background now
      EXPECT_EQ(v.trainId.at<std::uint8_t>(cvRound(previous.y), cvRound(previous.x)),
                static_cast<int>(TrainId::Building));
    }
    previous = expected;
  }
}

TEST(Renderer, SilhouetteSupersamplingMixesByCoverage) {
  // Front plane covering image columns u < 10.25 at depth 2, background at depth 4; with N = 4 the
  // sub-pixel samples of pixel 10 sit at 9.625, 9.875, 10.125, 10.375: three on the front plane.
  Scene scene;
  const int front = scene.addMaterial(uniform(0.9f, TrainId::Building));
  const int back = scene.addMaterial(uniform(0.2f, TrainId::Building));
  const PinholeCamera cam = smallCamera();
  const double edgeX = (10.25 - cam.cx) * 2.0 / cam.fx;
  scene.addRect({-20.0, -20.0, 2.0}, Vector3d::UnitX(), Vector3d::UnitY(), edgeX + 20.0, 40.0, front);
  scene.addRect({-40.0, -40.0, 4.0}, Vector3d::UnitX(), Vector3d::UnitY(), 80.0, 80.0, back);
  RenderOptions o;
  o.supersampling = 4;
  const RenderedView v = Renderer(cam, o).render(scene, Eigen::Isometry3d::Identity(), 0.0);
  const double shade = scene.lighting.shade(Vector3d(0, 0, -1));  // both planes face the camera (-z)
  const double iFront = 255 * 0.9 * shade, iBack = 255 * 0.2 * shade;
  EXPECT_NEAR(v.radiance.at<float>(20, 5), iFront, 1e-3);
  EXPECT_NEAR(v.radiance.at<float>(20, 20), iBack, 1e-3);
  EXPECT_NEAR(v.radiance.at<float>(20, 10), 0.75 * iFront + 0.25 * iBack, 1e-3);
  EXPECT_NEAR(v.depth.at<float>(20, 10), 2.0, 1e-6);  // the centre 10.0 is on the front plane
  EXPECT_NEAR(v.depth.at<float>(20, 11), 4.0, 1e-6);
}

TEST(Renderer, TextureSticksToTheSurfaceAcrossViewpoints) {
  // Render a brick wall from A and B and warp A's pixels into B through the depth. Control: the same wall
  // with its texture slid by 7 cm along the surface (what a texture not attached to the surface would look
  // like from B). The true warp must explain B far better than the control does.
  Material bricks;
  bricks.kind = TextureKind::Bricks;
  bricks.trainId = static_cast<std::uint8_t>(TrainId::Wall);
  bricks.albedo = 0.5f;
  bricks.contrast = 0.2f;
  Scene scene, slid;
  scene.addRect({2.5, -10.0, -5.0}, Vector3d::UnitY(), Vector3d::UnitZ(), 20.0, 10.0, scene.addMaterial(bricks));
  slid.addRect({2.5, -10.07, -5.0}, Vector3d::UnitY(), Vector3d::UnitZ(), 20.0, 10.0, slid.addMaterial(bricks));
  PinholeCamera cam = smallCamera();
  cam.width = 160;
  cam.height = 120;
  cam.fx = cam.fy = 140.0;
  cam.cx = 79.5;
  cam.cy = 59.5;
  const Renderer renderer(cam, RenderOptions{});
  const Eigen::Isometry3d A = lookFrom({0, 0, 0}, {5, 0, 0});
  const Eigen::Isometry3d B = lookFrom({0.3, 0.4, 0.1}, {5, 0.5, 0.2});
  const RenderedView va = renderer.render(scene, A, 0), vb = renderer.render(scene, B, 0);
  const RenderedView vbSlid = renderer.render(slid, B, 0);
  double warped = 0, control = 0;
  int n = 0;
  for (int y = 5; y < cam.height - 5; ++y)
    for (int x = 5; x < cam.width - 5; ++x) {
      const Vector3d X = A * (va.depth.at<float>(y, x) * rayOf(cam, x, y));
      const Vector3d c = B.inverse() * X;
      const double u = cam.fx * c.x() / c.z() + cam.cx, w = cam.fy * c.y() / c.z() + cam.cy;
      if (u < 1 || w < 1 || u > cam.width - 2 || w > cam.height - 2) continue;
      const cv::Point2f at(static_cast<float>(u), static_cast<float>(w));
      cv::Mat patch, patchSlid;
      cv::getRectSubPix(vb.radiance, {1, 1}, at, patch);
      cv::getRectSubPix(vbSlid.radiance, {1, 1}, at, patchSlid);
      warped += std::abs(patch.at<float>(0, 0) - va.radiance.at<float>(y, x));
      control += std::abs(patchSlid.at<float>(0, 0) - va.radiance.at<float>(y, x));
      ++n;
    }
  ASSERT_GT(n, 5000);
  EXPECT_LT(warped / n, 0.5 * control / n) << "warped " << warped / n << " control " << control / n;
  EXPECT_LT(warped / n, 5.0);
}

TEST(Renderer, WhiteModeHasUniformShadingPerPlane) {
  Scene scene;
  Material m;
  m.kind = TextureKind::Bricks;
  m.trainId = static_cast<std::uint8_t>(TrainId::Wall);
  scene.addRect({5.0, -10.0, -5.0}, Vector3d::UnitY(), Vector3d::UnitZ(), 20.0, 10.0, scene.addMaterial(m));
  RenderOptions o;
  o.textured = false;
  const RenderedView v = Renderer(smallCamera(), o).render(scene, lookFrom({0, 0, 0}, {5, 0.3, 0.1}), 0);
  double lo = 0, hi = 0;
  cv::minMaxLoc(v.radiance, &lo, &hi);
  EXPECT_NEAR(hi - lo, 0.0, 1e-3);
  EXPECT_NEAR(hi, 255 * 0.85 * scene.lighting.shade(Vector3d(-1, 0, 0)), 1e-3);
}

TEST(Renderer, ThreadCountDoesNotChangeTheImage) {
  Scene scene;
  Material bricks;
  bricks.kind = TextureKind::PosterWall;
  scene.addRect({3.0, -10.0, -5.0}, Vector3d::UnitY(), Vector3d::UnitZ(), 20.0, 10.0, scene.addMaterial(bricks));
  scene.addStaticBox("box", {2.0, 0.3, -0.5}, {0.5, 0.6, 0.7}, 0.4, scene.addMaterial(uniform(0.7f, TrainId::Car)));
  RenderOptions one, three;
  three.threads = 3;
  const Eigen::Isometry3d T = lookFrom({0, 0, 0}, {3, 0.2, -0.1});
  const RenderedView a = Renderer(smallCamera(), one).render(scene, T, 0);
  const RenderedView b = Renderer(smallCamera(), three).render(scene, T, 0);
  EXPECT_EQ(cv::countNonZero(a.radiance != b.radiance), 0);
  EXPECT_EQ(cv::countNonZero(a.trainId != b.trainId), 0);
  EXPECT_EQ(cv::countNonZero(a.depth != b.depth), 0);
}

TEST(Renderer, RejectsBadCamera) {
  PinholeCamera c = smallCamera();
  c.fx = -1;
  try {
    Renderer r(c, RenderOptions{});
    FAIL() << "accepted a negative focal length";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("fx"), std::string::npos);
  }
}

TEST(Texture, DeterministicSeededAndBandLimited) {
  Material m;
  m.kind = TextureKind::PosterWall;
  m.seed = 7;
  SurfacePoint p;
  p.s = 1.234;
  p.t = 1.5;
  EXPECT_EQ(albedoAt(m, p), albedoAt(m, p));
  int differs = 0;
  for (int k = 0; k < 50; ++k) {
    p.s = 0.37 * k;
    Material m2 = m;
    m2.seed = 8;
    differs += albedoAt(m, p) != albedoAt(m2, p);
  }
  EXPECT_GT(differs, 40);
  // Far away (huge footprint) every octave is faded out and the noise is exactly its mean.
  EXPECT_EQ(fractalNoise(3.3, 4.4, 1, 1.0, 8, 10.0), 0.0f);
  // Fully resolved noise has a spread; its sample mean is near zero.
  double mean = 0, sq = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double v = fractalNoise(0.013 * i, 0.71 * i, 3, 1.0, 6, 1e-4);
    mean += v;
    sq += v * v;
  }
  mean /= n;
  EXPECT_NEAR(mean, 0.0, 0.05);
  EXPECT_GT(std::sqrt(sq / n - mean * mean), 0.1);
}

TEST(Texture, SemanticGroupsFollowTable31) {
  for (int id = 0; id <= 9; ++id) EXPECT_EQ(semanticGroupOfTrainId(static_cast<std::uint8_t>(id)), 0) << id;
  EXPECT_EQ(semanticGroupOfTrainId(10), 2);
  for (int id = 11; id <= 18; ++id) EXPECT_EQ(semanticGroupOfTrainId(static_cast<std::uint8_t>(id)), 1) << id;
  EXPECT_EQ(semanticGroupOfTrainId(255), 2);
}

TEST(Motion, MonotoneCubicInterpolatesWithoutOvershoot) {
  const MonotoneCubic f({0, 1, 2, 4, 5}, {0, 1, 1, 3, 2.5});
  EXPECT_DOUBLE_EQ(f(0), 0);
  EXPECT_DOUBLE_EQ(f(1), 1);
  EXPECT_DOUBLE_EQ(f(4), 3);
  for (double t = 1; t <= 2; t += 0.01) EXPECT_NEAR(f(t), 1.0, 1e-12);  // flat keys stay flat (a stop)
  for (double t = 2; t <= 4; t += 0.01) {
    EXPECT_GE(f(t), 1 - 1e-12);
    EXPECT_LE(f(t), 3 + 1e-12);
  }
  // C1: left and right finite-difference slopes agree at a key.
  const double h = 1e-6;
  EXPECT_NEAR((f(4) - f(4 - h)) / h, (f(4 + h) - f(4)) / h, 1e-4);
  // Periodic: value and slope continuous across the wrap.
  const MonotoneCubic g({0, 1, 2, 3}, {0, 2, 1, 0}, true);
  EXPECT_NEAR(g(3 - h), g(h), 1e-5);
  EXPECT_NEAR((g(0) - g(-h)) / h, (g(h) - g(0)) / h, 1e-4);
}

TEST(Motion, SpeedProfileDistanceIsTheIntegralOfSpeed) {
  const SpeedProfile p({0, 3, 7, 12, 15}, {7, 7, 0, 0, 8}, 2.0);
  // Midpoint-rule integral of the speed vs the closed form.
  double s = 2.0;
  const double dt = 1e-4;
  for (double t = 0; t < 18 - 1e-9; t += dt) {
    s += p.speed(t + 0.5 * dt) * dt;
    if (std::fmod(t + dt, 1.0) < dt) {
      EXPECT_NEAR(p.distance(t + dt), s, 1e-6) << t;
    }
  }
  EXPECT_NEAR(p.distance(9.0), p.distance(11.0), 1e-12);  // standing still
}

TEST(Motion, LookAtGivesARightHandedCameraWithYDown) {
  const Eigen::Matrix3d R = lookAtRotation(Vector3d(1, 2, -0.3), Vector3d::UnitZ());
  EXPECT_NEAR((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(R.determinant(), 1, 1e-12);
  EXPECT_NEAR((R.col(2) - Vector3d(1, 2, -0.3).normalized()).norm(), 0, 1e-12);
  EXPECT_NEAR(R.col(0).z(), 0, 1e-12);  // no roll: x stays horizontal
  EXPECT_LT(R.col(1).z(), 0);           // image y points down in the world
}
