#include "pslam/direct/DirectFrontEnd.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "DirectHelpers.h"
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

using detail::evenSubset;
using detail::patternSsdAt;

DirectFrontEnd::DirectFrontEnd(const DirectFeaturesParams& params, const landmarks::PointModelParams& pointModel,
                               const geometry::PinholeCamera& camera, double depthPixelNoise)
    : params_(params),
      pointModel_(pointModel),
      depthPixelNoise_(depthPixelNoise),
      keypointModel_(pointModel.keypoint) {
  params_.check();
  pointModel_.check();
  require(depthPixelNoise > 0.0, "DirectFrontEnd", "depthPixelNoise must be > 0");
  intrinsics_ = camera.withoutDistortion();
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

void DirectFrontEnd::prepareTrackedFrame(const tracking::Frame& frame) {
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

DirectFrameCounts DirectFrontEnd::viewCounts() const {
  DirectFrameCounts counts;
  counts.active = lastActive_;
  counts.inactive = lastInactive_;
  counts.referenceInView = lastReferenceInView_;
  counts.referenceActive = lastReferenceActive_;
  return counts;
}

DirectFrameCounts DirectFrontEnd::afterTracking(const tracking::Frame& frame, const map::Map& map,
                                                          const std::vector<bool>& factorOutliers) {
  DirectFrameCounts counts = viewCounts();
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

std::map<std::string, std::size_t> DirectFrontEnd::counts() const {
  std::size_t points = 0, active = 0;
  for (const auto& [id, h] : hosts_)
    for (const auto& p : h.points) {
      if (p.bad) continue;
      ++points;
      if (mayUse(p, id)) ++active;
    }
  return {{"direct_points", points}, {"direct_active", active}, {"direct_hosts", hosts_.size()}};
}

// ---------------------------------------------------------------- the module's stages (tracking::LandmarkModule)

nlohmann::json DirectFrameCounts::toJson() const {
  return {{"direct_factors", factors},   {"direct_inliers", inliers},
          {"direct_active", active},     {"direct_inactive", inactive},
          {"direct_measured", measured}, {"direct_reference_in_view", referenceInView},
          {"direct_reference_active", referenceActive}};
}

bool DirectFrontEnd::joins(const tracking::PoseAttempt& attempt) const {
  return attempt.finalOptimization || attempt.keypointObservations < 2 * attempt.minPoseInliers;
}

tracking::ModulePoseFactors DirectFrontEnd::poseFactors(const tracking::Frame& frame, const map::Map& map,
                                                        map::KeyFrameId reference) {
  tracking::ModulePoseFactors factors;
  factors.pyramid = photometricFactors(frame, map, reference);
  return factors;
}

tracking::ModuleFrameReport DirectFrontEnd::afterTracking(const tracking::Frame& frame, const map::Map& map,
                                                          const std::vector<bool>& factorOutliers, bool learn) {
  DirectFrameCounts counts;
  if (learn) {
    counts = afterTracking(frame, map, factorOutliers);
  } else {
    // Localization: the points stay as they were loaded (no measurements, counters or culling); the report still
    // says what the pose used and which points it saw.
    counts = viewCounts();
    counts.factors = static_cast<int>(factorOutliers.size());
    for (bool o : factorOutliers) counts.inliers += o ? 0 : 1;
  }
  tracking::ModuleFrameReport report;
  report.counts = counts.toJson();
  report.referenceInView = counts.referenceInView;
  report.referenceActive = counts.referenceActive;
  return report;
}

void DirectFrontEnd::addKeyFrame(const tracking::KeyFrameImages& keyFrame) {
  addKeyFrame(keyFrame.id, keyFrame.grey, keyFrame.semantic, keyFrame.fromLastFrame);
}

void DirectFrontEnd::afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings& timings,
                                       nlohmann::json& log) {
  // New direct points at the keyframe's refined pose (§3.4.3), matched into its best covisible keyframe.
  const DirectCreationReport d = createPoints(map, kf);
  prune(map);
  timings.add("direct_creation", d.ms);
  if (d.partner != map::kNoKeyFrame) {  // its steps (doc/experiments.md, cost of the direct points)
    timings.add("direct_selection", d.selectionMs);
    timings.add("direct_flow", d.flowMs);
    timings.add("direct_new_points", d.pointsMs);
  }
  log["direct_selected"] = d.selected;
  log["direct_tracked"] = d.tracked;
  log["direct_created"] = d.created;
  log["direct_partner"] = d.partner == map::kNoKeyFrame ? -1 : static_cast<long long>(d.partner);
}

std::optional<std::string> DirectFrontEnd::mapExtension() const {
  if (numPoints() == 0) return std::nullopt;
  return serialize();
}

std::function<void()> DirectFrontEnd::prepareLoad(const std::string& bytes, const map::Map& loaded) {
  auto hosts = std::make_shared<std::map<map::KeyFrameId, DirectHost>>(parse(bytes, loaded));
  return [this, hosts] { restore(std::move(*hosts)); };
}

}  // namespace pslam::direct
