#include "pslam/features/FeatureGrid.h"

#include <algorithm>
#include <cmath>

#include "pslam/core/Error.h"

namespace pslam::features {

FeatureGrid::FeatureGrid(const std::vector<cv::Point2f>& positions, const std::vector<int>& octaves,
                         const cv::Rect2f& bounds, int cols, int rows)
    : positions_(positions), octaves_(octaves), bounds_(bounds), cols_(cols), rows_(rows) {
  const std::string ctx = "FeatureGrid";
  require(positions.size() == octaves.size(), ctx,
          "positions (" + std::to_string(positions.size()) + ") and octaves (" + std::to_string(octaves.size()) +
              ") differ in size");
  require(cols > 0 && rows > 0, ctx, "grid needs cols > 0 and rows > 0");
  require(std::isfinite(bounds.x) && std::isfinite(bounds.y) && bounds.width > 0 && bounds.height > 0, ctx,
          "bounds must be finite with positive width and height");
  invCellW_ = cols / bounds.width;
  invCellH_ = rows / bounds.height;
  cells_.assign(static_cast<size_t>(cols) * rows, {});
  for (size_t i = 0; i < positions.size(); ++i) {
    const cv::Point2f& p = positions[i];
    require(std::isfinite(p.x) && std::isfinite(p.y), ctx, "point " + std::to_string(i) + " is not finite");
    cells_[static_cast<size_t>(cellY(p.y)) * cols_ + cellX(p.x)].push_back(i);
  }
}

FeatureGrid FeatureGrid::fromKeypoints(const std::vector<cv::KeyPoint>& keypoints, const cv::Rect2f& bounds,
                                       int cols, int rows) {
  std::vector<cv::Point2f> pts(keypoints.size());
  std::vector<int> oct(keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i) {
    pts[i] = keypoints[i].pt;
    oct[i] = keypoints[i].octave;
  }
  return FeatureGrid(pts, oct, bounds, cols, rows);
}

int FeatureGrid::cellX(float x) const {
  const float c = std::floor((x - bounds_.x) * invCellW_);
  return static_cast<int>(std::clamp(c, 0.f, static_cast<float>(cols_ - 1)));
}
int FeatureGrid::cellY(float y) const {
  const float c = std::floor((y - bounds_.y) * invCellH_);
  return static_cast<int>(std::clamp(c, 0.f, static_cast<float>(rows_ - 1)));
}

template <typename Accept>
std::vector<size_t> FeatureGrid::query(float cx, float cy, float reach, OctaveRange octaves, Accept accept) const {
  std::vector<size_t> out;
  if (positions_.empty() || !(reach >= 0) || !std::isfinite(cx) || !std::isfinite(cy)) return out;
  // Clamping keeps out-of-bounds points (stored in border cells) reachable.
  const int x0 = cellX(cx - reach), x1 = cellX(cx + reach);
  const int y0 = cellY(cy - reach), y1 = cellY(cy + reach);
  for (int gy = y0; gy <= y1; ++gy)
    for (int gx = x0; gx <= x1; ++gx)
      for (size_t i : cells_[static_cast<size_t>(gy) * cols_ + gx]) {
        if (!octaves.contains(octaves_[i])) continue;
        if (accept(positions_[i].x - cx, positions_[i].y - cy)) out.push_back(i);
      }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<size_t> FeatureGrid::featuresInWindow(float cx, float cy, float halfSize, OctaveRange octaves) const {
  return query(cx, cy, halfSize, octaves,
               [halfSize](float dx, float dy) { return std::abs(dx) < halfSize && std::abs(dy) < halfSize; });
}

std::vector<size_t> FeatureGrid::featuresInRadius(float cx, float cy, float radius, OctaveRange octaves) const {
  const float r2 = radius * radius;
  return query(cx, cy, radius, octaves, [r2](float dx, float dy) { return dx * dx + dy * dy <= r2; });
}

}  // namespace pslam::features
