#include "pslam/tracking/Relocalizer.h"

#include <algorithm>
#include <set>

#include "pslam/features/Matching.h"
#include "pslam/geometry/Pnp.h"
#include "pslam/places/BowMatching.h"
#include "pslam/tracking/ProjectionSearch.h"

namespace pslam::tracking {

void Relocalizer::setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary,
                                const places::PlacesParams& params) {
  params.check();
  vocabulary_ = std::move(vocabulary);
  placesParams_ = params;
  keyFrameDatabase_.clear();
  for (const auto& [id, kf] : ctx_.map.keyFrames()) computeKeyFrameBow(id);
}

void Relocalizer::onMapReplaced() {
  keyFrameDatabase_.clear();
  for (const auto& [id, kf] : ctx_.map.keyFrames()) computeKeyFrameBow(id);
}

void Relocalizer::computeKeyFrameBow(map::KeyFrameId id) {
  if (!vocabulary_ || !ctx_.map.hasKeyFrame(id)) return;
  map::KeyFrame& kf = ctx_.map.mutableKeyFrame(id);
  if (!kf.bow.empty() || kf.descriptors.empty()) return;
  vocabulary_->transform(kf.descriptors, kf.bow, &kf.bowFeatures, placesParams_.directIndexLevelsUp);
}

void Relocalizer::computeFrameBow(Frame& frame) const {
  if (!vocabulary_ || !frame.bow.empty() || frame.descriptors.empty()) return;
  vocabulary_->transform(frame.descriptors, frame.bow, &frame.bowFeatures, placesParams_.directIndexLevelsUp);
}

void Relocalizer::syncKeyFrameDatabase() {
  for (const places::KeyFrameKey id : keyFrameDatabase_.keyFrames())
    if (!ctx_.map.hasKeyFrame(id)) keyFrameDatabase_.erase(id);
  for (const auto& [id, kf] : ctx_.map.keyFrames())
    if (!keyFrameDatabase_.contains(id)) {
      computeKeyFrameBow(id);
      keyFrameDatabase_.add(id, ctx_.map.keyFrame(id).bow);
    }
}

std::vector<Relocalizer::Candidate> Relocalizer::candidates(Frame& frame) {
  std::vector<Candidate> cands;
  if (vocabulary_ && placesParams_.relocalization) {
    // ORB-SLAM: the keyframe database proposes the keyframes (and covisible groups) most similar to the frame;
    // each is matched by vocabulary node (SearchByBoW: TH_LOW, ratio 0.75, rotation consistency).
    computeFrameBow(frame);
    syncKeyFrameDatabase();
    const auto places = keyFrameDatabase_.relocalizationCandidates(
        frame.bow, [&](places::KeyFrameKey k) { return ctx_.map.bestCovisibleKeyFrames(k, 10); });
    places::NodeMatchParams np;
    np.ratio = 0.75f;
    for (const places::PlaceCandidate& pc : places) {
      const map::KeyFrame& kf = ctx_.map.keyFrame(pc.keyFrame);
      Candidate c{pc.keyFrame, {}};
      for (const auto& m : places::matchByVocabularyNode(
               kf.bowFeatures, kf.descriptors, kf.keypoints, frame.bowFeatures, frame.descriptors, frame.keypoints, np,
               [&](std::size_t i) { return ctx_.usable(kf.mapPointIds[i]); }))
        c.matches.emplace_back(static_cast<std::size_t>(m.i2), kf.mapPointIds[static_cast<std::size_t>(m.i1)]);
      if (static_cast<int>(c.matches.size()) >= ctx_.params.minReferenceMatches) cands.push_back(std::move(c));
    }
  } else {
    // Without a vocabulary: exhaustive descriptor matching against every keyframe's points (the match count
    // stands in for the BoW similarity).
    features::BruteForceParams bp;
    bp.ratio = 0.75f;
    bp.maxDistance = features::kOrbThHigh;
    for (const auto& [kfId, kf] : ctx_.map.keyFrames()) {
      std::vector<int> rows;
      for (std::size_t i = 0; i < kf.mapPointIds.size(); ++i)
        if (ctx_.usable(kf.mapPointIds[i])) rows.push_back(static_cast<int>(i));
      if (static_cast<int>(rows.size()) < ctx_.params.minReferenceMatches) continue;
      cv::Mat query(static_cast<int>(rows.size()), 32, CV_8U);
      for (std::size_t r = 0; r < rows.size(); ++r) kf.descriptors.row(rows[r]).copyTo(query.row(static_cast<int>(r)));
      Candidate c{kfId, {}};
      for (const auto& m : features::matchBruteForce(query, frame.descriptors, bp))
        c.matches.emplace_back(static_cast<std::size_t>(m.i2), kf.mapPointIds[rows[m.i1]]);
      if (static_cast<int>(c.matches.size()) >= ctx_.params.minReferenceMatches) cands.push_back(std::move(c));
    }
  }
  std::stable_sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    return a.matches.size() > b.matches.size();
  });
  if (static_cast<int>(cands.size()) > ctx_.params.relocalizationCandidates) cands.resize(ctx_.params.relocalizationCandidates);
  return cands;
}

