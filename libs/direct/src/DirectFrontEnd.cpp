#include "pslam/direct/DirectFrontEnd.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/PixelCentres.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/landmarks/MatchingAccuracy.h"
#include "pslam/landmarks/MeasurementVariance.h"
#include "pslam/mapping/MapPointModelPolicy.h"
#include "pslam/optimize/PhotometricPoseFactor.h"

namespace pslam::direct {

PSLAM_DEFINE_PARAMS(DirectFeaturesParams)

namespace {

using Clock = std::chrono::steady_clock;

/// Indices 0..n-1 thinned to at most `cap`, evenly (deterministic).
std::vector<std::size_t> evenSubset(std::size_t n, std::size_t cap) {
  std::vector<std::size_t> out;
  if (n <= cap) {
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = i;
    return out;
  }
  out.reserve(cap);
  for (std::size_t k = 0; k < cap; ++k) out.push_back(k * n / cap);
  return out;
}

/// Median (upper middle element) of a non-empty vector, which is reordered.
double medianOf(std::vector<double>& v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// Median and median absolute deviation of `v` (reordered).
std::pair<double, double> medianAndMad(std::vector<double>& v) {
  const double med = medianOf(v);
  for (double& x : v) x = std::abs(x - med);
  return {med, medianOf(v)};
}

/// Sum over the pattern of the squared difference of the exposure-normalized intensities (eq. 3.5): host
/// intensities (level 0) against the target image sampled around `pixel`.
double patternSsdAt(const optimize::DirectLandmark& point, const optimize::AffineBrightness& hostAffine,
                    const cv::Mat& targetLevel0, const Eigen::Vector2d& pixel, const optimize::AffineBrightness& targetAffine) {
  if (!point.usableAt(0)) return std::numeric_limits<double>::infinity();
  double ssd = 0.0;
  for (int k = 0; k < optimize::kPatternSize; ++k) {
    const double x = pixel.x() + optimize::kDirectPattern[static_cast<std::size_t>(k)][0];
    const double y = pixel.y() + optimize::kDirectPattern[static_cast<std::size_t>(k)][1];
    if (!optimize::insideBilinear(targetLevel0, x, y)) return std::numeric_limits<double>::infinity();
    const double host = std::exp(-hostAffine.a) * (point.hostIntensities[0][static_cast<std::size_t>(k)] - hostAffine.b);
    const double target = std::exp(-targetAffine.a) * (optimize::sampleBilinear(targetLevel0, x, y) - targetAffine.b);
    ssd += (host - target) * (host - target);
  }
  return ssd;
}

}  // namespace

DirectFrontEnd::DirectFrontEnd(const DirectFeaturesParams& params, const landmarks::PointModelParams& pointModel,
                               const geometry::PinholeCamera& camera, double depthPixelNoise)
    : params_(params),
      pointModel_(pointModel),
      depthPixelNoise_(depthPixelNoise),
      keypointModel_(pointModel.keypoint) {
  params_.check();
  pointModel_.check();
  require(depthPixelNoise > 0.0, "DirectFrontEnd", "depthPixelNoise must be > 0");
  intrinsics_ = tracking::toIntrinsics(camera);
  policy_ = landmarks::makeMapPointPolicy(pointModel_.policy, keypointModel_);
  for (double d : camera.distortion) distorted_ = distorted_ || d != 0.0;
  if (distorted_) {
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const cv::Mat dist = (cv::Mat_<double>(1, 5) << camera.distortion[0], camera.distortion[1], camera.distortion[2],
                          camera.distortion[3], camera.distortion[4]);
    cv::initUndistortRectifyMap(K, dist, cv::Mat(), K, cv::Size(camera.width, camera.height), CV_32FC1, undistortX_,
                                undistortY_);
  }
}

cv::Mat DirectFrontEnd::undistort(const cv::Mat& image, bool nearest) const {
  if (!distorted_ || image.empty()) return image;
  cv::Mat out;
  cv::remap(image, out, undistortX_, undistortY_, nearest ? cv::INTER_NEAREST : cv::INTER_LINEAR,
            cv::BORDER_REPLICATE);
  return out;
}

std::optional<landmarks::ClassVector> DirectFrontEnd::classEvidenceAt(const cv::Mat& semantic,
                                                                      const Eigen::Vector2d& pixel) const {
  // eq. 3.10 as for the keypoints (MapPointModelPolicy::classEvidence): without the prior, no evidence (static).
  if (!pointModel_.semantic || semantic.empty()) return std::nullopt;
  const int x = std::clamp(static_cast<int>(std::lround(pixel.x())), 0, semantic.cols - 1);
  const int y = std::clamp(static_cast<int>(std::lround(pixel.y())), 0, semantic.rows - 1);
  const cv::Vec3b px = semantic.at<cv::Vec3b>(y, x);
  return landmarks::ClassVector{px[0] / 255.0, px[1] / 255.0, px[2] / 255.0};
}

landmarks::MapPointRecord DirectFrontEnd::recordOf(const DirectMapPoint& p, map::KeyFrameId host) const {
  landmarks::MapPointRecord r;
  r.model = p.state;
  // A direct point is seen by its host and the keyframe it was triangulated with; its found/visible ratio is that
  // of the pose optimizations it entered.
  r.counters.visible = std::max<std::uint32_t>(1, p.visible);
  r.counters.found = p.visible == 0 ? 1 : p.found;
  r.counters.observations = 2;
  r.counters.firstKeyframeId = static_cast<std::int64_t>(host);
  r.counters.bad = p.bad;
  return r;
}

bool DirectFrontEnd::mayUse(const DirectMapPoint& p, map::KeyFrameId host) const {
  return !p.bad && policy_->isActive(recordOf(p, host));
}

Eigen::Vector3d DirectFrontEnd::worldPosition(const map::Map& map, const DirectMapPoint& p) {
  const map::KeyFrame& host = map.keyFrame(p.landmark->host);
  return host.T_world_cam() * (p.landmark->bearing / p.landmark->inverseDepth);
}

std::size_t DirectFrontEnd::numPoints() const {
  std::size_t n = 0;
  for (const auto& [id, h] : hosts_)
    for (const auto& p : h.points) n += p.bad ? 0 : 1;
  return n;
}

std::shared_ptr<optimize::ImagePyramid> DirectFrontEnd::hostPyramid(DirectHost& host) const {
  if (!host.pyramid && !host.grey.empty())
    host.pyramid = std::make_shared<optimize::ImagePyramid>(host.grey, params_.pyramidLevels);
  return host.pyramid;
}

void DirectFrontEnd::prepareFrame(const tracking::Frame& frame) {
  if (framePyramid_ && frame.index == frameIndex_ && frame.timestamp == frameTimestamp_) return;
  require(!frame.grey.empty() && frame.grey.type() == CV_8UC1, "DirectFrontEnd",
          "frame " + std::to_string(frame.index) + " has no grey image");
  frameIndex_ = frame.index;
  frameTimestamp_ = frame.timestamp;
  frameGrey_ = undistort(frame.grey, false);
  frameSemantic_ = undistort(frame.semantic, true);
  framePyramid_ = std::make_shared<optimize::ImagePyramid>(frameGrey_, params_.pyramidLevels);
  frameAffine_ = {};
}

std::vector<map::KeyFrameId> DirectFrontEnd::trackingHosts(const map::Map& map, map::KeyFrameId reference) const {
  std::vector<map::KeyFrameId> out;
  if (hosts_.count(reference) && map.hasKeyFrame(reference)) out.push_back(reference);
  for (auto it = hosts_.rbegin(); it != hosts_.rend() && static_cast<int>(out.size()) < params_.hostKeyFrames; ++it)
    if (it->first != reference && map.hasKeyFrame(it->first) && !it->second.points.empty()) out.push_back(it->first);
  return out;
}

std::vector<std::shared_ptr<const optimize::PhotometricPoseFactor>> DirectFrontEnd::poseFactors(
    const tracking::Frame& frame, const map::Map& map, map::KeyFrameId reference) {
  lastFactors_.clear();
  lastInView_.clear();
  lastActive_ = lastInactive_ = lastReferenceInView_ = lastReferenceActive_ = 0;
  if (hosts_.empty()) return {};
  prepareFrame(frame);
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

tracking::DirectFrameCounts DirectFrontEnd::viewCounts() const {
  tracking::DirectFrameCounts counts;
  counts.active = lastActive_;
  counts.inactive = lastInactive_;
  counts.referenceInView = lastReferenceInView_;
  counts.referenceActive = lastReferenceActive_;
  return counts;
}

tracking::DirectFrameCounts DirectFrontEnd::afterTracking(const tracking::Frame& frame, const map::Map& map,
                                                          const std::vector<bool>& factorOutliers) {
  tracking::DirectFrameCounts counts = viewCounts();
  if (factorOutliers.size() == lastFactors_.size()) {
    counts.factors = static_cast<int>(lastFactors_.size());
    for (std::size_t k = 0; k < lastFactors_.size(); ++k) {
      DirectMapPoint& p = hosts_.at(lastFactors_[k].host).points[lastFactors_[k].index];
      ++p.visible;
      if (!factorOutliers[k]) {
        ++p.found;
        ++counts.inliers;
      }
    }
  }
  if (!framePyramid_ || frame.index != frameIndex_) return counts;

  // §3.4.2: every point in view, active or not, is measured: optical flow from its host pixel into the frame
  // starting at its projection, the flow re-triangulated against the host gives one depth measurement with the
  // eq. 2.24-2.29 variance, the pattern SSD the matching accuracy (eq. 3.4-3.5), the frame's SEMANTIC channel the
  // class evidence (eq. 3.10). The heuristic model learns nothing (ORB-SLAM*).
  if (policy_->model() != landmarks::MapPointModel::Heuristic && params_.maxMeasuredPoints > 0) {
    const std::vector<std::size_t> chosen =
        evenSubset(lastInView_.size(), static_cast<std::size_t>(params_.maxMeasuredPoints));
    std::map<map::KeyFrameId, std::vector<std::size_t>> byHost;  // into lastInView_
    for (std::size_t c : chosen) byHost[lastInView_[c].host].push_back(c);
    const geometry::Matrix34d Pf =
        geometry::projectionMatrix(intrinsics_.K(), frame.T_cam_world.linear(), frame.T_cam_world.translation());
    const cv::Mat& level0 = framePyramid_->level(0);
    // The frame's optical-flow pyramid once for all hosts, each host's (with its gradients) once while it is
    // measured: calcOpticalFlowPyrLK on the images would build both per call, with the same result.
    const cv::Size measureWin(params_.measureWindow, params_.measureWindow);
    std::vector<cv::Mat> frameFlowPyramid;
    int flowLevels = params_.measureLevels;
    if (!byHost.empty())
      flowLevels = std::min(flowLevels, cv::buildOpticalFlowPyramid(frameGrey_, frameFlowPyramid, measureWin,
                                                                    params_.measureLevels, false));
    for (auto& [h, host] : hosts_)
      if (!byHost.count(h)) host.flowPyramid.clear();
    for (auto& [h, list] : byHost) {
      DirectHost& host = hosts_.at(h);
      if (host.grey.empty()) continue;
      if (host.flowPyramid.empty())
        cv::buildOpticalFlowPyramid(host.grey, host.flowPyramid, measureWin, params_.measureLevels, true);
      const map::KeyFrame& kf = map.keyFrame(h);
      std::vector<cv::Point2f> from, to;
      std::vector<Eigen::Vector2d> predicted;
      for (std::size_t c : list) {
        const DirectMapPoint& p = host.points[lastInView_[c].index];
        const Eigen::Vector2d uv = intrinsics_.project(frame.T_cam_world * worldPosition(map, p));
        from.emplace_back(static_cast<float>(p.landmark->pixel.x()), static_cast<float>(p.landmark->pixel.y()));
        to.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
        predicted.push_back(uv);
      }
      std::vector<uchar> status;
      std::vector<float> err;
      cv::calcOpticalFlowPyrLK(host.flowPyramid, frameFlowPyramid, from, to, status, err, measureWin, flowLevels,
                               cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03),
                               cv::OPTFLOW_USE_INITIAL_FLOW);
      const geometry::Matrix34d Ph =
          geometry::projectionMatrix(intrinsics_.K(), kf.T_cam_world.linear(), kf.T_cam_world.translation());
      const Eigen::Vector3d t_host_frame = kf.T_cam_world * frame.cameraCenter();
      for (std::size_t k = 0; k < list.size(); ++k) {
        DirectMapPoint& p = host.points[lastInView_[list[k]].index];
        const Eigen::Vector2d flow(to[k].x, to[k].y);
        const std::optional<landmarks::ClassVector> classes =
            classEvidenceAt(frameSemantic_, status[k] ? flow : predicted[k]);
        if (!status[k] || (flow - predicted[k]).norm() > params_.maxMeasureShift) {
          keypointModel_.addSemanticObservation(p.state, classes, 0.0);
          continue;
        }
        const double ssd = patternSsdAt(*p.landmark, host.affine, level0, flow, frameAffine_);
        const double alpha = std::isfinite(ssd) ? landmarks::matchingAccuracyFromSsd(
                                                      ssd * 255.0 * 255.0, pointModel_.matching.photometricMaxSsd)
                                                : 0.0;
        Eigen::Vector3d X;
        bool updated = false;
        if (t_host_frame.norm() > 0.0 && geometry::triangulateDLT(Ph, p.landmark->pixel, Pf, flow, X)) {
          const Eigen::Vector3d X_host = kf.T_cam_world * X;
          if (X_host.z() > 0.0) {
            const landmarks::DepthUncertainty tau = landmarks::depthUncertainty(
                p.landmark->bearing, X_host.norm(), t_host_frame, intrinsics_.fx, depthPixelNoise_);
            if (tau.valid && tau.tau2InverseDepth() > 0.0) {
              keypointModel_.observe(p.state, 1.0 / X_host.z(), tau.tau2InverseDepth(), alpha, classes);
              ++p.updates;
              ++counts.measured;
              updated = true;
            }
          }
        }
        if (!updated) keypointModel_.addSemanticObservation(p.state, classes, alpha);
      }
    }
  }

  // Culling: points the pose optimizations keep rejecting (ORB-SLAM's found ratio), and for the probabilistic
  // model the points whose inlier ratio collapsed (landmarks::inlierRatioShouldCull).
  for (const PointRef& r : lastInView_) {
    DirectMapPoint& p = hosts_.at(r.host).points[r.index];
    if (p.bad) continue;
    if (p.visible >= static_cast<std::uint32_t>(params_.cullMinVisible) &&
        static_cast<double>(p.found) < params_.cullMinFoundRatio * static_cast<double>(p.visible))
      p.bad = true;
    else if (policy_->model() == landmarks::MapPointModel::Probabilistic &&
             landmarks::inlierRatioShouldCull(recordOf(p, r.host), pointModel_.policy, keypointModel_))
      p.bad = true;
  }
  return counts;
}

void DirectFrontEnd::addKeyFrame(map::KeyFrameId kf, const cv::Mat& grey, const cv::Mat& semantic, bool fromLastFrame) {
  require(!grey.empty() && grey.type() == CV_8UC1, "DirectFrontEnd", "keyframe " + std::to_string(kf) + " has no grey image");
  DirectHost& host = hosts_[kf];
  host.grey = undistort(grey, false);
  host.semantic = undistort(semantic, true);
  host.pyramid.reset();
  host.flowPyramid.clear();
  host.affine = fromLastFrame ? frameAffine_ : optimize::AffineBrightness{};
  host.points.clear();
}

DirectCreationReport DirectFrontEnd::createPoints(const map::Map& map, map::KeyFrameId kfId) {
  const auto t0 = Clock::now();
  DirectCreationReport report;
  auto it = hosts_.find(kfId);
  if (it == hosts_.end() || it->second.grey.empty() || !map.hasKeyFrame(kfId)) return report;
  DirectHost& host = it->second;
  const map::KeyFrame& kf = map.keyFrame(kfId);
  // Depth prior of the expected positions: the host's map points (median per cell of an 8 x 6 grid, the
  // keyframe's median where a cell has none).
  constexpr int kCellsX = 8, kCellsY = 6;
  std::vector<std::vector<double>> cellDepths(kCellsX * kCellsY);
  std::vector<double> allDepths;
  auto cellOf = [&](const Eigen::Vector2d& px) {
    const int cx = std::clamp(static_cast<int>(px.x() * kCellsX / host.grey.cols), 0, kCellsX - 1);
    const int cy = std::clamp(static_cast<int>(px.y() * kCellsY / host.grey.rows), 0, kCellsY - 1);
    return cy * kCellsX + cx;
  };
  for (std::size_t i = 0; i < kf.mapPointIds.size(); ++i) {
    const map::MapPointId id = kf.mapPointIds[i];
    if (id == map::kNoMapPoint || !map.hasMapPoint(id) || map.mapPoint(id).bad) continue;
    const double z = (kf.T_cam_world * map.worldPosition(id)).z();
    if (z <= 0.0) continue;
    cellDepths[static_cast<std::size_t>(cellOf(kf.pixel(i)))].push_back(z);
    allDepths.push_back(z);
  }
  if (allDepths.empty()) return report;
  const double globalDepth = medianOf(allDepths);

  // The partner: the most recent keyframes with an image first (the least change of appearance for the optical
  // flow), then the best covisible ones; the first whose baseline is at least minPartnerBaseline of the scene
  // depth (a keyframe inserted one frame after the last one has too little parallax to triangulate), else the
  // candidate with the longest baseline.
  std::vector<map::KeyFrameId> candidates;
  for (auto h = hosts_.rbegin(); h != hosts_.rend() && candidates.size() < 3; ++h)
    if (h->first != kfId && map.hasKeyFrame(h->first) && !h->second.grey.empty()) candidates.push_back(h->first);
  for (map::KeyFrameId n : map.bestCovisibleKeyFrames(kfId, 10)) {
    auto h = hosts_.find(n);
    if (h != hosts_.end() && !h->second.grey.empty() &&
        std::find(candidates.begin(), candidates.end(), n) == candidates.end())
      candidates.push_back(n);
  }
  double longest = -1.0;
  for (map::KeyFrameId c : candidates) {
    const double ratio = (map.keyFrame(c).cameraCenter() - kf.cameraCenter()).norm() / globalDepth;
    if (ratio >= params_.minPartnerBaseline) {
      report.partner = c;
      break;
    }
    if (ratio > longest) {
      longest = ratio;
      report.partner = c;
    }
  }
  if (report.partner == map::kNoKeyFrame) return report;
  DirectHost& partner = hosts_.at(report.partner);
  const map::KeyFrame& pkf = map.keyFrame(report.partner);

  // Multi-resolution selection (Algorithm 3 on halved images), points in level-0 pixels.
  auto step = Clock::now();
  std::vector<cv::Mat> levels{host.grey};
  for (int l = 1; l < params_.selectionLevels; ++l) {
    cv::Mat half;
    cv::resize(levels.back(), half, cv::Size(levels.back().cols / 2, levels.back().rows / 2), 0, 0, cv::INTER_AREA);
    if (half.cols < 16 || half.rows < 16) break;
    levels.push_back(half);
  }
  const features::DirectPointSelector selector(params_.selector);
  const auto selected = selector.selectPyramid(levels);
  const double border = optimize::kPatternPadding * (1 << (params_.pyramidLevels - 1)) + 2.0;
  std::vector<Eigen::Vector2d> pixels;
  for (std::size_t l = 0; l < selected.size(); ++l) {
    const double s = static_cast<double>(1 << l);
    for (const features::DirectPoint& d : selected[l]) {
      const Eigen::Vector2d p(toOriginalPixel(static_cast<double>(d.pixel.x), s),
                              toOriginalPixel(static_cast<double>(d.pixel.y), s));
      if (p.x() < border || p.y() < border || p.x() > host.grey.cols - 1 - border || p.y() > host.grey.rows - 1 - border)
        continue;
      pixels.push_back(p);
    }
  }
  report.selected = static_cast<int>(pixels.size());
  report.selectionMs = msSince(step);
  step = Clock::now();
  if (pixels.empty()) return report;

  std::vector<double> cellDepth(cellDepths.size(), globalDepth);
  for (std::size_t c = 0; c < cellDepths.size(); ++c)
    if (cellDepths[c].size() >= 3) cellDepth[c] = medianOf(cellDepths[c]);

  const Eigen::Isometry3d T_partner_host = pkf.T_cam_world * kf.T_world_cam();
  std::vector<cv::Point2f> from, guesses;
  for (const Eigen::Vector2d& px : pixels) {
    const Eigen::Vector3d ray = intrinsics_.bearing(px);
    const double z = cellDepth[static_cast<std::size_t>(cellOf(px))];
    const Eigen::Vector3d pc = T_partner_host * (ray / ray.z() * z);
    const Eigen::Vector2d g = pc.z() > 0.0 ? intrinsics_.project(pc) : px;
    from.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    guesses.emplace_back(static_cast<float>(g.x()), static_cast<float>(g.y()));
  }
  const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(
      intrinsics_.K(), kf.T_cam_world.linear(), kf.T_cam_world.translation(), intrinsics_.K(),
      pkf.T_cam_world.linear(), pkf.T_cam_world.translation());
  cv::Matx33d F21;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) F21(r, c) = F12(c, r);
  features::DirectMatchParams mp;
  mp.windowSize = params_.flowWindow;
  mp.pyramidLevels = params_.flowLevels;
  mp.maxEpipolarDistance = static_cast<float>(params_.maxEpipolarDistance);
  mp.maxForwardBackward = static_cast<float>(params_.maxForwardBackward);
  const std::vector<features::DirectMatch> matches =
      features::matchDirectPoints(host.grey, partner.grey, from, guesses, &F21, mp);
  report.flowMs = msSince(step);
  step = Clock::now();

