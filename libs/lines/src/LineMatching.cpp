#include "pslam/lines/LineMatching.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "pslam/lines/LineGeometry.h"

namespace pslam::lines {

int hamming(const cv::Mat& a, const cv::Mat& b) { return static_cast<int>(cv::norm(a, b, cv::NORM_HAMMING)); }

double segmentOverlap(const LineSegment& a, const LineSegment& b) {
  const double la = a.length(), lb = b.length();
  if (!(la > 0.0) || !(lb > 0.0)) return 0.0;
  const Eigen::Vector2d d = a.direction();
  const double t0 = (b.start - a.start).dot(d), t1 = (b.end - a.start).dot(d);
  const double common = std::min(std::max(t0, t1), la) - std::max(std::min(t0, t1), 0.0);
  return std::max(0.0, common) / std::min(la, lb);
}

std::vector<int> matchByProjection(const std::vector<ProjectedLine>& lines, const LineFeatures& frame,
                                   const LineMatchParams& params) {
  std::vector<int> match(lines.size(), -1);
  std::vector<int> bestDist(lines.size(), std::numeric_limits<int>::max());
  const double cosMax = std::cos(params.maxAngleDeg * M_PI / 180.0);
  std::vector<int> owner(frame.size(), -1);  // segment -> line holding it
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const LineSegment& p = lines[i].segment;
    if (!(p.length() > 1.0)) continue;
    const Eigen::Vector3d l = imageLine(p.start, p.end);
    const Eigen::Vector2d d = p.direction();
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), bestJ = -1;
    for (std::size_t j = 0; j < frame.size(); ++j) {
      const LineSegment& s = frame.segments[j];
      if (std::abs(d.dot(s.direction())) < cosMax) continue;
      if (std::max(std::abs(lineDistance(l, s.start)), std::abs(lineDistance(l, s.end))) > params.maxDistance) continue;
      if (segmentOverlap(p, s) < params.minOverlap) continue;
      const int dist = hamming(lines[i].descriptor, frame.descriptors.row(static_cast<int>(j)));
      if (dist < best) {
        second = best;
        best = dist;
        bestJ = static_cast<int>(j);
      } else if (dist < second) {
        second = dist;
      }
    }
    if (bestJ < 0 || best > params.maxHamming) continue;
    if (second != std::numeric_limits<int>::max() && !(best < params.ratio * second)) continue;
    const int prev = owner[static_cast<std::size_t>(bestJ)];
    if (prev >= 0) {
      if (bestDist[static_cast<std::size_t>(prev)] <= best) continue;
      match[static_cast<std::size_t>(prev)] = -1;
    }
    owner[static_cast<std::size_t>(bestJ)] = static_cast<int>(i);
    match[i] = bestJ;
    bestDist[i] = best;
  }
  return match;
}

std::vector<std::pair<int, int>> matchByDescriptor(const cv::Mat& a, const cv::Mat& b, const LineMatchParams& params,
                                                   const std::vector<bool>& useA, const std::vector<bool>& useB) {
  std::vector<std::pair<int, int>> out;
  if (a.empty() || b.empty()) return out;
  const int na = a.rows, nb = b.rows;
  std::vector<int> dist(static_cast<std::size_t>(na) * nb, std::numeric_limits<int>::max());
  auto okA = [&](int i) { return useA.empty() || useA[static_cast<std::size_t>(i)]; };
  auto okB = [&](int j) { return useB.empty() || useB[static_cast<std::size_t>(j)]; };
  for (int i = 0; i < na; ++i)
    if (okA(i))
      for (int j = 0; j < nb; ++j)
        if (okB(j)) dist[static_cast<std::size_t>(i) * nb + j] = hamming(a.row(i), b.row(j));
  auto bestOf = [&](int n, auto at) {
    int best = std::numeric_limits<int>::max(), second = best, arg = -1;
    for (int k = 0; k < n; ++k) {
      const int d = at(k);
      if (d < best) {
        second = best;
        best = d;
        arg = k;
      } else if (d < second) {
        second = d;
      }
    }
    const bool ok = arg >= 0 && best <= params.maxHamming &&
                    (second == std::numeric_limits<int>::max() || best < params.ratio * second);
    return ok ? arg : -1;
  };
  for (int i = 0; i < na; ++i) {
    if (!okA(i)) continue;
    const int j = bestOf(nb, [&](int k) { return dist[static_cast<std::size_t>(i) * nb + k]; });
    if (j < 0) continue;
    const int back = bestOf(na, [&](int k) { return dist[static_cast<std::size_t>(k) * nb + j]; });
    if (back == i) out.emplace_back(i, j);
  }
  return out;
}

}  // namespace pslam::lines
