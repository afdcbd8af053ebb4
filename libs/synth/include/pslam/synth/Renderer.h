#pragma once
// CPU ray caster for Scene: per pixel intensity (Lambertian shading of procedural albedo), depth along the
// optical axis, camera-frame normal and Cityscapes class. No display, no GPU, single thread.
//
// Depth, normal and class come from the ray through the pixel centre (pixel (u,v) centre at integer
// coordinates, the OpenCV convention). Intensity is anti-aliased: pixels on a silhouette (a neighbour sees
// another surface) cast N x N sub-pixel rays; inside a surface the texture is band-limited by its pixel
// footprint and, depending on the mode, N x N texture samples are averaged everywhere (Full) or only where a
// first single-sample pass shows strong local contrast, i.e. at sharp pattern edges (Adaptive).
#include <opencv2/core.hpp>

#include <mrpt/img/TCamera.h>

#include "pslam/geometry/PinholeCamera.h"
#include "pslam/synth/Scene.h"

namespace pslam::synth {

/// The camera of a rendering: the project's one camera type (no distortion: renders are ideal pinhole images).
using geometry::PinholeCamera;
/// The camera slam-synth renders with by default: 640 x 480, f 525 px, principal point at the image centre.
PinholeCamera defaultRenderCamera();
/// What the renderer accepts: 8-8192 px wide and high, positive finite focal lengths, a finite principal point;
/// pslam::Error naming the bad value otherwise.
void checkRenderCamera(const PinholeCamera& camera);

enum class AntiAliasing {
  Silhouettes,  ///< supersample object outlines only
  Adaptive,     ///< outlines + interior pixels whose single-sample contrast to a neighbour exceeds a threshold
  Full          ///< outlines + every interior pixel (about 4x slower at N = 2)
};

struct RenderOptions {
  bool textured = true;     ///< false: every surface white (albedo 0.85), Lambertian shading only
  int supersampling = 2;    ///< N: N x N samples per anti-aliased pixel (1 = no supersampling)
  AntiAliasing antiAliasing = AntiAliasing::Adaptive;
  double adaptiveContrast = 6.0;  ///< grey levels that trigger interior supersampling in Adaptive mode
  double nearClip = 0.05;   ///< metres
  int threads = 1;          ///< rows rendered in parallel; the image is identical for any count
};

struct RenderedView {
  cv::Mat radiance;  ///< CV_32FC1, grey level 0..255 before exposure and noise
  cv::Mat depth;     ///< CV_32FC1, metres along the optical axis (z), 0 where no surface
  cv::Mat normals;   ///< CV_32FC3, unit camera-frame normal facing the camera (x right, y down, z fwd); 0 = none
  cv::Mat trainId;   ///< CV_8UC1, Cityscapes trainId (sky = 10, 255 = nothing hit in a scene without sky)
  cv::Mat objectId;  ///< CV_32SC1: rect index, or rects.size() + object index, or -1 for nothing
};

class Renderer {
 public:
  Renderer(PinholeCamera camera, RenderOptions options);
  const PinholeCamera& camera() const { return camera_; }
  const RenderOptions& options() const { return options_; }
  /// Renders `scene` at time `time` (object poses) seen from T_world_cam.
  RenderedView render(const Scene& scene, const Eigen::Isometry3d& T_world_cam, double time) const;

 private:
  PinholeCamera camera_;
  RenderOptions options_;
};

}  // namespace pslam::synth
