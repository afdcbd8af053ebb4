#include "pslam/tracking/ManhattanInitializer.h"

#include <algorithm>
#include <cmath>

#include "pslam/geometry/Triangulation.h"
#include "pslam/manhattan/ManhattanTracker.h"

namespace pslam::tracking {

namespace {
constexpr double kRadToDeg = 180.0 / M_PI;

Eigen::Vector3d normalizedCoordinates(const geometry::PinholeCamera& cam, const cv::KeyPoint& kp) {
  return {(kp.pt.x - cam.cx) / cam.fx, (kp.pt.y - cam.cy) / cam.fy, 1.0};
}
}  // namespace

ManhattanInitializer::ManhattanInitializer(const geometry::PinholeCamera& camera, InitializerParams params,
                                           optimize::BundleAdjustmentParams baParams)
    : camera_(camera), params_(params), baParams_(baParams), fallback_(camera, params, baParams) {}

void ManhattanInitializer::reset() {
  reference_.reset();
  skipped_ = 0;
  fallback_.reset();
}

InitializationOutcome ManhattanInitializer::takeAsReference(Frame& current, const std::string& why) {
  InitializationOutcome out;
  reference_.reset();
  skipped_ = 0;
  if (static_cast<int>(current.size()) >= params_.minKeypoints && current.R_cam_mf) reference_ = current;
  out.message = "manhattan: " + why;
  return out;
}

InitializationOutcome ManhattanInitializer::skip(Frame& current, const std::string& why) {
  // §4.4.1: "we discard the second frame and keep searching ... If too many frames are skipped we reset the
  // first frame and start over again".
  const double maxSeconds = params_.manhattan.maxSkippedSeconds;
  const bool tooLate = maxSeconds > 0 && reference_ && current.timestamp - reference_->timestamp > maxSeconds;
  if (++skipped_ > params_.manhattan.maxSkippedFrames || tooLate)
    return takeAsReference(current, why + "; " + std::to_string(skipped_ - 1) + " frames skipped, reference replaced");
  InitializationOutcome out;
  out.matches = diag_.matches;
  out.message = "manhattan: " + why + ", frame skipped";
  return out;
}

InitializationOutcome ManhattanInitializer::process(Frame& current, map::Map& map, std::mt19937& rng,
                                                    Frame* referenceOut) {
  diag_ = ManhattanInitDiagnostics();
  const ManhattanInitParams& P = params_.manhattan;
  if (!current.R_cam_mf) {
    // No Manhattan frame in this frame: the H/F path (its own reference frame).
    reference_.reset();
    skipped_ = 0;
    InitializationOutcome out = fallback_.process(current, map, rng, referenceOut);
    out.message = "no Manhattan frame, two-view: " + out.message;
    return out;
  }
  fallback_.reset();
  if (!reference_) return takeAsReference(current, "new reference frame");
  if (static_cast<int>(current.size()) < params_.minKeypoints) return skip(current, "too few keypoints");

  // Rotation from the two Manhattan frames (§4.4.1): R_cur_ref = R_cur_mf R_ref_mf^T, with the current frame's
  // axes re-labelled to the reference's (the cube symmetry closest to no rotation).
  const Frame& ref = *reference_;
  double angleDeg = 0.0;
  const Eigen::Matrix3d R_cur_mf = manhattan::alignToReference(*current.R_cam_mf, *ref.R_cam_mf, &angleDeg);
  diag_.rotationDeg = angleDeg;
  if (angleDeg > P.maxRotationDeg)
    return skip(current, "Manhattan frames " + std::to_string(angleDeg) + " deg apart");
  const Eigen::Matrix3d R = R_cur_mf * ref.R_cam_mf->transpose();
  diag_.R_cur_ref = R;

  // SearchForInitialization around where each reference keypoint goes under the rotation alone (the
  // infinite homography K R K^-1): the window then only has to cover the translation's flow.
  std::vector<cv::Point2f> predicted;
  predicted.reserve(ref.size());
  for (const auto& kp : ref.keypoints) {
    const Eigen::Vector3d r = R * normalizedCoordinates(ref.camera, kp);
    predicted.emplace_back(r.z() > 1e-6 ? static_cast<float>(current.camera.fx * r.x() / r.z() + current.camera.cx)
                                        : -1e6f,
                           r.z() > 1e-6 ? static_cast<float>(current.camera.fy * r.y() / r.z() + current.camera.cy)
                                        : -1e6f);
  }
  features::InitMatchParams mp;
  mp.windowHalfSize = params_.windowHalfSize;
  mp.nnRatio = params_.nnRatio;
  mp.maxOctave1 = params_.maxOctave;
  auto matches = features::matchForInitialization(ref.keypoints, ref.descriptors, current.keypoints,
                                                  current.descriptors, current.grid, predicted, mp);
  keepStaticMatches(ref, current, params_.minStaticProbability, matches);
  diag_.matches = static_cast<int>(matches.size());
  if (diag_.matches < P.minMatches)
    return skip(current, "too few initialization matches (" + std::to_string(diag_.matches) + ")");

  // Translation direction by eq. 4.1 (each pair one row, SVD), inside RANSAC.
  std::vector<Eigen::Vector3d> bRef, bCur;
  for (const auto& m : matches) {
    bRef.push_back(normalizedCoordinates(ref.camera, ref.keypoints[static_cast<std::size_t>(m.i1)]));
    bCur.push_back(normalizedCoordinates(current.camera, current.keypoints[static_cast<std::size_t>(m.i2)]));
  }
  // Pure rotation leaves the translation undetermined (every row of eq. 4.1 vanishes): the rotation-compensated
  // bearings of most pairs must diverge.
  std::vector<double> parallax;
  for (std::size_t m = 0; m < matches.size(); ++m)
    parallax.push_back(std::acos(std::clamp((R * bRef[m]).normalized().dot(bCur[m].normalized()), -1.0, 1.0)) *
                       kRadToDeg);
  std::nth_element(parallax.begin(), parallax.begin() + static_cast<long>(parallax.size() / 2), parallax.end());
  diag_.medianParallaxDeg = parallax[parallax.size() / 2];
  if (diag_.medianParallaxDeg < P.minMedianParallaxDeg)
    return skip(current, "rotation only (median parallax " + std::to_string(diag_.medianParallaxDeg) + " deg)");

  const manhattan::TranslationEstimate te = manhattan::ransacTranslationDirection(bRef, bCur, R, P.ransac);
  diag_.translationInliers = static_cast<int>(te.inlierCount);
  if (!te.valid || diag_.translationInliers < P.minInliers)
    return skip(current, "too few translation inliers (" + std::to_string(diag_.translationInliers) + " of " +
                             std::to_string(diag_.matches) + ")");
  diag_.t_cur_ref = te.t_cur_prev;

  // Triangulation of the inlier pairs with ORB-SLAM's two-view checks (positive depth in both views, chi-square
  // reprojection test at the keypoint's level, parallax).
  const Eigen::Matrix3d K = camera_.K();
  const Eigen::Vector3d t = te.t_cur_prev;
  const geometry::Matrix34d P1 = geometry::projectionMatrix(K, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const geometry::Matrix34d P2 = geometry::projectionMatrix(K, R, t);
  const Eigen::Vector3d c2 = -R.transpose() * t;
  const double cosMinParallax = std::cos(P.minParallaxDeg / kRadToDeg);
  std::vector<std::pair<int, int>> pairs;
  std::vector<Eigen::Vector3d> points;
  for (std::size_t m = 0; m < matches.size(); ++m) {
    if (!te.inliers[m]) continue;
    const auto& k1 = ref.keypoints[static_cast<std::size_t>(matches[m].i1)];
    const auto& k2 = current.keypoints[static_cast<std::size_t>(matches[m].i2)];
    const Eigen::Vector2d u1(k1.pt.x, k1.pt.y), u2(k2.pt.x, k2.pt.y);
    Eigen::Vector3d X;
    if (!geometry::triangulateDLT(P1, u1, P2, u2, X) || !X.allFinite()) continue;
    if (!geometry::hasPositiveDepth(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), X) ||
        !geometry::hasPositiveDepth(R, t, X))
      continue;
    if (geometry::parallaxCosine(X, Eigen::Vector3d::Zero(), c2) > cosMinParallax) continue;
    const double s1 = ref.levelSigma2[static_cast<std::size_t>(k1.octave)];
    const double s2 = current.levelSigma2[static_cast<std::size_t>(k2.octave)];
    if (!geometry::passesReprojectionTest(
            geometry::reprojectionErrorSquared(K, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), X, u1), s1) ||
        !geometry::passesReprojectionTest(geometry::reprojectionErrorSquared(K, R, t, X, u2), s2))
      continue;
    pairs.emplace_back(matches[m].i1, matches[m].i2);
    points.push_back(X);
  }
  diag_.triangulated = static_cast<int>(points.size());
  if (diag_.triangulated < P.minTriangulated)
    return skip(current, "too few triangulated points (" + std::to_string(diag_.triangulated) + ")");

  Eigen::Isometry3d T_cur_ref = Eigen::Isometry3d::Identity();
  T_cur_ref.linear() = R;
  T_cur_ref.translation() = t;
  Frame reference = *reference_;
  const InitialMapOutcome built =
      buildInitialMap(reference, current, T_cur_ref, pairs, points, baParams_, P.minMapPoints, map);
  InitializationOutcome out;
  out.matches = diag_.matches;
  if (!built.accepted) {
    reference_.reset();
    skipped_ = 0;
    out.message = "manhattan: " + built.message;
    return out;
  }
  out.initialized = true;
  out.manhattanRotation = true;
  out.kf1 = built.kf1;
  out.kf2 = built.kf2;
  out.message = "initialized (manhattan, rotation " + std::to_string(angleDeg) + " deg, " +
                std::to_string(diag_.translationInliers) + " translation inliers, " + built.message + ")";
  if (referenceOut) *referenceOut = reference;
  reference_.reset();
  skipped_ = 0;
  return out;
}

}  // namespace pslam::tracking
