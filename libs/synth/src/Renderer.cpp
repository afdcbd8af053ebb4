#include "pslam/synth/Renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>

#include "pslam/core/Error.h"

namespace pslam::synth {

namespace {

constexpr int kTile = 16;
constexpr float kWhiteAlbedo = 0.85f;

/// A primitive transformed into the camera frame of one render call.
struct Prim {
  bool isBox = false;
  int material = 0;
  int objectId = -1;
  // Rectangle: plane n.X = dist, corner o, unit axes u, v, extents su, sv (camera frame).
  Eigen::Vector3d n = Eigen::Vector3d::Zero(), o = Eigen::Vector3d::Zero(), u = Eigen::Vector3d::Zero(),
                  v = Eigen::Vector3d::Zero();
  double dist = 0, su = 0, sv = 0;
  // Box: rotation camera->box, camera centre in box coordinates, half extents.
  Eigen::Matrix3d R_box_cam = Eigen::Matrix3d::Identity(), R_world_box = Eigen::Matrix3d::Identity();
  Eigen::Vector3d camInBox = Eigen::Vector3d::Zero(), half = Eigen::Vector3d::Zero();
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive pixel bounding box
};

struct Hit {
  double t = std::numeric_limits<double>::infinity();  // = depth along z, since rays have d.z = 1
  int prim = -1;
  int face = 0;
  double s = 0, q = 0, sizeS = 1, sizeT = 1;
};

inline bool intersectRect(const Prim& p, const Eigen::Vector3d& d, double nearClip, Hit& hit, int index) {
  const double denom = p.n.dot(d);
  if (std::abs(denom) < 1e-12) return false;
  const double t = p.dist / denom;
  if (t <= nearClip || t >= hit.t) return false;
  const Eigen::Vector3d r = t * d - p.o;
  const double s = r.dot(p.u);
  if (s < 0 || s > p.su) return false;
  const double q = r.dot(p.v);
  if (q < 0 || q > p.sv) return false;
  hit.t = t;
  hit.prim = index;
  hit.face = 0;
  hit.s = s;
  hit.q = q;
  hit.sizeS = p.su;
  hit.sizeT = p.sv;
  return true;
}

inline void boxFaceCoords(const Prim& p, const Eigen::Vector3d& P, int axis, Hit& hit) {
  // Texture axes of a face: the other two box axes in increasing order, so t is the height (z) on the
  // vertical faces.
  const int j = axis == 0 ? 1 : 0;
  const int k = axis == 2 ? 1 : 2;
  hit.s = P[j] + p.half[j];
  hit.q = P[k] + p.half[k];
  hit.sizeS = 2 * p.half[j];
  hit.sizeT = 2 * p.half[k];
}

inline bool intersectBox(const Prim& p, const Eigen::Vector3d& d, double nearClip, Hit& hit, int index) {
  // Slab test in box coordinates (Kay-Kajiya).
  const Eigen::Vector3d db = p.R_box_cam * d;
  const Eigen::Vector3d& ob = p.camInBox;
  double tmin = -std::numeric_limits<double>::infinity(), tmax = std::numeric_limits<double>::infinity();
  int axis = -1;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(db[i]) < 1e-15) {
      if (std::abs(ob[i]) > p.half[i]) return false;
      continue;
    }
    const double inv = 1.0 / db[i];
    double t1 = (-p.half[i] - ob[i]) * inv, t2 = (p.half[i] - ob[i]) * inv;
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > tmin) {
      tmin = t1;
      axis = i;
    }
    tmax = std::min(tmax, t2);
    if (tmin > tmax) return false;
  }
  if (axis < 0 || tmin <= nearClip || tmin >= hit.t) return false;  // behind, or the camera is inside
  hit.t = tmin;
  hit.prim = index;
  // The ray enters through the face whose outward normal opposes it.
  hit.face = 2 * axis + (db[axis] < 0 ? 1 : 0);
  boxFaceCoords(p, ob + tmin * db, axis, hit);
  return true;
}

inline bool intersect(const Prim& p, const Eigen::Vector3d& d, double nearClip, Hit& hit, int index) {
  return p.isBox ? intersectBox(p, d, nearClip, hit, index) : intersectRect(p, d, nearClip, hit, index);
}

