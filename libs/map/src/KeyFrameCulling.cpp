#include "pslam/map/KeyFrameCulling.h"

#include <iterator>

namespace pslam::map {

int cullRedundantKeyFrames(Map& map, KeyFrameId newest, const KeyFrameCullingParams& params) {
  if (map.numKeyFrames() <= 2) return 0;
  auto it = map.keyFrames().begin();
  const KeyFrameId firstId = it->first;
  const KeyFrameId secondId = std::next(it)->first;
  int culled = 0;
  for (KeyFrameId candidate : map.covisibleKeyFrames(newest, 1)) {
    if (candidate == firstId || candidate == secondId || candidate == newest || !map.hasKeyFrame(candidate)) continue;
    const KeyFrame& kf = map.keyFrame(candidate);
    int numPoints = 0, numRedundant = 0;
    for (std::size_t k = 0; k < kf.numKeypoints(); ++k) {
      const MapPointId id = kf.mapPointIds[k];
      if (id == kNoMapPoint) continue;
      const MapPoint& p = map.mapPoint(id);
      if (p.bad) continue;
      ++numPoints;
      if (static_cast<int>(p.numObservations()) <= params.redundantMinObservers) continue;
      const int level = kf.keypoints[k].octave;
      int observers = 0;
      for (const auto& [other, ko] : p.observations) {
        if (other == candidate) continue;
        if (map.keyFrame(other).keypoints[ko].octave <= level + 1 && ++observers >= params.redundantMinObservers) break;
      }
      if (observers >= params.redundantMinObservers) ++numRedundant;
    }
    if (numPoints > 0 && numRedundant > params.redundantFraction * numPoints) {
      map.eraseKeyFrame(candidate);
      ++culled;
    }
  }
  return culled;
}

}  // namespace pslam::map
