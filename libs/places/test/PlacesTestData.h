#pragma once
// Synthetic "images" of ORB descriptors for the place-recognition tests: every image draws its descriptors from
// its own prototypes (its place), with a few bits flipped per draw, so descriptors of one place cluster together
// and different places share little.
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

namespace pslam::places::test {

inline cv::Mat randomDescriptors(int rows, std::mt19937& rng) {
  cv::Mat d(rows, 32, CV_8U);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < 32; ++c) d.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(rng() & 0xFF);
  return d;
}

/// A copy of `d` with `bits` random bits flipped per row.
inline cv::Mat withNoise(const cv::Mat& d, int bits, std::mt19937& rng) {
  cv::Mat out = d.clone();
  for (int r = 0; r < out.rows; ++r)
    for (int b = 0; b < bits; ++b) {
      const unsigned bit = rng() % 256u;
      out.at<std::uint8_t>(r, static_cast<int>(bit / 8)) ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  return out;
}

/// `places` places of `perPlace` prototype descriptors; `views` noisy views of each (image = view of one place).
struct PlaceSet {
  std::vector<cv::Mat> prototypes;  ///< per place
  std::vector<cv::Mat> images;      ///< views, place-major: image v of place p is images[p * views + v]
  int views = 0;
};

inline PlaceSet makePlaces(int places, int perPlace, int views, int noiseBits, std::uint32_t seed) {
  std::mt19937 rng(seed);
  PlaceSet s;
  s.views = views;
  for (int p = 0; p < places; ++p) {
    s.prototypes.push_back(randomDescriptors(perPlace, rng));
    for (int v = 0; v < views; ++v) s.images.push_back(withNoise(s.prototypes.back(), noiseBits, rng));
  }
  return s;
}

}  // namespace pslam::places::test
