#pragma once
// ORB-SLAM's KeyFrameCulling (thesis §2.4.1, local mapping): a keyframe covisible with the newest one is erased
// when more than `redundantFraction` of its map points are seen by at least `redundantMinObservers` other
// keyframes at the same or a finer scale (one pyramid level coarser allowed). The first two keyframes (the
// initial map, which fixes the gauge) and the newest one are never erased. Step 6 of mapping::LocalMapper.
#include "pslam/core/Params.h"
#include "pslam/map/Map.h"

namespace pslam::map {

struct KeyFrameCullingParams {
  double redundantFraction = 0.9;
  int redundantMinObservers = 3;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, redundantFraction, inLeftOpen(0, 1), "cull when this share of points is redundant (ORB-SLAM 0.9)");
    PSLAM_FIELD(v, redundantMinObservers, atLeast(1), "other keyframes at the same or a finer scale (ORB-SLAM thObs 3)");
  }
};

/// Examines the keyframes covisible with `newest` (ascending id) and erases the redundant ones
/// (Map::eraseKeyFrame, which records their pose relative to the spanning tree). Returns how many were erased.
int cullRedundantKeyFrames(Map& map, KeyFrameId newest, const KeyFrameCullingParams& params);

}  // namespace pslam::map
