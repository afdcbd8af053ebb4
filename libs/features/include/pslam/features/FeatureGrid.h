#pragma once
// Fixed grid index over keypoint positions (ORB-SLAM's Frame grid, 64 x 48 cells over the undistorted image
// bounds): window and radius queries filtered by octave, used by projection search and by the two-view
// initialization matcher (ORB-SLAM's GetFeaturesInArea).
#include <cstddef>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

namespace pslam::features {

/// Inclusive octave (pyramid level) range; the default accepts every level.
struct OctaveRange {
  int min = 0;
  int max = std::numeric_limits<int>::max();
  bool contains(int octave) const { return octave >= min && octave <= max; }
  static OctaveRange only(int octave) { return {octave, octave}; }
};

class FeatureGrid {
 public:
  FeatureGrid() = default;
  /// Indexes `positions` (normally the undistorted keypoints, in pixels) with their `octaves`, over the image
  /// bounds `bounds` split into cols x rows cells. Points outside the bounds are kept in the border cells, so
  /// queries stay exact. Throws pslam::Error on size mismatch, non-finite positions or an empty/invalid grid.
  FeatureGrid(const std::vector<cv::Point2f>& positions, const std::vector<int>& octaves, const cv::Rect2f& bounds,
              int cols = 64, int rows = 48);
  /// Convenience: positions and octaves taken from keypoints.
  static FeatureGrid fromKeypoints(const std::vector<cv::KeyPoint>& keypoints, const cv::Rect2f& bounds,
                                   int cols = 64, int rows = 48);

  /// Indices (ascending) of the points with |x - cx| < halfSize and |y - cy| < halfSize and octave in range:
  /// ORB-SLAM's square window search.
  std::vector<size_t> featuresInWindow(float cx, float cy, float halfSize, OctaveRange octaves = {}) const;
  /// Indices (ascending) of the points with Euclidean distance <= radius and octave in range.
  std::vector<size_t> featuresInRadius(float cx, float cy, float radius, OctaveRange octaves = {}) const;

  size_t size() const { return positions_.size(); }

 private:
  int cellX(float x) const;
  int cellY(float y) const;
  template <typename Accept>
  std::vector<size_t> query(float cx, float cy, float reach, OctaveRange octaves, Accept accept) const;

  std::vector<cv::Point2f> positions_;
  std::vector<int> octaves_;
  cv::Rect2f bounds_;
  int cols_ = 0, rows_ = 0;
  float invCellW_ = 0, invCellH_ = 0;
  std::vector<std::vector<size_t>> cells_;  ///< row-major, cell (cx, cy) at cy * cols_ + cx
};

}  // namespace pslam::features
