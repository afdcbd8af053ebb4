#include "pslam/geometry/PinholeCamera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/calib3d.hpp>

#include "pslam/core/Error.h"

namespace pslam::geometry {

namespace {
void requireFinite(double value, const char* name) {
  if (!std::isfinite(value)) {
    throw Error(std::string("PinholeCamera: ") + name + " is not finite");
  }
}
}  // namespace

PinholeCamera::PinholeCamera(double fx_, double fy_, double cx_, double cy_, int width_, int height_,
                             std::array<double, 5> distortion_)
    : fx(fx_), fy(fy_), cx(cx_), cy(cy_), width(width_), height(height_), distortion(distortion_) {}

PinholeCamera PinholeCamera::fromTCamera(const mrpt::img::TCamera& camera) {
  PinholeCamera result(camera.fx(), camera.fy(), camera.cx(), camera.cy(), static_cast<int>(camera.ncols),
                       static_cast<int>(camera.nrows));
  switch (camera.distortion) {
    case mrpt::img::DistortionModel::none:
      break;
    case mrpt::img::DistortionModel::plumb_bob:
      for (std::size_t i = 5; i < camera.dist.size(); ++i) {
        if (camera.dist[i] != 0.0) {
          throw Error("PinholeCamera: camera '" + camera.cameraName +
                      "' uses rational distortion coefficients k4..k6, which are not supported");
        }
      }
      for (std::size_t i = 0; i < 5; ++i) result.distortion[i] = camera.dist[i];
      break;
    default:
      throw Error("PinholeCamera: camera '" + camera.cameraName +
                  "' has an unsupported distortion model (only none and plumb_bob)");
  }
  result.check();
  return result;
}

mrpt::img::TCamera PinholeCamera::toTCamera() const {
  mrpt::img::TCamera camera;
  camera.ncols = static_cast<uint32_t>(width);
  camera.nrows = static_cast<uint32_t>(height);
  camera.setIntrinsicParamsFromValues(fx, fy, cx, cy);
  if (hasDistortion()) {
    camera.distortion = mrpt::img::DistortionModel::plumb_bob;
    camera.dist.fill(0.0);
    for (std::size_t i = 0; i < 5; ++i) camera.dist[i] = distortion[i];
  } else {
    camera.distortion = mrpt::img::DistortionModel::none;
  }
  return camera;
}

PinholeCamera PinholeCamera::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg,
                                                const std::string& section) {
  mrpt::img::TCamera camera;
  try {
    camera.loadFromConfigFile(section, cfg);
  } catch (const std::exception& e) {
    throw Error("PinholeCamera: cannot read camera section [" + section + "]: " + e.what());
  }
  try {
    return fromTCamera(camera);
  } catch (const Error& e) {
    throw Error("section [" + section + "]: " + e.what());
  }
}

void PinholeCamera::check() const {
  requireFinite(fx, "fx");
  requireFinite(fy, "fy");
  requireFinite(cx, "cx");
  requireFinite(cy, "cy");
  static const char* kDistNames[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (std::size_t i = 0; i < 5; ++i) requireFinite(distortion[i], kDistNames[i]);
  if (fx <= 0.0) throw Error("PinholeCamera: fx must be > 0, got " + std::to_string(fx));
  if (fy <= 0.0) throw Error("PinholeCamera: fy must be > 0, got " + std::to_string(fy));
  if (width <= 0) throw Error("PinholeCamera: width must be > 0, got " + std::to_string(width));
  if (height <= 0) throw Error("PinholeCamera: height must be > 0, got " + std::to_string(height));
  if (cx < 0.0 || cx > width) {
    throw Error("PinholeCamera: cx = " + std::to_string(cx) + " lies outside the image width " +
                std::to_string(width));
  }
  if (cy < 0.0 || cy > height) {
    throw Error("PinholeCamera: cy = " + std::to_string(cy) + " lies outside the image height " +
                std::to_string(height));
  }
}

void PinholeCamera::check(const std::string& context) const {
  require(std::isfinite(fx) && fx > 0.0 && std::isfinite(fy) && fy > 0.0, context,
          "focal lengths fx, fy must be finite and positive");
  require(std::isfinite(cx) && std::isfinite(cy), context, "principal point cx, cy must be finite");
  require(width > 0 && height > 0, context, "image width and height must be positive");
}

PinholeCamera PinholeCamera::withoutDistortion() const {
  PinholeCamera c = *this;
  c.distortion.fill(0.0);
  return c;
}

std::string PinholeCamera::describe() const {
  std::ostringstream os;
  os.precision(10);
  os << "fx " << fx << ", fy " << fy << ", cx " << cx << ", cy " << cy << ", " << width << "x" << height;
  return os.str();
}

bool PinholeCamera::operator==(const PinholeCamera& o) const {
  return fx == o.fx && fy == o.fy && cx == o.cx && cy == o.cy && width == o.width && height == o.height &&
         distortion == o.distortion;
}

bool PinholeCamera::hasDistortion() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0.0; });
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