/// Texture coordinates where ray d meets the (unbounded) surface of a known primitive face: used for the
/// texture samples of interior pixels, which need no visibility test.
inline double coordsOnSurface(const Prim& p, int face, const Eigen::Vector3d& d, Hit& h) {
  if (!p.isBox) {
    const double t = p.dist / p.n.dot(d);
    const Eigen::Vector3d r = t * d - p.o;
    h.s = r.dot(p.u);
    h.q = r.dot(p.v);
    return t;
  }
  const int axis = face / 2;
  const double sign = (face % 2) ? 1.0 : -1.0;
  const Eigen::Vector3d db = p.R_box_cam * d;
  const double t = (sign * p.half[axis] - p.camInBox[axis]) / db[axis];
  boxFaceCoords(p, p.camInBox + t * db, axis, h);
  return t;
}

/// Camera-frame normal of a hit, facing the camera.
inline Eigen::Vector3d normalOf(const Prim& p, int face, const Eigen::Vector3d& d) {
  Eigen::Vector3d n;
  if (p.isBox) {
    const int axis = face / 2;
    n = p.R_box_cam.row(axis).transpose() * ((face % 2) ? 1.0 : -1.0);
  } else {
    n = p.n;
  }
  return n.dot(d) > 0 ? -n : n;
}

}  // namespace

PinholeCamera defaultRenderCamera() { return PinholeCamera(525.0, 525.0, 319.5, 239.5, 640, 480); }

void checkRenderCamera(const PinholeCamera& camera) {
  const PinholeCamera& c = camera;
  require(c.width >= 8 && c.width <= 8192, "camera", "width must be in [8, 8192], got " + std::to_string(c.width));
  require(c.height >= 8 && c.height <= 8192, "camera", "height must be in [8, 8192], got " + std::to_string(c.height));
  require(std::isfinite(c.fx) && c.fx > 0, "camera", "fx must be positive and finite");
  require(std::isfinite(c.fy) && c.fy > 0, "camera", "fy must be positive and finite");
  require(std::isfinite(c.cx) && std::isfinite(c.cy), "camera", "cx/cy must be finite");
  require(!c.hasDistortion(), "camera", "renders are ideal pinhole images: the distortion must be zero");
}

Renderer::Renderer(PinholeCamera camera, RenderOptions options) : camera_(camera), options_(options) {
  checkRenderCamera(camera_);
  require(options_.supersampling >= 1 && options_.supersampling <= 8, "renderer", "supersampling must be in [1, 8]");
  require(options_.nearClip > 0, "renderer", "nearClip must be positive");
}

