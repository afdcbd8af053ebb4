#pragma once
// Pixel coordinates between an image and a resampled copy of it. cv::resize (and cv::pyrDown) map pixel centres
// onto pixel centres, with the centre of pixel i at coordinate i: a point at x in a copy whose pixels are `scale`
// times as large as the original's (original size / copy size) is at (x + 0.5) * scale - 0.5 in the original.
// (x * scale, ORB-SLAM's mapping of its pyramid levels, is off by 0.5 (scale - 1) px.)

namespace pslam {

inline double toOriginalPixel(double x, double scale) { return (x + 0.5) * scale - 0.5; }
inline float toOriginalPixel(float x, float scale) { return (x + 0.5f) * scale - 0.5f; }

}  // namespace pslam