Eigen::Matrix3d PinholeCamera::Kinv() const {
  Eigen::Matrix3d k;
  k << 1.0 / fx, 0.0, -cx / fx, 0.0, 1.0 / fy, -cy / fy, 0.0, 0.0, 1.0;
  return k;
}

cv::Mat PinholeCamera::cvK() const { return (cv::Mat_<double>(3, 3) << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0); }

cv::Mat PinholeCamera::cvDistortion() const {
  return (cv::Mat_<double>(1, 5) << distortion[0], distortion[1], distortion[2], distortion[3], distortion[4]);
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& X_cam, Eigen::Matrix<double, 2, 3>& jacobian) const {
  const double invZ = 1.0 / X_cam.z();
  const double invZ2 = invZ * invZ;
  jacobian << fx * invZ, 0.0, -fx * X_cam.x() * invZ2, 0.0, fy * invZ, -fy * X_cam.y() * invZ2;
  return project(X_cam);
}

Eigen::Vector3d PinholeCamera::unprojectToPlane(const Eigen::Vector2d& pixel) const {
  return {(pixel.x() - cx) / fx, (pixel.y() - cy) / fy, 1.0};
}

Eigen::Vector3d PinholeCamera::unprojectToBearing(const Eigen::Vector2d& pixel) const {
  return unprojectToPlane(pixel).normalized();
}

std::vector<cv::Point2f> PinholeCamera::undistortPoints(const std::vector<cv::Point2f>& distorted) const {
  if (!hasDistortion() || distorted.empty()) return distorted;
  std::vector<cv::Point2f> undistorted;
  // P = K keeps the result in pixels of the ideal camera (ORB-SLAM's UndistortKeyPoints).
  cv::undistortPoints(distorted, undistorted, cvK(), cvDistortion(), cv::noArray(), cvK());
  return undistorted;
}

std::vector<cv::KeyPoint> PinholeCamera::undistortKeyPoints(const std::vector<cv::KeyPoint>& distorted) const {
  std::vector<cv::Point2f> points;
  points.reserve(distorted.size());
  for (const auto& kp : distorted) points.push_back(kp.pt);
  const std::vector<cv::Point2f> undistorted = undistortPoints(points);
  std::vector<cv::KeyPoint> result = distorted;
  for (std::size_t i = 0; i < result.size(); ++i) result[i].pt = undistorted[i];
  return result;
}

ImageBounds PinholeCamera::undistortedBounds() const {
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  if (!hasDistortion()) return {0.0, w, 0.0, h};
  // Corners in the order top-left, top-right, bottom-left, bottom-right.
  const std::vector<cv::Point2f> corners = undistortPoints({{0.f, 0.f}, {w, 0.f}, {0.f, h}, {w, h}});
  ImageBounds b;
  b.minX = std::min(corners[0].x, corners[2].x);
  b.maxX = std::max(corners[1].x, corners[3].x);
  b.minY = std::min(corners[0].y, corners[1].y);
  b.maxY = std::max(corners[2].y, corners[3].y);
  return b;
}

}  // namespace pslam::geometry
