#pragma once
// Seeded synthetic test images: many random rectangles, circles and triangles of random grey levels give
// corners at every scale and a uniform texture density (so spread and count checks are meaningful).
#include <random>

#include <opencv2/imgproc.hpp>

namespace pslam::features::test {

inline cv::Mat texturedImage(int width, int height, unsigned seed, int shapesPer10kPx = 6) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(0, 255);
  std::uniform_real_distribution<float> ux(0.f, static_cast<float>(width)), uy(0.f, static_cast<float>(height));
  std::uniform_int_distribution<int> extent(4, 40), kind(0, 2);
  cv::Mat img(height, width, CV_8UC1, cv::Scalar(128));
  const int shapes = shapesPer10kPx * width * height / 10000;
  for (int s = 0; s < shapes; ++s) {
    const cv::Point c(static_cast<int>(ux(rng)), static_cast<int>(uy(rng)));
    const int a = extent(rng), b = extent(rng);
    const cv::Scalar colour(grey(rng));
    switch (kind(rng)) {
      case 0: cv::rectangle(img, cv::Rect(c.x, c.y, a, b), colour, cv::FILLED); break;
      case 1: cv::circle(img, c, a / 2, colour, cv::FILLED, cv::LINE_AA); break;
      default: {
        const std::vector<cv::Point> tri{c, {c.x + a, c.y + b / 3}, {c.x + a / 3, c.y + b}};
        cv::fillConvexPoly(img, tri, colour, cv::LINE_AA);
      }
    }
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.7);  // soften aliasing so corners survive resampling
  return img;
}

}  // namespace pslam::features::test
