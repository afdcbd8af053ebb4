#pragma once
// Matching of line segments (thesis §2.3.2.2: Hamming distance of the binary LBD descriptors, as for ORB):
//   - by projection (tracking): a map line projected at the frame's pose estimate is matched to the frame segment
//     with the smallest descriptor distance among those near it (angle, distance of the segment's endpoints to the
//     projected infinite line, overlap along it), with a ratio test and mutual best;
//   - by descriptor between two keyframes (triangulation of new lines): mutual best with a ratio test.
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "pslam/lines/LineExtractor.h"

namespace pslam::lines {

struct LineMatchParams {
  int maxHamming = 60;          ///< of 256 bits
  double ratio = 0.85;          ///< best < ratio * second best (second among the gated candidates)
  double maxAngleDeg = 10.0;    ///< projected line vs segment direction (undirected)
  double maxDistance = 15.0;    ///< pixels: the segment's endpoints from the projected infinite line
  double minOverlap = 0.2;      ///< common part along the line / the shorter of the two
};

/// One map line projected into the frame: the segment of its projected endpoints and its descriptor (1 x 32).
struct ProjectedLine {
  LineSegment segment;
  cv::Mat descriptor;
};

/// Fraction of the shorter of `a` and `b` that their projections onto a's direction share (0 when disjoint).
double segmentOverlap(const LineSegment& a, const LineSegment& b);

/// For each projected line the index of the matched frame segment, or -1. Every segment is matched at most once
/// (the line with the smallest distance keeps it).
std::vector<int> matchByProjection(const std::vector<ProjectedLine>& lines, const LineFeatures& frame,
                                   const LineMatchParams& params);

/// Mutual best descriptor matches (i in a, j in b) among the rows allowed by `useA` / `useB` (empty = all), with
/// distance <= maxHamming and the ratio test on both sides.
std::vector<std::pair<int, int>> matchByDescriptor(const cv::Mat& a, const cv::Mat& b, const LineMatchParams& params,
                                                   const std::vector<bool>& useA = {},
                                                   const std::vector<bool>& useB = {});

/// Hamming distance of two 1 x 32 CV_8U rows.
int hamming(const cv::Mat& a, const cv::Mat& b);

}  // namespace pslam::lines
