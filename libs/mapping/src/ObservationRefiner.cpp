#include "pslam/mapping/ObservationRefiner.h"

#include <iterator>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::mapping {

ObservationRefiner::ObservationRefiner(const ObservationRefinementParams& params, const geometry::PinholeCamera& camera)
    : params_(params), camera_(camera) {
  if (camera_.hasDistortion()) {
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera_.distortion.data()));
    cv::initUndistortRectifyMap(camera_.cvK(), dist, cv::Mat(), camera_.cvK(), cv::Size(camera_.width, camera_.height),
                                CV_32FC1, undistortMapX_, undistortMapY_);
  }
}

void ObservationRefiner::addKeyFrame(map::KeyFrameId id, const cv::Mat& grey, const std::vector<double>& scaleFactors) {
  const std::string ctx = "ObservationRefiner: keyframe " + std::to_string(id);
  require(!grey.empty() && grey.type() == CV_8UC1, ctx, "the image must be a non-empty CV_8UC1");
  require(grey.cols == camera_.width && grey.rows == camera_.height, ctx,
          "the image is " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) + ", the camera " +
              std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
  cv::Mat image = grey;
  if (!undistortMapX_.empty()) cv::remap(grey, image, undistortMapX_, undistortMapY_, cv::INTER_LINEAR);
  auto pyramid = std::make_shared<const features::ScalePyramid>(image, scaleFactors);
  std::lock_guard<std::mutex> lk(mutex_);
  images_[id] = std::move(pyramid);
  while (static_cast<int>(images_.size()) > params_.cachedKeyFrames) images_.erase(images_.begin());
}

void ObservationRefiner::reset() {
  std::lock_guard<std::mutex> lk(mutex_);
  images_.clear();
  alignedTo_.clear();
}

std::size_t ObservationRefiner::keptKeyFrames() const {
  std::lock_guard<std::mutex> lk(mutex_);
  return images_.size();
}

std::size_t ObservationRefiner::keptBytes() const {
  std::lock_guard<std::mutex> lk(mutex_);
  std::size_t n = 0;
  for (const auto& [id, p] : images_) n += p->bytes();
  return n;
}

RefinementCounts ObservationRefiner::refine(map::Map& map, map::KeyFrameId kfId) {
  RefinementCounts counts;
  std::map<map::KeyFrameId, Pyramid> images;
  {
    std::lock_guard<std::mutex> lk(mutex_);
    for (auto it = images_.begin(); it != images_.end();)  // erased (culled) keyframes
      it = map.hasKeyFrame(it->first) ? std::next(it) : images_.erase(it);
    images = images_;
  }
  for (auto it = alignedTo_.begin(); it != alignedTo_.end();)
    it = images.count(it->first) ? std::next(it) : alignedTo_.erase(it);
  if (!map.hasKeyFrame(kfId)) return counts;

  const int h = params_.alignment.halfPatch;
  for (const map::MapPointId pid : map.pointsOf(kfId)) {
    const map::MapPoint& point = map.mapPoint(pid);
    if (point.bad) continue;
    const auto anchorImage = images.find(point.anchorKeyFrame);
    if (anchorImage == images.end()) continue;
    const map::KeyFrame& anchor = map.keyFrame(point.anchorKeyFrame);
    const std::pair<map::KeyFrameId, std::size_t> anchorObs{point.anchorKeyFrame, point.anchorKeypoint};
    const Eigen::Vector3d p_world = map.worldPosition(pid);
    const Eigen::Vector3d p_anchor = anchor.T_cam_world * p_world;
    if (!(p_anchor.z() > 0)) continue;
    const cv::KeyPoint& ka = anchor.keypoints.at(point.anchorKeypoint);
    const features::ScalePyramid& pa = *anchorImage->second;
    if (ka.octave < 0 || ka.octave >= pa.numLevels()) continue;
    // The observations not yet aligned to this anchor observation; only points with some cost a back-projection.
    std::vector<std::pair<map::KeyFrameId, std::size_t>> pending;
    for (const auto& [obsKf, obsKp] : point.observations) {
      if (obsKf == point.anchorKeyFrame || !images.count(obsKf)) continue;
      const auto kfAligned = alignedTo_.find(obsKf);
      if (kfAligned != alignedTo_.end()) {
        const auto done = kfAligned->second.find(obsKp);
        if (done != kfAligned->second.end() && done->second == anchorObs) continue;
      }
      pending.emplace_back(obsKf, obsKp);
    }
    if (pending.empty()) continue;
    const Eigen::Vector2d centreA = pa.toLevel(Eigen::Vector2d(ka.pt.x, ka.pt.y), ka.octave);
    // A level-0 pixel of the anchor, back-projected to the point's depth: where the other keyframe sees it.
    const Eigen::Isometry3d T_world_anchor = anchor.T_world_cam();
    const auto anchorPixelToWorld = [&](const Eigen::Vector2d& levelPixel) {
      const Eigen::Vector2d u = pa.toLevel0(levelPixel, ka.octave);
      const Eigen::Vector3d ray((u.x() - anchor.camera.cx) / anchor.camera.fx,
                                (u.y() - anchor.camera.cy) / anchor.camera.fy, 1.0);
      return Eigen::Vector3d(T_world_anchor * (ray * p_anchor.z()));
    };

    for (const auto& [obsKf, obsKp] : pending) {
      map::KeyFrame& kf = map.mutableKeyFrame(obsKf);
      cv::KeyPoint& kp = kf.keypoints.at(obsKp);
      const features::ScalePyramid& pj = *images.at(obsKf);
      if (kp.octave < 0 || kp.octave >= pj.numLevels()) continue;
      const auto transfer = [&](const Eigen::Vector2d& anchorLevelPixel) -> std::optional<Eigen::Vector2d> {
        const Eigen::Vector3d c = kf.T_cam_world * anchorPixelToWorld(anchorLevelPixel);
        if (!(c.z() > 0)) return std::nullopt;
        return pj.toLevel(kf.camera.project(c), kp.octave);
      };
      const std::optional<features::PatchWarp> warp = features::patchWarpOf(transfer, centreA, h);
      if (!warp) continue;
      const Eigen::Vector2d start = pj.toLevel(Eigen::Vector2d(kp.pt.x, kp.pt.y), kp.octave);
      ++counts.tried;
      alignedTo_[obsKf][obsKp] = anchorObs;
      const features::PatchAlignmentResult r =
          features::alignPatch(pa.level(ka.octave), centreA, warp->A, pj.level(kp.octave), start, params_.alignment);
      if (!r.accepted) continue;
      const Eigen::Vector2d u = pj.toLevel0(r.position, kp.octave);
      kp.pt = cv::Point2f(static_cast<float>(u.x()), static_cast<float>(u.y()));
      ++counts.refined;
      counts.sumShift += (r.position - start).norm();
    }
  }
  return counts;
}

}  // namespace pslam::mapping