  const geometry::Matrix34d P1 =
      geometry::projectionMatrix(intrinsics_.K(), kf.T_cam_world.linear(), kf.T_cam_world.translation());
  const geometry::Matrix34d P2 =
      geometry::projectionMatrix(intrinsics_.K(), pkf.T_cam_world.linear(), pkf.T_cam_world.translation());
  const Eigen::Vector3d O1 = kf.cameraCenter(), O2 = pkf.cameraCenter();
  const Eigen::Vector3d t_host_partner = kf.T_cam_world * O2;
  const std::shared_ptr<optimize::ImagePyramid> pyramid = hostPyramid(host);
  const cv::Mat& partnerLevel0 = hostPyramid(partner)->level(0);
  const double maxReproj2 = params_.maxReprojection * params_.maxReprojection;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    if (!matches[i].valid) continue;
    ++report.tracked;
    const Eigen::Vector2d x2(matches[i].position.x, matches[i].position.y);
    Eigen::Vector3d X;
    if (!geometry::triangulateDLT(P1, pixels[i], P2, x2, X)) continue;
    const Eigen::Vector3d X1 = kf.T_cam_world * X, X2 = pkf.T_cam_world * X;
    if (X1.z() <= 0.0 || X2.z() <= 0.0) continue;
    const Eigen::Vector3d r1 = (X - O1).normalized(), r2 = (X - O2).normalized();
    if (r1.dot(r2) > params_.maxParallaxCos) continue;
    if ((intrinsics_.project(X1) - pixels[i]).squaredNorm() > maxReproj2 ||
        (intrinsics_.project(X2) - x2).squaredNorm() > maxReproj2)
      continue;
    DirectMapPoint p;
    try {
      p.landmark = std::make_shared<optimize::DirectLandmark>(
          optimize::DirectLandmark::create(kfId, pixels[i], 1.0 / X1.norm(), intrinsics_, *pyramid));
    } catch (const Error&) {
      continue;  // the pattern does not fit (cannot happen inside the border; kept as a guard)
    }
    // Seed of the keypoint model as for a triangulated keypoint (LocalMapper::createNewMapPoints): the inverse
    // depth with this pair's eq. 2.24-2.29 variance, the class evidence of both views weighted by the matching
    // accuracy of the pair (eq. 3.4).
    const landmarks::DepthUncertainty tau = landmarks::depthUncertainty(p.landmark->bearing, X1.norm(), t_host_partner,
                                                                        intrinsics_.fx, depthPixelNoise_);
    const double variance = tau.valid && tau.tau2InverseDepth() > 0.0
                                ? tau.tau2InverseDepth()
                                : mapping::initialInverseDepthVariance(pointModel_.keypoint);
    p.state = keypointModel_.initialize(p.landmark->inverseDepth / p.landmark->bearing.z(), variance);
    const double ssd = patternSsdAt(*p.landmark, host.affine, partnerLevel0, x2, partner.affine);
    const double alpha = std::isfinite(ssd) ? landmarks::matchingAccuracyFromSsd(ssd * 255.0 * 255.0,
                                                                                 pointModel_.matching.photometricMaxSsd)
                                            : 0.0;
    keypointModel_.addSemanticObservation(p.state, classEvidenceAt(host.semantic, pixels[i]), 1.0);
    keypointModel_.addSemanticObservation(p.state, classEvidenceAt(partner.semantic, x2), alpha);
    host.points.push_back(std::move(p));
    ++report.created;
  }
  report.pointsMs = msSince(step);
  report.ms = msSince(t0);
  return report;
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

int DirectFrontEnd::afterBundleAdjustment(const std::vector<bool>& factorOutliers) {
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

void DirectFrontEnd::prune(const map::Map& map) {
  for (auto it = hosts_.begin(); it != hosts_.end();) {
    if (!map.hasKeyFrame(it->first))
      it = hosts_.erase(it);
    else
      ++it;
  }
  int kept = 0;
  for (auto it = hosts_.rbegin(); it != hosts_.rend(); ++it) {
    if (it->second.grey.empty()) continue;
    if (++kept > params_.keepImages) {
      it->second.grey.release();
      it->second.semantic.release();
      it->second.pyramid.reset();
      it->second.flowPyramid.clear();
    }
  }
}

void DirectFrontEnd::reset() {
  hosts_.clear();
  lastFactors_.clear();
  lastInView_.clear();
  baPoints_.clear();
  framePyramid_.reset();
  frameIndex_ = static_cast<std::size_t>(-1);
}

nlohmann::json DirectFrontEnd::summary() const {
  std::size_t points = 0, active = 0;
  for (const auto& [id, h] : hosts_)
    for (const auto& p : h.points) {
      if (p.bad) continue;
      ++points;
      if (mayUse(p, id)) ++active;
    }
  return {{"direct_points", points}, {"direct_active", active}, {"direct_hosts", hosts_.size()}};
}

}  // namespace pslam::direct
