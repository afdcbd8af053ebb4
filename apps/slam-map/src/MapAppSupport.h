#pragma once
// Small helpers shared by the slam-map subcommands' sources (not installed).
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pslam/map/Map.h"

namespace pslam::apps::detail {

inline std::string fmt(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

inline nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// Good (not bad) points, in id order.
template <class F>
void forGoodPoints(const map::Map& map, F&& f) {
  for (const auto& [id, p] : map.mapPoints())
    if (!p.bad) f(id, p);
}

/// Keyframes in timestamp order: the order of the keyframe trajectory.
inline std::vector<const map::KeyFrame*> keyFramesByTime(const map::Map& map) {
  std::vector<const map::KeyFrame*> kfs;
  for (const auto& [id, kf] : map.keyFrames()) kfs.push_back(&kf);
  std::stable_sort(kfs.begin(), kfs.end(),
                   [](const map::KeyFrame* a, const map::KeyFrame* b) { return a->timestamp < b->timestamp; });
  return kfs;
}

}  // namespace pslam::apps::detail

namespace pslam::apps {
using detail::fmt;
using detail::forGoodPoints;
using detail::keyFramesByTime;
using detail::vec;
}  // namespace pslam::apps