bool Relocalizer::relocalize(Frame& frame) {
  // Candidate keyframes with their matches, most matches first; each is tried by PnP. The query (BoW vector,
  // database, node matching) is timed on its own: it grows with the map differently from the PnP attempts.
  std::vector<Candidate> cands;
  {
    std::optional<ScopedStage> stage;
    ctx_.time(stage, "relocalization_query");
    cands = candidates(frame);
  }
  for (const Candidate& c : cands) {
    std::vector<Eigen::Vector3d> pts;
    std::vector<Eigen::Vector2d> pixels;
    for (const auto& [k, p] : c.matches) {
      pts.push_back(ctx_.map.worldPosition(p));
      pixels.push_back(frame.pixel(k));
    }
    const geometry::PnpResult pnp = geometry::solvePnpRansac(ctx_.camera, pts, pixels, ctx_.params.pnp);
    if (!pnp.success) continue;
    frame.resetMatches();
    optimizer_.clearMeasurements();
    for (std::size_t m = 0; m < c.matches.size(); ++m)
      if (pnp.inliers[m]) frame.mapPointIds[c.matches[m].first] = c.matches[m].second;
    frame.T_cam_world = Eigen::Isometry3d::Identity();
    frame.T_cam_world.linear() = pnp.R_cam_world;
    frame.T_cam_world.translation() = pnp.t_cam_world;
    int inliers = optimizer_.optimize(frame, {});  // a pose from PnP: keypoints alone
    if (inliers < ctx_.params.minPoseInliers) continue;
    if (inliers < ctx_.params.minInliersAfterReloc) {
      // Project the candidate keyframe's other points with a wide window and optimize again.
      std::set<map::MapPointId> have(frame.mapPointIds.begin(), frame.mapPointIds.end());
      std::vector<ProjectionCandidate> pc;
      for (map::MapPointId id : ctx_.map.pointsOf(c.kf)) {
        if (have.count(id) || !ctx_.usable(id)) continue;
        const map::MapPoint& p = ctx_.map.mapPoint(id);
        const Eigen::Vector3d pw = ctx_.map.worldPosition(id);
        const double dist = (pw - frame.cameraCenter()).norm();
        ProjectionCandidate cand;
        cand.id = id;
        cand.p_world = pw;
        cand.descriptor = p.descriptor;
        cand.predictedLevel = predictLevel(dist, p.maxDistance, frame.numLevels() > 1 ? frame.scaleFactors[1] : 1.2,
                                           frame.numLevels());
        cand.minLevel = std::max(0, cand.predictedLevel - 1);
        cand.maxLevel = cand.predictedLevel + 1;
        cand.radius = 10.f * static_cast<float>(frame.scaleFactors[cand.predictedLevel]);
        pc.push_back(cand);
      }
      ProjectionSearchParams sp;
      sp.checkOrientation = false;
      searchByProjection(frame, frame.T_cam_world, pc, sp);
      inliers = optimizer_.optimize(frame, {});
    }
    if (inliers >= ctx_.params.minInliersAfterReloc) {
      ctx_.referenceKeyFrame = c.kf;
      return true;
    }
  }
  frame.resetMatches();
  return false;
}

}  // namespace pslam::tracking
