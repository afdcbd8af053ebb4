// New direct points of a keyframe (thesis §3.2.2, §3.4.1, §3.4.3): DSO's multi-resolution selection, pyramidal
// optical flow into the best covisible keyframe with an image, epipolar and forward-backward checks, triangulation
// along the host's bearing, and the keypoint model of each new point.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "DirectHelpers.h"
#include "pslam/core/Error.h"
#include "pslam/core/PixelCentres.h"
#include "pslam/core/StageTimer.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/landmarks/MatchingAccuracy.h"
#include "pslam/landmarks/MeasurementVariance.h"
#include "pslam/mapping/MapPointModelPolicy.h"

namespace pslam::direct {

using detail::evenSubset;
using detail::medianOf;
using detail::patternSsdAt;

DirectCreationReport DirectFrontEnd::createPoints(const map::Map& map, map::KeyFrameId kfId) {
  const auto t0 = std::chrono::steady_clock::now();
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
  auto step = std::chrono::steady_clock::now();
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
  step = std::chrono::steady_clock::now();
  if (pixels.empty()) return report;

  std::vector<double> cellDepth(cellDepths.size(), globalDepth);
  for (std::size_t c = 0; c < cellDepths.size(); ++c)
    if (cellDepths[c].size() >= 3) cellDepth[c] = medianOf(cellDepths[c]);

  const Eigen::Isometry3d T_partner_host = pkf.T_cam_world * kf.T_world_cam();
  std::vector<cv::Point2f> from, guesses;
  for (const Eigen::Vector2d& px : pixels) {
    const Eigen::Vector3d ray = intrinsics_.unprojectToBearing(px);
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
  step = std::chrono::steady_clock::now();

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

}  // namespace pslam::direct
