#include "pslam/loopclosing/LoopCloser.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include "pslam/core/ByteCodec.h"
#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/features/Matching.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/geometry/Sim3Solver.h"
#include "pslam/optimize/MapAdapter.h"
#include "pslam/optimize/PoseGraph.h"
#include "pslam/places/BowMatching.h"
#include "pslam/places/Vocabulary.h"

namespace pslam::loopclosing {

PSLAM_DEFINE_PARAMS(LoopClosingParams)

using geometry::Sim3;
using map::KeyFrame;
using map::KeyFrameId;
using map::MapPointId;

nlohmann::json LoopReport::toJson() const {
  nlohmann::json v = nlohmann::json::array();
  for (const auto& x : verified)
    v.push_back({{"candidate", x.candidate}, {"bow_matches", x.bowMatches}, {"sim3_inliers", x.sim3Inliers},
                 {"loop_matches", x.loopMatches}});
  nlohmann::json j = {{"keyframe", keyFrame}, {"candidates", candidates}, {"consistent_candidates", consistentCandidates},
                      {"verified", v}, {"closed", closed}, {"ms", ms}};
  if (closed || withdrawn) {
    j["matched_keyframe"] = matchedKeyFrame;
    j["scale"] = scale;
    j["correction_m"] = correctionMetres;
    j["corrected_keyframes"] = correctedKeyFrames;
    j["fused_points"] = fusedPoints;
    j["essential_graph_edges"] = essentialGraphEdges;
    j["correction_outlier_ratio"] = correctionOutlierRatio;
  }
  if (withdrawn) j["withdrawn"] = true;
  if (closed) {
    j["global_ba_ms"] = globalBaMs;
    j["global_ba_asynchronous"] = globalBaAsynchronous;
    if (!globalBa.is_null()) j["global_ba"] = globalBa;
  }
  if (abortedGlobalBa) j["aborted_global_ba"] = true;
  return j;
}

LoopCloser::LoopCloser(map::Map& map, const LoopClosingParams& params, const optimize::BundleAdjustmentParams& ba,
                       std::uint32_t seed)
    : map_(map), params_(params), ba_(ba), rng_(seed) {
  params_.check();
}

LoopCloser::~LoopCloser() = default;  // a running global BA is waited for (std::future)

void LoopCloser::reset() {
  pending_.reset();  // waits for a running global BA; its result belongs to the old map
  stopped_.clear();  // and for the stopped ones
  database_.clear();
  groups_.clear();
  lastLoopKeyFrame_ = map::kNoKeyFrame;
  loopEdges_.clear();
}

std::string LoopCloser::serializeLoopEdges() const {
  std::vector<std::pair<KeyFrameId, KeyFrameId>> kept;
  for (const auto& e : loopEdges_)
    if (map_.hasKeyFrame(e.first) && map_.hasKeyFrame(e.second)) kept.push_back(e);
  ByteWriter w;
  w.put<std::uint64_t>(kept.size());
  for (const auto& [a, b] : kept) {
    w.put<std::uint64_t>(a);
    w.put<std::uint64_t>(b);
  }
  return w.take();
}

void LoopCloser::restoreLoopEdges(const std::string& bytes, const map::Map& map) {
  loopEdges_.clear();
  loopEdges_ = parseLoopEdges(bytes, map);
}

std::vector<std::pair<KeyFrameId, KeyFrameId>> LoopCloser::parseLoopEdges(const std::string& bytes,
                                                                          const map::Map& map) {
  ByteReader r(bytes, "loop edges");
  const std::uint64_t n = r.count("edge", bytes.size() / 16);
  std::vector<std::pair<KeyFrameId, KeyFrameId>> edges;
  for (std::uint64_t i = 0; i < n; ++i) {
    const auto a = r.get<std::uint64_t>("edge"), b = r.get<std::uint64_t>("edge");
    if (a == b || !map.hasKeyFrame(a) || !map.hasKeyFrame(b))
      r.fail("edge " + std::to_string(a) + " - " + std::to_string(b) + " does not join two keyframes of the map");
    edges.emplace_back(a, b);
  }
  if (!r.atEnd()) r.fail("unexpected bytes after the last edge");
  return edges;
}

bool LoopCloser::usablePoint(MapPointId id) const {
  return id != map::kNoMapPoint && map_.hasMapPoint(id) && !map_.mapPoint(id).bad;
}

std::vector<KeyFrameId> LoopCloser::detect(KeyFrameId kfId, LoopReport& report) {
  const KeyFrame& kf = map_.keyFrame(kfId);
  // The lowest similarity of the keyframe to its covisible neighbours: a loop candidate must look at least as
  // similar as the keyframe's own neighbourhood does.
  double minScore = 1.0;
  for (KeyFrameId n : map_.covisibleKeyFrames(kfId)) {
    const KeyFrame& nk = map_.keyFrame(n);
    if (!nk.bow.empty()) minScore = std::min(minScore, places::Vocabulary::score(kf.bow, nk.bow));
  }
  std::set<KeyFrameId> excluded{kfId};
  for (const auto& [n, w] : kf.sharedPoints) excluded.insert(n);
  const auto candidates = database_.loopCandidates(
      kf.bow, [&](places::KeyFrameKey k) { return map_.bestCovisibleKeyFrames(k, 10); }, excluded, minScore);
  report.candidates = static_cast<int>(candidates.size());
  // Covisibility consistency (ORB-SLAM): a candidate's group (it and its neighbours) must overlap a group of the
  // previous keyframes' candidates `consistency` times in a row.
  std::vector<Group> current;
  std::vector<KeyFrameId> consistent;
  std::vector<bool> continued(groups_.size(), false);
  for (const places::PlaceCandidate& c : candidates) {
    Group g;
    g.keyFrames.insert(c.keyFrame);
    for (KeyFrameId n : map_.covisibleKeyFrames(c.keyFrame)) g.keyFrames.insert(n);
    bool enough = false, consistentWithAny = false;
    for (std::size_t k = 0; k < groups_.size(); ++k) {
      const bool overlaps = std::any_of(g.keyFrames.begin(), g.keyFrames.end(),
                                        [&](KeyFrameId id) { return groups_[k].keyFrames.count(id) != 0; });
      if (!overlaps) continue;
      consistentWithAny = true;
      const int n = groups_[k].consistency + 1;
      if (!continued[k]) {
        current.push_back({g.keyFrames, n});
        continued[k] = true;
      }
      if (n >= params_.consistency && !enough) {
        consistent.push_back(c.keyFrame);
        enough = true;
      }
    }
    if (!consistentWithAny) current.push_back({g.keyFrames, 0});
  }
  groups_ = std::move(current);
  if (params_.consistency == 0)
    for (const auto& c : candidates) consistent.push_back(c.keyFrame);
  report.consistentCandidates = static_cast<int>(consistent.size());
  return consistent;
}

std::map<std::size_t, MapPointId> LoopCloser::searchByProjection(KeyFrameId kfId, const Sim3& S_cw,
                                                                 const std::vector<MapPointId>& points,
                                                                 const std::set<std::size_t>& taken,
                                                                 float radius) const {
  const KeyFrame& kf = map_.keyFrame(kfId);
  const Eigen::Vector3d centre = -(S_cw.R.transpose() * S_cw.t) / S_cw.s;
  std::map<std::size_t, std::pair<MapPointId, int>> best;  // keypoint -> (point, distance)
  std::set<MapPointId> inKf(kf.mapPointIds.begin(), kf.mapPointIds.end());
  for (MapPointId id : points) {
    if (!usablePoint(id) || inKf.count(id)) continue;
    const map::MapPoint& p = map_.mapPoint(id);
    const Eigen::Vector3d X = map_.worldPosition(id);
    const Eigen::Vector3d pc = S_cw.map(X);
    if (pc.z() <= 0) continue;
    const Eigen::Vector2d uv = kf.camera.project(pc);
    if (!kf.camera.inImage(uv)) continue;
    const Eigen::Vector3d po = X - centre;
    const double dist = po.norm();
    if (dist < 0.8 * p.minDistance || dist > 1.2 * p.maxDistance) continue;
    if (p.normal.norm() > 0 && po.dot(p.normal) < 0.5 * dist) continue;
    const int level = map_.predictScale(id, dist, kfId);
    const double r = radius * kf.scaleFactors.at(static_cast<std::size_t>(std::clamp(level, 0, kf.numLevels() - 1)));
    int bestDist = 257;
    std::size_t bestK = 0;
    for (std::size_t k = 0; k < kf.numKeypoints(); ++k) {
      if (taken.count(k)) continue;
      const cv::KeyPoint& kp = kf.keypoints[k];
      if (kp.octave < level - 1 || kp.octave > level) continue;
      const double dx = kp.pt.x - uv.x(), dy = kp.pt.y - uv.y();
      if (dx * dx + dy * dy > r * r) continue;
      const int d = features::hammingDistance256(p.descriptor.ptr<std::uint8_t>(0),
                                                 kf.descriptors.ptr<std::uint8_t>(static_cast<int>(k)));
      if (d < bestDist) {
        bestDist = d;
        bestK = k;
      }
    }
    if (bestDist > features::kOrbThLow) continue;
    const auto it = best.find(bestK);
    if (it == best.end() || bestDist < it->second.second) best[bestK] = {id, bestDist};
  }
  std::map<std::size_t, MapPointId> out;
  for (const auto& [k, pd] : best) out[k] = pd.first;
  return out;
}

bool LoopCloser::verify(KeyFrameId kfId, KeyFrameId candId, Sim3& S_cw, std::map<std::size_t, MapPointId>& loopMatches,
                        LoopReport::Verification& v) {
  const KeyFrame& kf = map_.keyFrame(kfId);
  const KeyFrame& cand = map_.keyFrame(candId);
  places::NodeMatchParams np;
  np.ratio = 0.75f;
  const auto matches = places::matchByVocabularyNode(
      kf.bowFeatures, kf.descriptors, kf.keypoints, cand.bowFeatures, cand.descriptors, cand.keypoints, np,
      [&](std::size_t i) { return usablePoint(kf.mapPointIds[i]); },
      [&](std::size_t j) { return usablePoint(cand.mapPointIds[j]); });
  v.bowMatches = static_cast<int>(matches.size());
  if (v.bowMatches < params_.minBowMatches) return false;
  std::vector<geometry::Sim3Correspondence> corr;
  for (const auto& m : matches) {
    const auto i = static_cast<std::size_t>(m.i1), j = static_cast<std::size_t>(m.i2);
    geometry::Sim3Correspondence c;
    c.p1 = kf.T_cam_world * map_.worldPosition(kf.mapPointIds[i]);
    c.p2 = cand.T_cam_world * map_.worldPosition(cand.mapPointIds[j]);
    c.px1 = kf.pixel(i);
    c.px2 = cand.pixel(j);
    c.sigma2_1 = kf.levelSigma2.at(static_cast<std::size_t>(kf.keypoints[i].octave));
    c.sigma2_2 = cand.levelSigma2.at(static_cast<std::size_t>(cand.keypoints[j].octave));
    corr.push_back(c);
  }
  geometry::Sim3RansacParams rp;
  rp.minInliers = params_.minSim3Inliers;
  const geometry::Sim3RansacResult r = geometry::estimateSim3Ransac(corr, kf.camera.K(), cand.camera.K(), rp, rng_);
  v.sim3Inliers = r.numInliers;
  if (!r.success) return false;
  // The keyframe's corrected pose: the candidate's pose carried over by the estimated similarity.
  S_cw = r.S12 * Sim3::fromIsometry(cand.T_cam_world);
  std::set<std::size_t> taken;
  loopMatches.clear();
  for (std::size_t k = 0; k < matches.size(); ++k)
    if (r.inliers[k]) {
      loopMatches[static_cast<std::size_t>(matches[k].i1)] = cand.mapPointIds[static_cast<std::size_t>(matches[k].i2)];
      taken.insert(static_cast<std::size_t>(matches[k].i1));
    }
  // The points of the candidate's neighbourhood, projected with S_cw (ORB-SLAM: radius 10).
  std::set<MapPointId> loopPoints;
  std::vector<KeyFrameId> neighbourhood = map_.covisibleKeyFrames(candId);
  neighbourhood.push_back(candId);
  for (KeyFrameId n : neighbourhood)
    for (MapPointId p : map_.pointsOf(n)) loopPoints.insert(p);
  const auto projected =
      searchByProjection(kfId, S_cw, std::vector<MapPointId>(loopPoints.begin(), loopPoints.end()), taken, 10.f);
  for (const auto& [k, p] : projected) loopMatches[k] = p;
  v.loopMatches = static_cast<int>(loopMatches.size());
  return v.loopMatches >= params_.minLoopMatches;
}

double outlierRatio(const map::Map& map, KeyFrameId firstKeyFrame, double chi2) {
  std::set<MapPointId> points;
  for (auto it = map.keyFrames().lower_bound(firstKeyFrame); it != map.keyFrames().end(); ++it)
    for (MapPointId id : it->second.mapPointIds)
      if (id != map::kNoMapPoint && map.hasMapPoint(id) && !map.mapPoint(id).bad) points.insert(id);
  std::map<KeyFrameId, geometry::PinholeCamera> cameras;
  const auto cameraOf = [&](const KeyFrame& kf) -> const geometry::PinholeCamera& {
    const geometry::PinholeCamera& c = kf.camera;
    return cameras.try_emplace(kf.id, c.fx, c.fy, c.cx, c.cy, c.width, c.height).first->second;
  };
  constexpr double kHuberDelta = 2.448;  // Table 3.2 delta_R
  std::size_t total = 0, outliers = 0;
  for (MapPointId id : points) {
    const map::MapPoint& point = map.mapPoint(id);
    // The point refit to all its observations, poses fixed: Gauss-Newton with Huber weights from where it is.
    Eigen::Vector3d X = map.worldPosition(id);
    // (A point seen once has no depth to refit: it stays.)
    const int iterations = point.observations.size() >= 2 ? 5 : 0;
    for (int iteration = 0; iteration < iterations; ++iteration) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      for (const auto& [kfId, k] : point.observations) {
        const KeyFrame& kf = map.keyFrame(kfId);
        const Eigen::Vector3d p = kf.T_cam_world * X;
        if (!(p.z() > 0)) continue;
        Eigen::Matrix<double, 2, 3> J_p;
        const Eigen::Vector2d r = cameraOf(kf).project(p, J_p) - kf.pixel(k);
        const double w = kf.invSigma2(k), e = std::sqrt(r.squaredNorm() * w);
        const double huber = e <= kHuberDelta ? 1.0 : kHuberDelta / e;
        const Eigen::Matrix<double, 2, 3> J = J_p * kf.T_cam_world.linear();
        H += huber * w * J.transpose() * J;
        g += huber * w * J.transpose() * r;
      }
      const Eigen::Vector3d step = H.ldlt().solve(-g);
      if (!step.allFinite()) break;
      X += step;
    }
    for (const auto& [kfId, k] : point.observations) {
      if (kfId < firstKeyFrame) continue;
      const KeyFrame& kf = map.keyFrame(kfId);
      const Eigen::Vector3d p = kf.T_cam_world * X;
      ++total;
      if (!(p.z() > 0) || (kf.pixel(k) - kf.camera.project(p)).squaredNorm() * kf.invSigma2(k) > chi2) ++outliers;
    }
  }
  return total > 0 ? double(outliers) / double(total) : 0.0;
}

