#include "pslam/tracking/ProjectionSearch.h"

#include <algorithm>
#include <cmath>

namespace pslam::tracking {

int predictLevel(double distance, double maxDistance, double scaleFactor, int numLevels) {
  if (!(distance > 0) || !(maxDistance > 0)) return 0;
  const double ratio = maxDistance / distance;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(scaleFactor)));
  return std::clamp(level, 0, numLevels - 1);
}

float radiusByViewingCos(double viewCos) { return viewCos > 0.998 ? 2.5f : 4.0f; }

int searchByProjection(Frame& frame, const Eigen::Isometry3d& T_cam_world,
                       const std::vector<ProjectionCandidate>& candidates, const ProjectionSearchParams& params) {
  struct Match {
    std::size_t keypoint;
    map::MapPointId point;
    int distance;
    float angleDiff;  // < -1000: not in the histogram
  };
  // A keypoint may be claimed by several candidates: keep the one with the lowest distance (first on ties).
  std::vector<int> bestDistanceOfKeypoint(frame.size(), 257);
  std::vector<int> matchOfKeypoint(frame.size(), -1);
  std::vector<Match> matches;
  matches.reserve(candidates.size());

  for (const ProjectionCandidate& c : candidates) {
    const Eigen::Vector3d p_cam = T_cam_world * c.p_world;
    if (p_cam.z() <= 0) continue;
    const Eigen::Vector2d uv = frame.camera.project(p_cam);
    if (!frame.bounds.contains(uv.x(), uv.y())) continue;
    std::vector<size_t> window = frame.grid.featuresInWindow(static_cast<float>(uv.x()), static_cast<float>(uv.y()),
                                                             c.radius, features::OctaveRange{c.minLevel, c.maxLevel});
    // Only keypoints that are still free (matched before this search) are candidates.
    window.erase(std::remove_if(window.begin(), window.end(),
                                [&](size_t k) {
                                  return frame.mapPointIds[k] != map::kNoMapPoint && matchOfKeypoint[k] < 0;
                                }),
                 window.end());
    if (window.empty()) continue;
    const features::BestCandidate best = features::bestCandidate(c.descriptor.ptr<uint8_t>(0), frame.descriptors, window);
    if (best.index < 0 || best.distance > params.maxDistance) continue;
    if (params.ratio < 1.0f) {
      // Second-best level: ORB-SLAM only rejects ambiguity among keypoints of the same level.
      bool applyRatio = true;
      if (params.ratioOnlySameLevel) {
        int secondLevel = -1, secondDist = 257;
        for (size_t k : window) {
          if (static_cast<int>(k) == best.index) continue;
          const int d = features::hammingDistance(c.descriptor, 0, frame.descriptors, static_cast<int>(k));
          if (d < secondDist) {
            secondDist = d;
            secondLevel = frame.keypoints[k].octave;
          }
        }
        applyRatio = secondLevel == frame.keypoints[best.index].octave;
      }
      if (applyRatio && !(best.distance < params.ratio * best.secondDistance)) continue;
    }
    const std::size_t k = static_cast<std::size_t>(best.index);
    if (best.distance >= bestDistanceOfKeypoint[k]) continue;
    float angleDiff = -2000.f;
    if (params.checkOrientation && c.referenceAngle >= 0) {
      angleDiff = c.referenceAngle - frame.keypoints[k].angle;
      if (angleDiff < 0) angleDiff += 360.f;
    }
    if (matchOfKeypoint[k] >= 0) {
      matches[matchOfKeypoint[k]] = {k, c.id, best.distance, angleDiff};
    } else {
      matchOfKeypoint[k] = static_cast<int>(matches.size());
      matches.push_back({k, c.id, best.distance, angleDiff});
    }
    bestDistanceOfKeypoint[k] = best.distance;
  }

  std::vector<bool> keep(matches.size(), true);
  if (params.checkOrientation) {
    std::vector<std::vector<int>> histogram(params.histogramBins);
    for (std::size_t m = 0; m < matches.size(); ++m) {
      if (matches[m].angleDiff < -1000.f) continue;
      int bin = static_cast<int>(std::lround(matches[m].angleDiff * params.histogramBins / 360.f));
      if (bin == params.histogramBins) bin = 0;
      histogram[bin].push_back(static_cast<int>(m));
    }
    int b1, b2, b3;
    features::threeLargestBins(histogram, b1, b2, b3);
    for (int b = 0; b < params.histogramBins; ++b) {
      if (b == b1 || b == b2 || b == b3) continue;
      for (int m : histogram[b]) keep[m] = false;
    }
  }
  int added = 0;
  for (std::size_t m = 0; m < matches.size(); ++m) {
    if (!keep[m]) continue;
    frame.mapPointIds[matches[m].keypoint] = matches[m].point;
    frame.outlier[matches[m].keypoint] = false;
    ++added;
  }
  return added;
}

}  // namespace pslam::tracking
