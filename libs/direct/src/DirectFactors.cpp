// The direct points' factors (thesis §3.4.2-3.4.3, eq. 3.6): photometric pose factors of a tracked frame and
// photometric BA factors of the local-BA window, and what local BA's result does to the points' models.
#include <algorithm>
#include <cmath>

#include "DirectHelpers.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/optimize/PhotometricPoseFactor.h"

namespace pslam::direct {

using detail::evenSubset;
using detail::medianAndMad;

std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> DirectFrontEnd::photometricFactors(
    const tracking::Frame& frame, const map::Map& map, map::KeyFrameId reference) {
  lastFactors_.clear();
  lastInView_.clear();
  lastActive_ = lastInactive_ = lastReferenceInView_ = lastReferenceActive_ = 0;
  if (hosts_.empty()) return {};
  prepareTrackedFrame(frame);
  const cv::Mat& level0 = framePyramid_->level(0);
  const double margin = optimize::kPatternPadding + 1.0;
  std::vector<PointRef> active;
  for (map::KeyFrameId h : trackingHosts(map, reference)) {
    const DirectHost& host = hosts_.at(h);
    const Eigen::Isometry3d T_cam_host = frame.T_cam_world * map.keyFrame(h).T_world_cam();
    for (std::size_t i = 0; i < host.points.size(); ++i) {
      const DirectMapPoint& p = host.points[i];
      if (p.bad) continue;
      const Eigen::Vector3d pc = T_cam_host * (p.landmark->bearing / p.landmark->inverseDepth);
      if (pc.z() <= 0.0) continue;
      const Eigen::Vector2d uv = intrinsics_.project(pc);
      if (uv.x() < margin || uv.y() < margin || uv.x() > level0.cols - 1 - margin || uv.y() > level0.rows - 1 - margin)
        continue;
      lastInView_.push_back({h, i});
      if (mayUse(p, h)) {
        active.push_back({h, i});
        ++lastActive_;
        if (h == reference) ++lastReferenceInView_;
      } else {
        ++lastInactive_;
      }
    }
  }
  if (auto ref = hosts_.find(reference); ref != hosts_.end())
    for (const DirectMapPoint& p : ref->second.points) lastReferenceActive_ += mayUse(p, reference) ? 1 : 0;
  if (active.empty()) return {};
  const std::vector<std::size_t> chosen = evenSubset(active.size(), static_cast<std::size_t>(params_.maxTrackingPoints));

  if (params_.estimateAffine) {
    // DSO estimates (a, b) jointly with the pose; here they come first, from the radiance of the points' centre
    // pixels at the current estimate against the frame's intensities there: median and MAD match (robust to
    // the misregistered and the dynamic ones), then the pose is optimized with them fixed.
    std::vector<double> radiance, intensity;
    for (std::size_t c : chosen) {
      const PointRef& r = active[c];
      const DirectHost& host = hosts_.at(r.host);
      const DirectMapPoint& p = host.points[r.index];
      if (!p.landmark->usableAt(0)) continue;
      const Eigen::Vector3d pc = frame.T_cam_world * worldPosition(map, p);
      const Eigen::Vector2d uv = intrinsics_.project(pc);
      radiance.push_back(std::exp(-host.affine.a) * (p.landmark->hostIntensities[0][4] - host.affine.b));
      intensity.push_back(optimize::sampleBilinear(level0, uv.x(), uv.y()));
    }
    if (radiance.size() >= 30) {
      const auto [mr, sr] = medianAndMad(radiance);
      const auto [mi, si] = medianAndMad(intensity);
      if (sr > 1e-3 && si > 1e-3) {
        const double a = std::clamp(std::log(si / sr), -1.0, 1.0);
        frameAffine_ = {a, mi - std::exp(a) * mr};
      }
    }
  }

  std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> factors;
  factors.reserve(chosen.size());
  for (std::size_t c : chosen) {
    const PointRef& r = active[c];
    const DirectHost& host = hosts_.at(r.host);
    factors.push_back(std::make_shared<optimize::PhotometricPoseFactor>(
        host.points[r.index].landmark, map.keyFrame(r.host).T_cam_world, host.affine, framePyramid_, frameAffine_,
        intrinsics_, 0, params_.photometric));
    lastFactors_.push_back(r);
  }
  return factors;
}

std::vector<std::shared_ptr<optimize::BAFactor>> DirectFrontEnd::bundleAdjustmentFactors(
    const map::Map& map, const optimize::BAProblem& problem) {
  baPoints_.clear();
  std::vector<std::shared_ptr<optimize::BAFactor>> factors;
  if (!params_.localBundleAdjustment || params_.maxBaPoints == 0) return factors;
  // Candidate points: active, hosted in a free window keyframe (a fixed host would only constrain poses that
  // the keypoints already fix).
  std::vector<PointRef> candidates;
  for (const auto& [kfId, k] : problem.keyframes) {
    if (k.fixed) continue;
    auto h = hosts_.find(kfId);
    if (h == hosts_.end()) continue;
    for (std::size_t i = 0; i < h->second.points.size(); ++i)
      if (mayUse(h->second.points[i], kfId)) candidates.push_back({kfId, i});
  }
  const std::vector<std::size_t> chosen = evenSubset(candidates.size(), static_cast<std::size_t>(params_.maxBaPoints));
  std::map<map::KeyFrameId, std::shared_ptr<optimize::AffineBlock>> affine;
  auto affineOf = [&](map::KeyFrameId id) {
    auto& a = affine[id];
    if (!a) {
      a = std::make_shared<optimize::AffineBlock>();
      a->ab = {hosts_.at(id).affine.a, hosts_.at(id).affine.b};
      a->fixed = true;
    }
    return a;
  };
  const double margin = optimize::kPatternPadding + 1.0;
  for (std::size_t c : chosen) {
    const PointRef& r = candidates[c];
    const DirectMapPoint& p = hosts_.at(r.host).points[r.index];
    const Eigen::Vector3d pw = worldPosition(map, p);
    int targets = 0;
    // Targets: the other window keyframes with an image that see the point, the most recent first.
    for (auto it = problem.keyframes.rbegin(); it != problem.keyframes.rend() && targets < params_.maxBaTargets; ++it) {
      if (it->first == r.host) continue;
      auto th = hosts_.find(it->first);
      if (th == hosts_.end() || th->second.grey.empty()) continue;
      const map::KeyFrame& t = map.keyFrame(it->first);
      const Eigen::Vector3d pc = t.T_cam_world * pw;
      if (pc.z() <= 0.0) continue;
      const Eigen::Vector2d uv = intrinsics_.project(pc);
      if (uv.x() < margin || uv.y() < margin || uv.x() > th->second.grey.cols - 1 - margin ||
          uv.y() > th->second.grey.rows - 1 - margin)
        continue;
      factors.push_back(std::make_shared<optimize::PhotometricBAFactor>(
          p.landmark, it->first, hostPyramid(th->second), intrinsics_, affineOf(r.host), affineOf(it->first), 0,
          params_.photometric));
      baPoints_.push_back(r);
      ++targets;
    }
  }
  return factors;
}

int DirectFrontEnd::applyBundleAdjustment(const std::vector<bool>& factorOutliers) {
  std::map<std::pair<map::KeyFrameId, std::size_t>, bool> touched;  // point -> any outlier
  for (std::size_t k = 0; k < baPoints_.size(); ++k) {
    auto& any = touched[{baPoints_[k].host, baPoints_[k].index}];
    if (k < factorOutliers.size() && factorOutliers[k]) any = true;
  }
  int updated = 0;
  for (const auto& [key, outlier] : touched) {
    auto h = hosts_.find(key.first);
    if (h == hosts_.end() || key.second >= h->second.points.size()) continue;
    DirectMapPoint& p = h->second.points[key.second];
    if (!(p.landmark->inverseDepth > 0.0) || !std::isfinite(p.landmark->inverseDepth)) {
      p.bad = true;
      continue;
    }
    // §3.4.3: the refined depth becomes the filter mean (variance and inlier counts kept); an outlier in BA
    // counts as a miss of the pose-optimization ratio.
    p.state.mu = p.landmark->inverseDepth / p.landmark->bearing.z();
    ++p.visible;
    if (!outlier) ++p.found;
    ++updated;
  }
  baPoints_.clear();
  return updated;
}

}  // namespace pslam::direct