std::map<KeyFrameId, Eigen::Isometry3d> LoopCloser::correct(KeyFrameId kfId, KeyFrameId matched,
                                                           const Sim3& S_cw_corrected,
                                                           const std::map<std::size_t, MapPointId>& loopMatches,
                                                           LoopReport& report) {
  std::map<KeyFrameId, Eigen::Isometry3d> posesBefore;
  for (const auto& [id, kf] : map_.keyFrames()) posesBefore[id] = kf.T_cam_world;
  // 1. The keyframe's neighbourhood moves with it: S_iw corrected = S_ic S_cw (ORB-SLAM's CorrectLoop).
  std::vector<KeyFrameId> connected = map_.covisibleKeyFrames(kfId);
  connected.insert(connected.begin(), kfId);
  const Eigen::Isometry3d T_wc = map_.keyFrame(kfId).T_world_cam();
  std::map<KeyFrameId, Sim3> corrected, nonCorrected;
  for (KeyFrameId id : connected) {
    const Eigen::Isometry3d T_iw = map_.keyFrame(id).T_cam_world;
    nonCorrected[id] = Sim3::fromIsometry(T_iw);
    corrected[id] = id == kfId ? S_cw_corrected : Sim3::fromIsometry(T_iw * T_wc) * S_cw_corrected;
  }
  const Eigen::Vector3d oldCentre = map_.keyFrame(kfId).cameraCenter();
  // Points seen by the neighbourhood: carried by the first keyframe of it that sees them.
  std::map<MapPointId, KeyFrameId> correctedBy;
  std::map<MapPointId, Eigen::Vector3d> newPosition;
  for (KeyFrameId id : connected)
    for (MapPointId p : map_.pointsOf(id))
      if (correctedBy.emplace(p, id).second)
        newPosition[p] = corrected[id].inverse().map(nonCorrected[id].map(map_.worldPosition(p)));
  // Poses first: a point's world position is stored relative to its anchor keyframe.
  for (KeyFrameId id : connected) map_.setKeyFramePose(id, corrected[id].toIsometryUnscaled());
  for (const auto& [p, X] : newPosition) map_.setWorldPosition(p, X);
  report.correctedKeyFrames = static_cast<int>(connected.size());
  report.correctionMetres = (map_.keyFrame(kfId).cameraCenter() - oldCentre).norm();

  // 2. Loop fusion: the keyframe's matched keypoints take the loop's points (duplicates fused into them), then the
  // loop points are projected into every corrected neighbour and fused there too.
  const std::map<KeyFrameId, std::vector<KeyFrameId>> neighboursBefore = [&] {
    std::map<KeyFrameId, std::vector<KeyFrameId>> m;
    for (KeyFrameId id : connected) m[id] = map_.covisibleKeyFrames(id);
    return m;
  }();
  auto bind = [&](KeyFrameId id, std::size_t k, MapPointId loopPoint) {
    if (!usablePoint(loopPoint)) return;
    const MapPointId own = map_.keyFrame(id).mapPointIds[k];
    if (own == loopPoint) return;
    if (own != map::kNoMapPoint && map_.hasMapPoint(own)) {
      map_.fuseMapPoints(loopPoint, own);
    } else {
      if (map_.mapPoint(loopPoint).observations.count(id)) return;  // seen by another keypoint of id already
      map_.addObservation(loopPoint, id, k);
      map_.computeDistinctiveDescriptor(loopPoint);
      map_.updateNormalAndDepth(loopPoint);
    }
    ++report.fusedPoints;
  };
  for (const auto& [k, p] : loopMatches) bind(kfId, k, p);
  std::set<MapPointId> loopPoints;
  std::vector<KeyFrameId> loopNeighbourhood = map_.covisibleKeyFrames(matched);
  loopNeighbourhood.push_back(matched);
  for (KeyFrameId n : loopNeighbourhood)
    if (!std::count(connected.begin(), connected.end(), n))
      for (MapPointId p : map_.pointsOf(n)) loopPoints.insert(p);
  const std::vector<MapPointId> loopPointList(loopPoints.begin(), loopPoints.end());
  for (KeyFrameId id : connected) {
    if (!map_.hasKeyFrame(id)) continue;
    const auto found = searchByProjection(id, corrected[id], loopPointList, {}, 4.f);  // ORB-SLAM: radius 4
    for (const auto& [k, p] : found) bind(id, k, p);
  }

  // 3. Loop connections: neighbours each corrected keyframe gained by the fusion.
  std::vector<std::pair<KeyFrameId, KeyFrameId>> newEdges{{kfId, matched}};
  for (KeyFrameId id : connected) {
    if (!map_.hasKeyFrame(id)) continue;
    const auto& before = neighboursBefore.at(id);
    for (KeyFrameId n : map_.covisibleKeyFrames(id))
      if (!std::count(before.begin(), before.end(), n) && !std::count(connected.begin(), connected.end(), n))
        newEdges.emplace_back(id, n);
  }

  // 4. Essential graph over Sim(3): vertices at the corrected (neighbourhood) or current poses; edges measured on
  // the poses before the correction (spanning tree, covisibility >= essentialGraphMinWeight, earlier loop edges),
  // and on the corrected ones for the new loop connections. The matched keyframe is held fixed.
  std::map<std::uint64_t, Sim3> vertices;
  for (const auto& [id, kf] : map_.keyFrames()) {
    const auto c = corrected.find(id);
    vertices[id] = c != corrected.end() ? c->second : Sim3::fromIsometry(kf.T_cam_world);
  }
  auto before = [&](KeyFrameId id) {
    const auto nc = nonCorrected.find(id);
    return nc != nonCorrected.end() ? nc->second : Sim3::fromIsometry(map_.keyFrame(id).T_cam_world);
  };
  std::vector<optimize::PoseGraphEdge> edges;
  std::set<std::pair<KeyFrameId, KeyFrameId>> have;
  auto addEdge = [&](KeyFrameId i, KeyFrameId j, const Sim3& S_iw, const Sim3& S_jw) {
    if (i == j || !map_.hasKeyFrame(i) || !map_.hasKeyFrame(j)) return;
    if (!have.insert({std::min(i, j), std::max(i, j)}).second) return;
    edges.push_back({i, j, S_iw * S_jw.inverse(), 1.0});
  };
  for (const auto& [i, j] : newEdges)
    if (map_.hasKeyFrame(i) && map_.hasKeyFrame(j) &&
        ((i == kfId && j == matched) || map_.covisibilityWeight(i, j) >= params_.essentialGraphMinWeight))
      addEdge(i, j, vertices[i], vertices[j]);
  for (const auto& [i, j] : loopEdges_) addEdge(i, j, before(i), before(j));
  for (const auto& [id, kf] : map_.keyFrames()) {
    if (kf.parent != map::kNoKeyFrame) addEdge(id, kf.parent, before(id), before(kf.parent));
    for (KeyFrameId n : map_.covisibleKeyFrames(id, params_.essentialGraphMinWeight))
      if (n < id) addEdge(id, n, before(id), before(n));
  }
  report.essentialGraphEdges = static_cast<int>(edges.size());
  const std::map<std::uint64_t, Sim3> initial = vertices;
  optimize::PoseGraphParams pg;
  pg.maxIterations = params_.essentialGraphIterations;
  optimize::optimizeSim3PoseGraph(vertices, {matched}, edges, pg);
  // Points follow the keyframe that carried them (the corrected one, else their anchor).
  std::map<MapPointId, Eigen::Vector3d> moved;
  for (const auto& [p, point] : map_.mapPoints()) {
    const auto by = correctedBy.find(p);
    const KeyFrameId ref = by != correctedBy.end() && map_.hasKeyFrame(by->second) ? by->second : point.anchorKeyFrame;
    moved[p] = vertices.at(ref).inverse().map(initial.at(ref).map(map_.worldPosition(p)));
  }
  for (const auto& [id, S] : vertices) {
    map_.setKeyFramePose(id, S.toIsometryUnscaled());
    report.keyFrameScales[id] = S.s;
  }
  map_.rescaleErasedKeyFrameLinks(report.keyFrameScales);
  for (const auto& [p, X] : moved) {
    map_.setWorldPosition(p, X);
    map_.updateNormalAndDepth(p);
  }
  return posesBefore;
}

