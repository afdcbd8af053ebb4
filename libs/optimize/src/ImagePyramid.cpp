#include "pslam/optimize/ImagePyramid.h"

#include <string>


#include "pslam/core/Error.h"

namespace pslam::optimize {

ImagePyramid::ImagePyramid(const cv::Mat& grey, int levels) {
  const std::string ctx = "ImagePyramid";
  require(!grey.empty(), ctx, "empty image");
  require(grey.channels() == 1 && (grey.depth() == CV_8U || grey.depth() == CV_32F), ctx,
          "image must be CV_8UC1 or CV_32FC1");
  require(levels >= 1, ctx, "levels must be >= 1");
  cv::Mat level0;
  if (grey.depth() == CV_8U)
    grey.convertTo(level0, CV_32F, 1.0 / 255.0);
  else
    level0 = grey.clone();
  levels_.push_back(level0);
  for (int l = 1; l < levels; ++l) {
    const cv::Mat& prev = levels_.back();
    const int w = prev.cols / 2, h = prev.rows / 2;
    require(w >= 8 && h >= 8, ctx,
            "level " + std::to_string(l) + " would be smaller than 8x8 pixels (" + std::to_string(w) + "x" +
                std::to_string(h) + ")");
    cv::Mat next(h, w, CV_32F);
    for (int y = 0; y < h; ++y) {
      const float* a = prev.ptr<float>(2 * y);
      const float* b = prev.ptr<float>(2 * y + 1);
      float* o = next.ptr<float>(y);
      for (int x = 0; x < w; ++x) o[x] = 0.25f * (a[2 * x] + a[2 * x + 1] + b[2 * x] + b[2 * x + 1]);
    }
    levels_.push_back(next);
  }
}

const cv::Mat& ImagePyramid::level(int l) const {
  require(l >= 0 && l < levels(), "ImagePyramid",
          "level " + std::to_string(l) + " out of range (pyramid has " + std::to_string(levels()) + ")");
  return levels_[static_cast<std::size_t>(l)];
}

geometry::PinholeCamera levelCamera(const geometry::PinholeCamera& camera, int level) {
  const double s = std::ldexp(1.0, -level);
  geometry::PinholeCamera c = camera;
  c.fx = camera.fx * s;
  c.fy = camera.fy * s;
  c.cx = (camera.cx + 0.5) * s - 0.5;
  c.cy = (camera.cy + 0.5) * s - 0.5;
  c.width = camera.width >> level;
  c.height = camera.height >> level;
  return c;
}

Eigen::Vector2d levelPixel(const Eigen::Vector2d& pixel0, int level) {
  const double s = std::ldexp(1.0, -level);
  return (pixel0.array() + 0.5) * s - 0.5;
}

}  // namespace pslam::optimize