RenderedView Renderer::render(const Scene& scene, const Eigen::Isometry3d& T_world_cam, double time) const {
  const int W = camera_.width, H = camera_.height;
  const double fx = camera_.fx, fy = camera_.fy, cx = camera_.cx, cy = camera_.cy;
  const double nearClip = options_.nearClip;
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3d R_world_cam = T_world_cam.linear();

  // ---- Transform primitives to the camera frame and bound their projections.
  std::vector<Prim> prims;
  prims.reserve(scene.rects.size() + 2 * scene.objects.size());
  // Screen bounding box of a convex primitive from its corners and edges: the part in front of the near
  // plane is the hull of the front corners and of the edges' crossings of the near plane.
  auto bound = [&](Prim& p, const Eigen::Vector3d* corners, int n, const int (*edges)[2], int nEdges) {
    double u0 = 1e18, u1 = -1e18, v0 = 1e18, v1 = -1e18;
    bool any = false;
    auto addPoint = [&](const Eigen::Vector3d& c) {
      const double u = fx * c.x() / c.z() + cx, v = fy * c.y() / c.z() + cy;
      u0 = std::min(u0, u);
      u1 = std::max(u1, u);
      v0 = std::min(v0, v);
      v1 = std::max(v1, v);
      any = true;
    };
    for (int i = 0; i < n; ++i)
      if (corners[i].z() >= nearClip) addPoint(corners[i]);
    for (int e = 0; e < nEdges; ++e) {
      const Eigen::Vector3d& a = corners[edges[e][0]];
      const Eigen::Vector3d& b = corners[edges[e][1]];
      if ((a.z() < nearClip) != (b.z() < nearClip)) {
        const double w = (nearClip - a.z()) / (b.z() - a.z());
        Eigen::Vector3d c = a + w * (b - a);
        c.z() = nearClip;
        addPoint(c);
      }
    }
    if (!any) return false;
    p.x0 = static_cast<int>(std::max(0.0, std::floor(std::max(u0, -1e9)) - 1));
    p.x1 = static_cast<int>(std::min(W - 1.0, std::ceil(std::min(u1, 1e9)) + 1));
    p.y0 = static_cast<int>(std::max(0.0, std::floor(std::max(v0, -1e9)) - 1));
    p.y1 = static_cast<int>(std::min(H - 1.0, std::ceil(std::min(v1, 1e9)) + 1));
    return p.x0 <= p.x1 && p.y0 <= p.y1;
  };
  static const int kRectEdges[4][2] = {{0, 1}, {1, 3}, {3, 2}, {2, 0}};
  static const int kBoxEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                       {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (std::size_t i = 0; i < scene.rects.size(); ++i) {
    const auto& r = scene.rects[i];
    Prim p;
    p.material = r.material;
    p.objectId = static_cast<int>(i);
    p.o = T_cam_world * r.origin;
    p.u = T_cam_world.linear() * r.axisS;
    p.v = T_cam_world.linear() * r.axisT;
    p.n = p.u.cross(p.v).normalized();
    p.dist = p.n.dot(p.o);
    p.su = r.sizeS;
    p.sv = r.sizeT;
    const Eigen::Vector3d corners[4] = {p.o, p.o + p.su * p.u, p.o + p.sv * p.v, p.o + p.su * p.u + p.sv * p.v};
    if (bound(p, corners, 4, kRectEdges, 4)) prims.push_back(p);
  }
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const auto& obj = scene.objects[oi];
    const Eigen::Isometry3d T_world_object = obj.T_world_object(time);
    for (const auto& part : obj.parts) {
      const Eigen::Isometry3d T_world_box = T_world_object * part.T_object_box;
      const Eigen::Isometry3d T_cam_box = T_cam_world * T_world_box;
      Prim p;
      p.isBox = true;
      p.material = part.material;
      p.objectId = static_cast<int>(scene.rects.size() + oi);
      p.R_box_cam = T_cam_box.linear().transpose();
      p.R_world_box = T_world_box.linear();
      p.camInBox = -(p.R_box_cam * T_cam_box.translation());
      p.half = 0.5 * part.size;
      Eigen::Vector3d corners[8];
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d local((c & 1 ? 1 : -1) * p.half.x(), (c & 2 ? 1 : -1) * p.half.y(),
                                    (c & 4 ? 1 : -1) * p.half.z());
        corners[c] = T_cam_box * local;
      }
      if (bound(p, corners, 8, kBoxEdges, 12)) prims.push_back(p);
    }
  }

  // ---- Bin primitives into tiles so each ray only tests what may cover it.
  const int tilesX = (W + kTile - 1) / kTile, tilesY = (H + kTile - 1) / kTile;
  std::vector<std::vector<int>> tiles(static_cast<std::size_t>(tilesX * tilesY));
  for (std::size_t i = 0; i < prims.size(); ++i) {
    const auto& p = prims[i];
    for (int ty = p.y0 / kTile; ty <= p.y1 / kTile; ++ty)
      for (int tx = p.x0 / kTile; tx <= p.x1 / kTile; ++tx) tiles[ty * tilesX + tx].push_back(static_cast<int>(i));
  }
  // Casts the ray d of pixel (x, y) against the primitives whose box contains the pixel.
  auto castRay = [&](const Eigen::Vector3d& d, int x, int y, Hit& hit) {
    hit = Hit{};
    for (int idx : tiles[(y / kTile) * tilesX + x / kTile]) {
      const Prim& p = prims[idx];
      if (x < p.x0 || x > p.x1 || y < p.y0 || y > p.y1) continue;
      intersect(p, d, nearClip, hit, idx);
    }
    return hit.prim >= 0;
  };

  // Rows are independent within a pass: with options_.threads > 1 they are interleaved over threads (every
  // pixel is a pure function of the scene, so the output does not depend on the thread count).
  const int threads = std::max(1, std::min(options_.threads, H));
  auto forEachRow = [&](const auto& row) {
    if (threads == 1) {
      for (int y = 0; y < H; ++y) row(y);
      return;
    }
    std::vector<std::thread> pool;
    for (int k = 0; k < threads; ++k)
      pool.emplace_back([&, k] {
        for (int y = k; y < H; y += threads) row(y);
      });
    for (auto& t : pool) t.join();
  };

  // ---- Pass 1: pixel centres -> depth, normal, class, object.
  RenderedView out;
  out.radiance.create(H, W, CV_32FC1);
  out.depth.create(H, W, CV_32FC1);
  out.normals.create(H, W, CV_32FC3);
  out.trainId.create(H, W, CV_8UC1);
  out.objectId.create(H, W, CV_32SC1);
  std::vector<Hit> hits(static_cast<std::size_t>(W) * H);
  const std::uint8_t noHitClass = scene.hasSky ? static_cast<std::uint8_t>(TrainId::Sky)
                                               : static_cast<std::uint8_t>(TrainId::Unlabeled);
  forEachRow([&](int y) {
    auto* depthRow = out.depth.ptr<float>(y);
    auto* normalRow = out.normals.ptr<cv::Vec3f>(y);
    auto* classRow = out.trainId.ptr<std::uint8_t>(y);
    auto* idRow = out.objectId.ptr<std::int32_t>(y);
    const double dy = (y - cy) / fy;
    for (int x = 0; x < W; ++x) {
      const Eigen::Vector3d d((x - cx) / fx, dy, 1.0);
      Hit& h = hits[static_cast<std::size_t>(y) * W + x];
      if (castRay(d, x, y, h)) {
        const Prim& p = prims[h.prim];
        depthRow[x] = static_cast<float>(h.t);
        const Eigen::Vector3d n = normalOf(p, h.face, d);
        normalRow[x] = cv::Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
        classRow[x] = scene.materials[p.material].trainId;
        idRow[x] = p.objectId;
      } else {
        depthRow[x] = 0.f;
        normalRow[x] = cv::Vec3f(0, 0, 0);
        classRow[x] = noHitClass;
        idRow[x] = -1;
      }
    }
  });

  // ---- Pass 2: intensity with anti-aliasing.
  const double focal = std::sqrt(fx * fy);
  const int N = options_.supersampling;
  auto skyRadiance = [&](const Eigen::Vector3d& d) {
    const Eigen::Vector3d w = (R_world_cam * d).normalized();
    return 255.0 * (0.72 + 0.22 * std::clamp(2.0 * w.z(), 0.0, 1.0));
  };
  // Albedo x shading of a point of primitive `p`, face `face`, hit along d at depth t.
  auto shadeSample = [&](const Prim& p, int face, const Eigen::Vector3d& d, const Hit& h, double footprintScale) {
    const Eigen::Vector3d nCam = normalOf(p, face, d);
    const double shading = scene.lighting.shade(R_world_cam * nCam);
    float albedo = kWhiteAlbedo;
    if (options_.textured) {
      // Footprint of the (sub)pixel on the surface; the geometric mean of the two axes of the ellipse keeps
      // grazing surfaces from blurring out completely.
      const double dn = d.norm();
      const double cosine = std::max(std::abs(nCam.dot(d)) / dn, 0.05);
      SurfacePoint sp;
      sp.s = h.s;
      sp.t = h.q;
      sp.face = face;
      sp.sizeS = h.sizeS;
      sp.sizeT = h.sizeT;
      sp.footprint = h.t * dn / focal / std::sqrt(cosine) * footprintScale;
      albedo = albedoAt(scene.materials[p.material], sp);
    }
    return 255.0 * albedo * shading;
  };
  const double subStep = 1.0 / N;
  // Interior texture supersampling of one pixel: N x N samples on its own surface (no visibility test).
  auto interiorSupersampled = [&](int x, int y, const Hit& h) {
    const Prim& p = prims[h.prim];
    double sum = 0;
    for (int sy = 0; sy < N; ++sy)
      for (int sx = 0; sx < N; ++sx) {
        const Eigen::Vector3d d((x - 0.5 + (sx + 0.5) * subStep - cx) / fx, (y - 0.5 + (sy + 0.5) * subStep - cy) / fy,
                                1.0);
        Hit sub = h;
        sub.t = coordsOnSurface(p, h.face, d, sub);
        sum += shadeSample(p, h.face, d, sub, subStep);
      }
    return sum / (N * N);
  };
  const bool texturedInterior = options_.textured && N > 1;
  const bool fullInterior = texturedInterior && options_.antiAliasing == AntiAliasing::Full;
  // 0 = interior sampled once, 1 = final (silhouette, sky, or supersampled interior).
  std::vector<std::uint8_t> done(static_cast<std::size_t>(W) * H, 1);
  forEachRow([&](int y) {
    auto* radRow = out.radiance.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const std::size_t idx = static_cast<std::size_t>(y) * W + x;
      const Hit& h = hits[idx];
      auto same = [&](int xx, int yy) {
        if (xx < 0 || yy < 0 || xx >= W || yy >= H) return true;
        const Hit& o = hits[static_cast<std::size_t>(yy) * W + xx];
        return o.prim == h.prim && o.face == h.face;
      };
      const bool interior = same(x - 1, y) && same(x + 1, y) && same(x, y - 1) && same(x, y + 1);
      double value = 0;
      if (interior && h.prim < 0) {
        value = skyRadiance(Eigen::Vector3d((x - cx) / fx, (y - cy) / fy, 1.0));
      } else if (interior && fullInterior) {
        value = interiorSupersampled(x, y, h);
      } else if (interior) {
        const Eigen::Vector3d d((x - cx) / fx, (y - cy) / fy, 1.0);
        value = shadeSample(prims[h.prim], h.face, d, h, 1.0);
        done[idx] = texturedInterior ? 0 : 1;
      } else {
        const int Ne = std::max(N, 2);  // silhouettes are always supersampled
        const double step = 1.0 / Ne;
        for (int sy = 0; sy < Ne; ++sy)
          for (int sx = 0; sx < Ne; ++sx) {
            const Eigen::Vector3d d((x - 0.5 + (sx + 0.5) * step - cx) / fx, (y - 0.5 + (sy + 0.5) * step - cy) / fy, 1.0);
            Hit sub;
            if (castRay(d, x, y, sub)) value += shadeSample(prims[sub.prim], sub.face, d, sub, step);
            else value += skyRadiance(d);
          }
        value /= Ne * Ne;
      }
      radRow[x] = static_cast<float>(value);
    }
  });
  if (texturedInterior && options_.antiAliasing == AntiAliasing::Adaptive) {
    // Sharp texture edges (mortar, markings, window frames) show up as strong single-sample contrast;
    // only those pixels get the N x N texture average. Decisions use the first-pass values only, so the
    // result does not depend on the scan order.
    const cv::Mat first = out.radiance.clone();
    const float thr = static_cast<float>(options_.adaptiveContrast);
    forEachRow([&](int y) {
      const float* r0 = first.ptr<float>(y);
      const float* rUp = first.ptr<float>(std::max(y - 1, 0));
      const float* rDown = first.ptr<float>(std::min(y + 1, H - 1));
      auto* radRow = out.radiance.ptr<float>(y);
      for (int x = 0; x < W; ++x) {
        const std::size_t idx = static_cast<std::size_t>(y) * W + x;
        if (done[idx]) continue;
        const float v = r0[x];
        const float c = std::max({std::abs(v - r0[std::max(x - 1, 0)]), std::abs(v - r0[std::min(x + 1, W - 1)]),
                                  std::abs(v - rUp[x]), std::abs(v - rDown[x])});
        if (c > thr) radRow[x] = static_cast<float>(interiorSupersampled(x, y, hits[idx]));
      }
    });
  }
  return out;
}

}  // namespace pslam::synth