void LoopCloser::globalBundleAdjustment(const std::map<KeyFrameId, Eigen::Isometry3d>& posesBeforeCorrection,
                                        LoopReport& report) {
  auto moved = [&](const LoopReport& r, const std::map<KeyFrameId, Eigen::Isometry3d>& before) {
    if (keyFramesMoved_) keyFramesMoved_(r, before);
  };
  if (params_.globalBAIterations <= 0) {
    moved(report, posesBeforeCorrection);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (!asynchronousGlobalBa_) {
    // optimize::globalBundleAdjustment(map_, ...) spelled out, to report on the problem it solved.
    const optimize::BAProblem problem = optimize::makeGlobalProblem(map_);
    const optimize::BAResult result = optimize::globalBundleAdjustment(problem, globalBaParams());
    optimize::applyResult(map_, problem, result, false);
    report.globalBa = globalBaSummary(result, problem.observations.size());
    report.globalBaMs = msSince(t0);
    moved(report, posesBeforeCorrection);
    return;
  }
  // Threaded: tracking and local mapping go on in the corrected map while the BA runs on a copy of it (ORB-SLAM's
  // RunGlobalBundleAdjustment), so they learn of the correction now.
  moved(report, posesBeforeCorrection);
  startGlobalBundleAdjustment(report.keyFrame);
  report.globalBaAsynchronous = true;
  report.globalBaMs = msSince(t0);
}

nlohmann::json LoopCloser::globalBaSummary(const optimize::BAResult& result, std::size_t observations) {
  return {{"iterations", result.iterations},
          {"stopped", result.stopped},
          {"rms_px_before", result.initialRmsPixels},
          {"rms_px_after", result.finalRmsPixels},
          {"observations", observations},
          {"outliers", result.outliers.size()}};
}

optimize::BundleAdjustmentParams LoopCloser::globalBaParams() const {
  optimize::BundleAdjustmentParams ba = ba_;
  ba.globalIterations = std::max(params_.globalBAIterations, 1);
  return ba;
}

void LoopCloser::startGlobalBundleAdjustment(KeyFrameId loopKeyFrame) {
  require(asynchronousGlobalBa_, "loop closing", "startGlobalBundleAdjustment needs setAsynchronousGlobalBa");
  require(!pending_, "loop closing", "a global BA is already running");
  reapStoppedGlobalBas();
  const optimize::BundleAdjustmentParams ba = globalBaParams();
  pending_ = std::make_unique<PendingGlobalBa>();
  PendingGlobalBa* job = pending_.get();
  job->problem = optimize::makeGlobalProblem(map_);
  job->loopKeyFrame = loopKeyFrame;
  job->started = std::chrono::steady_clock::now();
  const std::function<void()> ready = globalBaReady_;
  // The job owns the copy; the thread reads only it. pending_ (and so the future) outlives the thread: reset(),
  // the destructor and applyGlobalBundleAdjustment() all wait for it.
  job->result = std::async(std::launch::async, [job, ba, ready] {
    optimize::BAResult r = optimize::globalBundleAdjustment(job->problem, ba, &job->stop);
    job->done = true;
    if (ready && !job->stop.load()) ready();  // a stopped BA is dropped: nobody waits for it
    return r;
  });
}

bool LoopCloser::abortGlobalBundleAdjustment() {
  if (!pending_) return false;
  pending_->stop = true;
  stopped_.push_back(std::move(pending_));  // joined later: waiting here would hold the map lock for an iteration
  return true;
}

void LoopCloser::reapStoppedGlobalBas() {
  stopped_.erase(std::remove_if(stopped_.begin(), stopped_.end(), [](const auto& job) { return job->done.load(); }),
                 stopped_.end());
}

std::optional<nlohmann::json> LoopCloser::applyGlobalBundleAdjustment() {
  reapStoppedGlobalBas();
  if (!pending_) return std::nullopt;
  const std::unique_ptr<PendingGlobalBa> job = std::move(pending_);
  const optimize::BAResult result = job->result.get();
  const auto t0 = std::chrono::steady_clock::now();
  std::map<KeyFrameId, Eigen::Isometry3d> before;
  for (const auto& [id, kf] : map_.keyFrames()) before[id] = kf.T_cam_world;
  int keyFramesSet = 0, keyFramesCulled = 0, keyFramesFollowed = 0, pointsSet = 0, pointsSkipped = 0;
  int pointsAtInfinity = 0;
  for (const auto& [id, T] : result.poses) {
    if (!map_.hasKeyFrame(id)) {
      ++keyFramesCulled;
      continue;
    }
    map_.setKeyFramePose(id, T);
    ++keyFramesSet;
  }
  for (const auto& [id, kf] : map_.keyFrames()) {  // ascending ids: a parent is settled before its children
    if (job->problem.keyframes.count(id) || kf.parent == map::kNoKeyFrame || !map_.hasKeyFrame(kf.parent)) continue;
    const Eigen::Isometry3d T_child_parent = before.at(id) * before.at(kf.parent).inverse();
    map_.setKeyFramePose(id, T_child_parent * map_.keyFrame(kf.parent).T_cam_world);
    ++keyFramesFollowed;
  }
  for (const auto& [id, rho] : result.inverseDepths) {
    // A point keeps its anchor-relative inverse depth; one fused away or re-anchored since the copy is left as it
    // is, and so is one the BA put at or behind its anchor's infinity.
    if (!map_.hasMapPoint(id) || map_.mapPoint(id).anchorKeyFrame != job->problem.points.at(id).anchor) {
      ++pointsSkipped;
      continue;
    }
    if (!optimize::isFiniteInverseDepth(rho)) {
      ++pointsAtInfinity;
      continue;
    }
    map_.setInverseDepth(id, rho);
    ++pointsSet;
  }
  for (const auto& [id, p] : map_.mapPoints()) map_.updateNormalAndDepth(id);
  LoopReport unscaled;
  unscaled.keyFrame = job->loopKeyFrame;
  for (const auto& [id, T] : before) unscaled.keyFrameScales[id] = 1.0;
  if (keyFramesMoved_) keyFramesMoved_(unscaled, before);
  const auto now = std::chrono::steady_clock::now();
  return nlohmann::json{{"loop_keyframe", job->loopKeyFrame},
                        {"global_ba_ms", std::chrono::duration<double, std::milli>(now - job->started).count()},
                        {"apply_ms", std::chrono::duration<double, std::milli>(now - t0).count()},
                        {"keyframes_set", keyFramesSet},
                        {"keyframes_culled_meanwhile", keyFramesCulled},
                        {"keyframes_made_meanwhile", keyFramesFollowed},
                        {"points_set", pointsSet},
                        {"points_fused_or_reanchored_meanwhile", pointsSkipped},
                        {"points_left_at_non_positive_inverse_depth", pointsAtInfinity},
                        {"solver", globalBaSummary(result, job->problem.observations.size())}};
}

LoopReport LoopCloser::processKeyFrame(KeyFrameId kfId) {
  const auto t0 = std::chrono::steady_clock::now();
  LoopReport report;
  report.keyFrame = kfId;
  for (const places::KeyFrameKey id : database_.keyFrames())
    if (!map_.hasKeyFrame(id)) database_.erase(id);
  if (!params_.enabled || !map_.hasKeyFrame(kfId) || map_.keyFrame(kfId).bow.empty()) return report;
  const bool tooEarly = static_cast<int>(map_.numKeyFrames()) < params_.minMapKeyFrames ||
                        (lastLoopKeyFrame_ != map::kNoKeyFrame &&
                         kfId < lastLoopKeyFrame_ + static_cast<KeyFrameId>(params_.minKeyFramesBetweenLoops));
  std::vector<KeyFrameId> consistent;
  if (!tooEarly) consistent = detect(kfId, report);
  database_.add(kfId, map_.keyFrame(kfId).bow);
  for (KeyFrameId cand : consistent) {
    LoopReport::Verification v;
    v.candidate = cand;
    Sim3 S_cw;
    std::map<std::size_t, MapPointId> loopMatches;
    const bool ok = verify(kfId, cand, S_cw, loopMatches, v);
    report.verified.push_back(v);
    if (!ok) continue;
    report.matchedKeyFrame = cand;
    report.scale = S_cw.s;
    // A false loop passes the Sim(3) and projection tests when its places look alike (repeated textures), but
    // once corrected the map bends against its own measurements: with their points refit, a true loop's keyframes
    // leave a few % of their observations failing the chi-square test, a false loop's a third or more
    // (doc/places.md). The map before the correction is kept to be put back then; nobody else has seen it yet.
    std::optional<map::Map> before;
    if (params_.maxCorrectionOutlierRatio < 1.0) before.emplace(map_);
    const std::map<KeyFrameId, Eigen::Isometry3d> posesBefore = correct(kfId, cand, S_cw, loopMatches, report);
    report.correctionOutlierRatio = outlierRatio(map_, cand, params_.correctionChi2);
    if (before && report.correctionOutlierRatio > params_.maxCorrectionOutlierRatio) {
      map_ = std::move(*before);
      report.withdrawn = true;
      report.keyFrameScales.clear();
      groups_.clear();  // the same candidate must be consistent over `consistency` keyframes again
      break;
    }
    // Threaded: the previous loop's global BA still runs on a copy of the map that lacks this correction; it is
    // stopped and dropped, and this loop's global BA replaces it (ORB-SLAM's RunGlobalBundleAdjustment abort).
    report.abortedGlobalBa = abortGlobalBundleAdjustment();
    report.closed = true;
    loopEdges_.emplace_back(kfId, cand);
    // 5. Global BA refines everything.
    globalBundleAdjustment(posesBefore, report);
    lastLoopKeyFrame_ = kfId;
    groups_.clear();
    break;
  }
  report.ms = msSince(t0);
  return report;
}

}  // namespace pslam::loopclosing
