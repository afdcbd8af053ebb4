#pragma once
// A synthetic keyframe sequence through local mapping, shared by the local-mapping tests (header only).
#include <random>
#include <string>
#include <vector>

#include "SyntheticScene.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping::testing {

/// ORB-SLAM's parameters with a one-thread BA (the same bytes on any machine).
inline LocalMappingParams heuristicParams() {
  LocalMappingParams p;
  p.ba.numThreads = 1;
  return p;
}

/// Tracker + local mapping over `numSlots` keyframes; the first two come with an initial map of 60 points.
/// `outsideMapLock`: the threaded mode's runner (LocalMapper::setOutsideMapLock), none = sequential.
inline map::Map runSequence(const LocalMappingParams& params, int numSlots, std::vector<LocalMappingReport>* reports,
                     Scene* sceneOut = nullptr, LocalMapper::OutsideMapLock outsideMapLock = nullptr) {
  std::mt19937 rng(31);
  Scene s = makeScene(300, 17);
  map::Map map;
  addKeyFrame(map, s, 0, rng);
  addKeyFrame(map, s, 1, rng);
  const auto initial = addTruePoints(map, s, 0, 60, 0, {0, 1});
  LocalMapper mapper(map, params);
  if (outsideMapLock) mapper.setOutsideMapLock(outsideMapLock);
  reports->push_back(mapper.processKeyFrame(s.keyframes[0], {}));
  map.checkInvariants("slot 0");
  reports->push_back(mapper.processKeyFrame(s.keyframes[1], initial));
  learnMapPoints(map, s);
  map.checkInvariants("slot 1");
  for (int slot = 2; slot < numSlots; ++slot) {
    addKeyFrame(map, s, slot, rng);
    trackKeyFrame(map, s, slot);
    reports->push_back(mapper.processKeyFrame(s.keyframes[slot], {}));
    map.checkInvariants("slot " + std::to_string(slot));
    learnMapPoints(map, s);
  }
  if (sceneOut) *sceneOut = s;
  return map;
}

}  // namespace pslam::mapping::testing
