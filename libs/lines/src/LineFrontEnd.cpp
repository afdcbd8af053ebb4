#include "pslam/lines/LineFrontEnd.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/tracking/Frame.h"

namespace pslam::lines {

PSLAM_DEFINE_PARAMS(LinesParams)

namespace {
using Clock = std::chrono::steady_clock;

/// Indices 0..n-1 thinned to at most `cap`, evenly (deterministic).
std::vector<std::size_t> evenSubset(std::size_t n, std::size_t cap) {
  std::vector<std::size_t> out;
  const std::size_t m = std::min(n, cap);
  out.reserve(m);
  for (std::size_t k = 0; k < m; ++k) out.push_back(n <= cap ? k : k * n / cap);
  return out;
}
}  // namespace

LineFrontEnd::LineFrontEnd(const LinesParams& params, const geometry::PinholeCamera& camera)
    : params_(params), intrinsics_(camera.withoutDistortion()), extractor_(params.extractor, camera) {
  params_.check();
}

void LineFrontEnd::prepareFrame(const tracking::Frame& frame) {
  if (framePrepared_ && frame.index == frameIndex_ && frame.timestamp == frameTimestamp_) return;
  require(!frame.grey.empty(), "LineFrontEnd", "frame " + std::to_string(frame.index) + " has no grey image");
  const auto t0 = Clock::now();
  frameFeatures_ = extractor_.extract(frame.grey);
  extractionMs_ = msSince(t0);
  frameIndex_ = frame.index;
  frameTimestamp_ = frame.timestamp;
  framePrepared_ = true;
  frameMatches_.assign(frameFeatures_.size(), -1);
  lastFactors_.clear();
  lastVisible_ = 0;
}

bool LineFrontEnd::inFront(const Line3& line, const Eigen::Isometry3d& T) const {
  return (T * line.start).z() > 0.0 && (T * line.end).z() > 0.0;
}

std::vector<std::shared_ptr<const optimize::PoseFactor>> LineFrontEnd::lineFactors(const tracking::Frame& frame) {
  prepareFrame(frame);
  lastFactors_.clear();
  lastVisible_ = 0;
  std::vector<std::shared_ptr<const optimize::PoseFactor>> factors;
  if (lines_.empty() || frameFeatures_.empty()) return factors;
  // Map lines in front of the frame whose projected segment reaches into the image.
  std::vector<ProjectedLine> projected;
  std::vector<std::uint64_t> ids;
  const double w = intrinsics_.width, h = intrinsics_.height;
  for (const auto& [id, l] : lines_) {
    if (l.bad) continue;
    const Line3 world = l.landmark->line();
    const Eigen::Vector3d a = frame.T_cam_world * world.start, b = frame.T_cam_world * world.end;
    if (!(a.z() > 0.0) || !(b.z() > 0.0)) continue;
    const LineSegment seg{intrinsics_.project(a), intrinsics_.project(b)};
    const Eigen::Vector2d m = seg.midpoint();
    const bool inside = [&] {
      for (const Eigen::Vector2d& p : {seg.start, seg.end, m})
        if (p.x() >= 0 && p.y() >= 0 && p.x() < w && p.y() < h) return true;
      return false;
    }();
    if (!inside || seg.length() < 1.0) continue;
    projected.push_back({seg, l.descriptor});
    ids.push_back(id);
  }
  lastVisible_ = static_cast<int>(projected.size());
  const std::vector<int> match = matchByProjection(projected, frameFeatures_, params_.trackingMatch());
  for (std::size_t i = 0; i < match.size(); ++i) {
    if (match[i] < 0) continue;
    const LineSegment& s = frameFeatures_.segments[static_cast<std::size_t>(match[i])];
    factors.push_back(std::make_shared<LinePoseFactor>(lines_.at(ids[i]).landmark->line(), s.start, s.end,
                                                       intrinsics_, frameFeatures_.pixelSigma));
    lastFactors_.emplace_back(ids[i], match[i]);
  }
  return factors;
}

LineFrameCounts LineFrontEnd::afterTracking(const tracking::Frame& frame, const std::vector<bool>& factorOutliers) {
  LineFrameCounts counts;
  if (!framePrepared_ || frame.index != frameIndex_) return counts;
  counts.detected = static_cast<int>(frameFeatures_.size());
  counts.visible = lastVisible_;
  frameMatches_.assign(frameFeatures_.size(), -1);
  if (factorOutliers.size() != lastFactors_.size()) return counts;
  counts.factors = static_cast<int>(lastFactors_.size());
  for (std::size_t k = 0; k < lastFactors_.size(); ++k) {
    auto it = lines_.find(lastFactors_[k].first);
    if (it == lines_.end()) continue;
    MapLine& l = it->second;
    ++l.visible;
    if (!factorOutliers[k]) {
      ++l.found;
      ++counts.inliers;
      frameMatches_[static_cast<std::size_t>(lastFactors_[k].second)] = static_cast<long long>(lastFactors_[k].first);
    }
    // Lines the pose optimizations keep rejecting (ORB-SLAM's found ratio).
    if (l.visible >= static_cast<std::uint32_t>(params_.cullMinVisible) &&
        static_cast<double>(l.found) < params_.cullMinFoundRatio * static_cast<double>(l.visible))
      l.bad = true;
  }
  return counts;
}

void LineFrontEnd::addObservation(std::uint64_t id, map::KeyFrameId kf, int segment) {
  MapLine& l = lines_.at(id);
  LineKeyFrame& k = keyframes_.at(kf);
  if (l.observations.count(kf)) return;
  l.observations[kf] = segment;
  k.lineIds[static_cast<std::size_t>(segment)] = static_cast<long long>(id);
  // The latest appearance matches the next frames best.
  l.descriptor = k.features.descriptors.row(segment).clone();
}

void LineFrontEnd::eraseObservation(std::uint64_t id, map::KeyFrameId kf) {
  auto it = lines_.find(id);
  if (it == lines_.end()) return;
  auto o = it->second.observations.find(kf);
  if (o == it->second.observations.end()) return;
  auto k = keyframes_.find(kf);
  if (k != keyframes_.end() && o->second >= 0 && o->second < static_cast<int>(k->second.lineIds.size()))
    k->second.lineIds[static_cast<std::size_t>(o->second)] = -1;
  it->second.observations.erase(o);
  if (it->second.observations.size() < 2) it->second.bad = true;
}

void LineFrontEnd::addKeyFrame(map::KeyFrameId kf, const cv::Mat& grey, bool fromLastFrame) {
  ++keyframesAdded_;
  // A keyframe id that comes back (after a reset) starts over.
  for (auto& [id, l] : lines_) l.observations.erase(kf);
  LineKeyFrame& k = keyframes_[kf];
  if (fromLastFrame && framePrepared_) {
    k.features = frameFeatures_;
  } else {
    require(!grey.empty(), "LineFrontEnd", "keyframe " + std::to_string(kf) + " has no grey image");
    k.features = extractor_.extract(grey);
  }
  k.lineIds.assign(k.features.size(), -1);
  if (!fromLastFrame || !framePrepared_) return;
  for (std::size_t j = 0; j < frameMatches_.size() && j < k.features.size(); ++j) {
    const long long id = frameMatches_[j];
    if (id < 0) continue;
    auto it = lines_.find(static_cast<std::uint64_t>(id));
    if (it == lines_.end() || it->second.bad) continue;
    addObservation(static_cast<std::uint64_t>(id), kf, static_cast<int>(j));
  }
}

std::uint64_t LineFrontEnd::addLine(const Line3& line, const cv::Mat& descriptor,
                                    const std::map<map::KeyFrameId, int>& observations) {
  const std::uint64_t id = nextId_++;
  MapLine& l = lines_[id];
  l.landmark = std::make_shared<LineLandmark>();
  l.landmark->set(line);
  l.descriptor = descriptor.clone();
  l.createdAt = keyframesAdded_;
  for (const auto& [kf, seg] : observations) {
    l.observations[kf] = seg;
    auto k = keyframes_.find(kf);
    if (k != keyframes_.end() && seg >= 0 && seg < static_cast<int>(k->second.lineIds.size()))
      k->second.lineIds[static_cast<std::size_t>(seg)] = static_cast<long long>(id);
  }
  return id;
}

LineCreationReport LineFrontEnd::createLines(const map::Map& map, map::KeyFrameId kfId) {
  const auto t0 = Clock::now();
  LineCreationReport report;
  auto kit = keyframes_.find(kfId);
  if (kit == keyframes_.end() || !map.hasKeyFrame(kfId)) return report;
  const map::KeyFrame& kf = map.keyFrame(kfId);
  // Partners: the best covisible keyframes, then the most recent ones, up to triangulationNeighbours.
  std::vector<map::KeyFrameId> partners;
  auto consider = [&](map::KeyFrameId n) {
    if (n == kfId || !keyframes_.count(n) || !map.hasKeyFrame(n)) return;
    if (std::find(partners.begin(), partners.end(), n) != partners.end()) return;
    if (static_cast<int>(partners.size()) < params_.triangulationNeighbours) partners.push_back(n);
  };
  for (map::KeyFrameId n : map.bestCovisibleKeyFrames(kfId, static_cast<std::size_t>(params_.triangulationNeighbours)))
    consider(n);
  for (auto it = keyframes_.rbegin(); it != keyframes_.rend(); ++it) consider(it->first);

  const LineMatchParams mp = params_.trackingMatch();
  LineTriangulationParams tp;
  tp.minPlaneAngleDeg = params_.minPlaneAngleDeg;
  tp.maxDepthRatio = params_.maxDepthRatio;
  for (map::KeyFrameId n : partners) {
    LineKeyFrame& mine = keyframes_.at(kfId);
    LineKeyFrame& other = keyframes_.at(n);
    const map::KeyFrame& nkf = map.keyFrame(n);
    std::vector<bool> useMine(mine.features.size());
    for (std::size_t i = 0; i < useMine.size(); ++i) useMine[i] = mine.lineIds[i] < 0;
    const auto matches = matchByDescriptor(mine.features.descriptors, other.features.descriptors, mp, useMine);
    for (const auto& [i, j] : matches) {
      ++report.candidates;
      const LineSegment& s1 = mine.features.segments[static_cast<std::size_t>(i)];
      const LineSegment& s2 = other.features.segments[static_cast<std::size_t>(j)];
      const long long seen = other.lineIds[static_cast<std::size_t>(j)];
      if (seen >= 0) {
        // The partner's segment observes a line already: this keyframe observes it too when it reprojects.
        auto it = lines_.find(static_cast<std::uint64_t>(seen));
        if (it == lines_.end() || it->second.bad || it->second.observations.count(kfId)) continue;
        const LinePoseFactor f(it->second.landmark->line(), s1.start, s1.end, intrinsics_, mine.features.pixelSigma);
        Eigen::VectorXd r;
        if (!f.evaluate(kf.T_cam_world, r, nullptr) || !(r.squaredNorm() <= kLineChi2)) continue;
        const Line3 world = it->second.landmark->line();
        const LineSegment proj{intrinsics_.project(kf.T_cam_world * world.start),
                               intrinsics_.project(kf.T_cam_world * world.end)};
        if (segmentOverlap(proj, s1) < params_.minOverlap) continue;
        addObservation(static_cast<std::uint64_t>(seen), kfId, i);
        ++report.fused;
        continue;
      }
      const LineTriangulation t =
          triangulateLine(intrinsics_, kf.T_cam_world, s1.start, s1.end, nkf.T_cam_world, s2.start, s2.end, tp);
      if (!t.valid) continue;
      // The endpoints come from this keyframe's segment; in the partner the line must cover the segment it was
      // matched with.
      const LineSegment proj{intrinsics_.project(nkf.T_cam_world * t.line.start),
                             intrinsics_.project(nkf.T_cam_world * t.line.end)};
      if (segmentOverlap(proj, s2) < params_.minOverlap) continue;
      addLine(t.line, mine.features.descriptors.row(i), {{kfId, i}, {n, j}});
      ++report.created;
    }
  }

  // Culling: lines no keyframe observed again within their probation.
  for (auto& [id, l] : lines_) {
    if (l.bad) continue;
    if (keyframesAdded_ >= l.createdAt + static_cast<std::uint64_t>(params_.probationKeyFrames) &&
        static_cast<int>(l.observations.size()) < params_.minObservations) {
      l.bad = true;
      ++report.culled;
    }
  }
  report.ms = msSince(t0);
  return report;
}

std::vector<std::shared_ptr<optimize::BAFactor>> LineFrontEnd::bundleAdjustmentFactors(
    const map::Map& map, const optimize::BAProblem& problem) {
  baFactors_.clear();
  std::vector<std::shared_ptr<optimize::BAFactor>> factors;
  if (!params_.localBundleAdjustment || params_.maxBaLines == 0) return factors;
  // Candidates: lines seen by at least two window keyframes, one of them free, in front of every one of them.
  std::vector<std::uint64_t> candidates;
  for (const auto& [id, l] : lines_) {
    if (l.bad) continue;
    int inWindow = 0;
    bool anyFree = false, front = true;
    for (const auto& [kf, seg] : l.observations) {
      auto w = problem.keyframes.find(kf);
      if (w == problem.keyframes.end() || !keyframes_.count(kf)) continue;
      ++inWindow;
      anyFree = anyFree || !w->second.fixed;
      front = front && inFront(l.landmark->line(), w->second.T_cam_world);
    }
    if (inWindow >= 2 && anyFree && front) candidates.push_back(id);
  }
  for (std::size_t c : evenSubset(candidates.size(), static_cast<std::size_t>(params_.maxBaLines))) {
    const std::uint64_t id = candidates[c];
    const MapLine& l = lines_.at(id);
    for (const auto& [kf, seg] : l.observations) {
      if (!problem.keyframes.count(kf)) continue;
      auto k = keyframes_.find(kf);
      if (k == keyframes_.end()) continue;
      const LineSegment& s = k->second.features.segments.at(static_cast<std::size_t>(seg));
      factors.push_back(std::make_shared<LineBAFactor>(l.landmark, kf, s.start, s.end, intrinsics_,
                                                       k->second.features.pixelSigma));
      baFactors_.emplace_back(id, kf);
    }
  }
  (void)map;
  return factors;
}

int LineFrontEnd::applyBundleAdjustment(const std::vector<bool>& factorOutliers) {
  std::map<std::uint64_t, bool> touched;
  for (std::size_t k = 0; k < baFactors_.size(); ++k) {
    const auto& [id, kf] = baFactors_[k];
    touched[id];
    if (k < factorOutliers.size() && factorOutliers[k]) eraseObservation(id, kf);
  }
  int refined = 0;
  for (const auto& [id, any] : touched) {
    auto it = lines_.find(id);
    if (it == lines_.end()) continue;
    bool finite = true;
    for (double v : it->second.landmark->endpoints) finite = finite && std::isfinite(v);
    if (!finite) it->second.bad = true;
    if (!it->second.bad) ++refined;
  }
  baFactors_.clear();
  return refined;
}

void LineFrontEnd::prune(const map::Map& map) {
  for (auto it = keyframes_.begin(); it != keyframes_.end();) {
    if (map.hasKeyFrame(it->first)) {
      ++it;
      continue;
    }
    const map::KeyFrameId gone = it->first;
    for (auto& [id, l] : lines_) {
      if (l.observations.erase(gone) && l.observations.size() < 2) l.bad = true;
    }
    it = keyframes_.erase(it);
  }
  for (auto it = lines_.begin(); it != lines_.end();) {
    if (!it->second.bad) {
      ++it;
      continue;
    }
    for (const auto& [kf, seg] : it->second.observations) {
      auto k = keyframes_.find(kf);
      if (k != keyframes_.end() && seg >= 0 && seg < static_cast<int>(k->second.lineIds.size()) &&
          k->second.lineIds[static_cast<std::size_t>(seg)] == static_cast<long long>(it->first))
        k->second.lineIds[static_cast<std::size_t>(seg)] = -1;
    }
    it = lines_.erase(it);
  }
  lastFactors_.clear();  // ids of erased lines must not come back through afterTracking
}

void LineFrontEnd::reset() {
  lines_.clear();
  keyframes_.clear();
  lastFactors_.clear();
  baFactors_.clear();
  frameMatches_.assign(frameFeatures_.size(), -1);
  lastVisible_ = 0;
  keyframesAdded_ = 0;
}

std::size_t LineFrontEnd::numLines() const {
  std::size_t n = 0;
  for (const auto& [id, l] : lines_) n += l.bad ? 0 : 1;
  return n;
}

std::map<std::string, std::size_t> LineFrontEnd::counts() const {
  return {{"lines", numLines()}, {"line_keyframes", keyframes_.size()}};
}

// ---------------------------------------------------------------- the module's stages (tracking::LandmarkModule)

nlohmann::json LineFrameCounts::toJson() const {
  return {{"lines_detected", detected}, {"lines_visible", visible}, {"lines_factors", factors},
          {"lines_inliers", inliers}};
}

void LineFrontEnd::prepareFrame(const tracking::Frame& frame, StageTimings& timings) {
  ScopedStage st(timings, "line_extraction");
  prepareFrame(frame);
}

tracking::ModulePoseFactors LineFrontEnd::poseFactors(const tracking::Frame& frame, const map::Map& /*map*/,
                                                      map::KeyFrameId /*reference*/) {
  tracking::ModulePoseFactors factors;
  factors.factors = lineFactors(frame);
  return factors;
}

tracking::ModuleFrameReport LineFrontEnd::afterTracking(const tracking::Frame& frame, const map::Map& /*map*/,
                                                        const std::vector<bool>& factorOutliers, bool learn) {
  LineFrameCounts counts;
  if (learn) {
    counts = afterTracking(frame, factorOutliers);
  } else {
    // Localization: the line store stays as it was loaded (no counters, no culling); the report still says what
    // the pose used.
    counts.factors = static_cast<int>(factorOutliers.size());
    for (bool o : factorOutliers) counts.inliers += o ? 0 : 1;
  }
  tracking::ModuleFrameReport report;
  report.counts = counts.toJson();
  return report;
}

void LineFrontEnd::addKeyFrame(const tracking::KeyFrameImages& keyFrame) {
  addKeyFrame(keyFrame.id, keyFrame.grey, keyFrame.fromLastFrame);
}

void LineFrontEnd::afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings& timings,
                                     nlohmann::json& log) {
  const LineCreationReport l = createLines(map, kf);
  prune(map);
  timings.add("line_creation", l.ms);
  log["lines_created"] = l.created;
  log["lines_fused"] = l.fused;
  log["lines_culled"] = l.culled;
  log["lines"] = numLines();
}

std::optional<std::string> LineFrontEnd::mapExtension() const {
  if (keyframes_.empty()) return std::nullopt;
  return serialize();
}

std::function<void()> LineFrontEnd::prepareLoad(const std::string& bytes, const map::Map& loaded) {
  auto store = std::make_shared<Store>(parse(bytes, loaded));
  return [this, store] { restore(std::move(*store)); };
}

}  // namespace pslam::lines
