// ORB-SLAM's LocalMapping::Run for one keyframe (thesis §2.4.1, §3.4.3). Step order and constants follow
// ORB-SLAM2's LocalMapping.cc / ORBmatcher.cc (monocular); differences are listed in doc/mapping.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include <Eigen/Dense>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/features/FeatureGrid.h"
#include "pslam/features/Matching.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/geometry/Triangulation.h"
#include "pslam/landmarks/MeasurementVariance.h"
#include "pslam/mapping/LocalMapper.h"

#include "pslam/map/KeyFrameCulling.h"

namespace pslam::mapping {

using map::KeyFrame;
using map::KeyFrameId;
using map::MapPoint;
using map::MapPointId;

namespace {

using Clock = std::chrono::steady_clock;

/// Median z of the keyframe's points in its own camera (ORB-SLAM ComputeSceneMedianDepth(2)); -1 if none.
double sceneMedianDepth(const map::Map& map, const KeyFrame& kf) {
  std::vector<double> z;
  for (MapPointId p : kf.mapPointIds)
    if (p != map::kNoMapPoint) z.push_back((kf.T_cam_world * map.worldPosition(p)).z());
  if (z.empty()) return -1.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

/// Keeps only the matches whose rotation bin is one of the three most populated (ORB-SLAM).
template <typename Match>
std::vector<Match> filterByRotation(const std::vector<Match>& matches, const std::vector<int>& bins) {
  std::vector<Match> kept;
  for (std::size_t i : features::inLargestRotationBins(bins)) kept.push_back(matches[i]);
  return kept;
}

}  // namespace

struct LocalMapper::Impl {
  /// The map-point model of params.pointModel.policy (keypoint-model updates read its KeypointModel).
  std::shared_ptr<const MapPointModelPolicy> modelPolicy;
  /// What culling and the BA window ask: modelPolicy unless the caller supplied its own.
  std::shared_ptr<const map::PointUsePolicy> usePolicy;
};

LocalMapper::LocalMapper(map::Map& map, const LocalMappingParams& params,
                         std::shared_ptr<const map::PointUsePolicy> pointUsePolicy)
    : map_(map), params_(params), impl_(std::make_unique<Impl>()) {
  params_.check();
  impl_->modelPolicy = std::make_shared<MapPointModelPolicy>(params_.pointModel, params_.depthPixelNoise);
  impl_->usePolicy = pointUsePolicy ? std::move(pointUsePolicy) : impl_->modelPolicy;
}

LocalMapper::~LocalMapper() = default;

void LocalMapper::reset() { recent_.clear(); }

landmarks::MapPointModel LocalMapper::model() const { return params_.pointModel.policy.model; }

bool LocalMapper::isActive(MapPointId point) const { return impl_->usePolicy->mayUse(map_.mapPoint(point)); }

std::shared_ptr<const map::PointUsePolicy> LocalMapper::pointUsePolicy() const { return impl_->usePolicy; }

// ------------------------------------------------------------------------------------ probabilistic hook

/// Updates the keypoint model of `pointId` with its observation in keyframe `kfId` (§3.4.2, see
/// MapPointModelPolicy::observe); the anchor's own observation carries no depth, only its class evidence.
/// Returns true if a depth update was applied.
static bool updateLandmarkState(map::Map& map, const MapPointModelPolicy& policy, MapPointId pointId, KeyFrameId kfId) {
  MapPoint& p = map.mutableMapPoint(pointId);
  const KeyFrame& kf = map.keyFrame(kfId);
  const std::size_t k = p.observations.at(kfId);
  const std::array<float, 3>* classes = kf.semanticProbabilities.empty() ? nullptr : &kf.semanticProbabilities.at(k);
  if (kfId != p.anchorKeyFrame) {
    map::PointMeasurement m;
    m.T_cam_world = kf.T_cam_world;
    m.camera = kf.camera;
    m.pixel = kf.pixel(k);
    if (!kf.descriptors.empty()) m.descriptor = kf.descriptors.row(static_cast<int>(k));
    m.classProbabilities = classes;
    return policy.observe(map, p, m);
  }
  // The anchor's class evidence, once; without any (no semantics) only a point without a stored state gets one.
  landmarks::KeypointState state = policy.stateOf(p);
  const std::optional<landmarks::ClassVector> evidence = policy.classEvidence(classes);
  if (state.semanticUpdates == 0 && (evidence || p.landmarkState.empty())) {
    policy.keypointModel().addSemanticObservation(state, evidence, 1.0);
    p.landmarkState = encodeKeypointState(state);
  }
  return false;
}

// ------------------------------------------------------------------------------------ 1. ProcessNewKeyFrame

void LocalMapper::processNewKeyFrame(KeyFrameId kfId, const std::vector<MapPointId>& recentlyAddedByTracking,
                                     bool measuredByTracking) {
  if (!map_.hasKeyFrame(kfId)) throw Error("LocalMapper: keyframe " + std::to_string(kfId) + " is not in the map");
  for (MapPointId id : map_.pointsOf(kfId)) {
    if (map_.mapPoint(id).bad) continue;
    // The model update first: alpha compares the keypoint with the descriptor the tracker matched against.
    // A keyframe the tracker measured (Tracker::track updates every point it matched) is not counted twice.
    if (model() != landmarks::MapPointModel::Heuristic && !measuredByTracking &&
        updateLandmarkState(map_, *impl_->modelPolicy, id, kfId))
      ++landmarkUpdates_;
    map_.updateNormalAndDepth(id);
    map_.computeDistinctiveDescriptor(id);
  }
  // Covisibility weights are kept by Map::addObservation; the spanning tree link is made once.
  map_.connectToSpanningTree(kfId);
  std::set<MapPointId> recent(recent_.begin(), recent_.end());
  for (MapPointId id : recentlyAddedByTracking)
    if (map_.hasMapPoint(id)) recent.insert(id);
  recent_.assign(recent.begin(), recent.end());
}

// ------------------------------------------------------------------------------------ 2. MapPointCulling

int LocalMapper::cullRecentPoints(KeyFrameId kfId, int* byInlierRatio) {
  int culled = 0;
  if (byInlierRatio) *byInlierRatio = 0;
  const auto current = static_cast<std::int64_t>(kfId);
  std::vector<MapPointId> stillRecent;
  for (MapPointId id : recent_) {
    if (!map_.hasMapPoint(id)) continue;  // fused or erased meanwhile
    const MapPoint& p = map_.mapPoint(id);
    const bool cull = impl_->usePolicy->shouldCull(p, kfId);
    if (cull) {
      map_.eraseMapPoint(id);
      ++culled;
      continue;
    }
    // ORB-SLAM: a point that survived three keyframes leaves probation.
    if (current - static_cast<std::int64_t>(p.firstKeyFrame) >= params_.pointModel.policy.observationWindow + 1) continue;
    stillRecent.push_back(id);
  }
  recent_ = std::move(stillRecent);
  // Probabilistic model: phi needs several depth updates (cullMinDepthUpdates) before the policy may cull, more
  // than ORB-SLAM's three-keyframe probation, so every point the keyframe just measured is checked by the
  // model's own rule as well (ORB-SLAM's rules stay with the recent points).
  if (model() == landmarks::MapPointModel::Probabilistic && map_.hasKeyFrame(kfId))
    for (MapPointId id : map_.pointsOf(kfId)) {
      if (!map_.hasMapPoint(id)) continue;
      const MapPoint& p = map_.mapPoint(id);
      if (p.bad || impl_->modelPolicy->inlierRatioSaysCull(p)) {
        map_.eraseMapPoint(id);
        ++culled;
        if (byInlierRatio) ++*byInlierRatio;
      }
    }
  return culled;
}

// ------------------------------------------------------------------------------------ 3. CreateNewMapPoints

namespace {

/// Keypoints of one keyframe binned in square cells, to list those that may lie within `halfWidth` pixels of a
/// line: the cells of every column (or row, for a steep line) between the line's values at the column's edges,
/// widened by the half-width measured along the axis. Conservative: it never leaves out a keypoint within the
/// band; the exact band test is still applied to each candidate. The keypoints are stored cell by cell (order()),
/// so a crossed cell is one contiguous range of positions.
class EpipolarBandGrid {
 public:
  EpipolarBandGrid(const std::vector<double>& xs, const std::vector<double>& ys, double halfWidth)
      : halfWidth_(halfWidth + 1.0) {  // + 1 px against rounding at the cell edges
    if (xs.empty()) return;
    x0_ = *std::min_element(xs.begin(), xs.end());
    y0_ = *std::min_element(ys.begin(), ys.end());
    const double x1 = *std::max_element(xs.begin(), xs.end()), y1 = *std::max_element(ys.begin(), ys.end());
    cols_ = static_cast<int>((x1 - x0_) / kCell) + 1;
    rows_ = static_cast<int>((y1 - y0_) / kCell) + 1;
    // Counting sort by cell (stable: ascending indices within a cell).
    std::vector<std::size_t> cellOf(xs.size());
    cellStart_.assign(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_) + 1, 0);
    for (std::size_t n = 0; n < xs.size(); ++n) {
      cellOf[n] = cellIndex(colOf(xs[n]), rowOf(ys[n]));
      ++cellStart_[cellOf[n] + 1];
    }
    for (std::size_t c = 1; c < cellStart_.size(); ++c) cellStart_[c] += cellStart_[c - 1];
    order_.resize(xs.size());
    std::vector<std::size_t> next(cellStart_.begin(), cellStart_.end() - 1);
    for (std::size_t n = 0; n < xs.size(); ++n) order_[next[cellOf[n]]++] = n;
  }

  /// The keypoint indices, cell by cell.
  const std::vector<std::size_t>& order() const { return order_; }

  /// Calls visit(begin, end) for every cell the band around the line a x + b y + c = 0 crosses (each cell once):
  /// its keypoints are order()[begin, end).
  template <class Visit>
  void forEachCrossedCell(const Eigen::Vector3d& line, Visit&& visit) const {
    if (order_.empty()) return;
    const double a = line.x(), b = line.y(), c = line.z();
    const double norm = std::hypot(a, b);
    if (!(norm > 0.0)) return;
    const auto cell = [&](int col, int row) {
      const std::size_t k = cellIndex(col, row);
      if (cellStart_[k] != cellStart_[k + 1]) visit(cellStart_[k], cellStart_[k + 1]);
    };
    if (std::abs(b) >= std::abs(a)) {  // y = -(a x + c) / b over each column
      const double widen = halfWidth_ * norm / std::abs(b);
      for (int col = 0; col < cols_; ++col) {
        const double xa = x0_ + col * kCell, xb = xa + kCell;
        const double ya = -(a * xa + c) / b, yb = -(a * xb + c) / b;
        const int r0 = std::max(0, rowOf(std::min(ya, yb) - widen)), r1 = std::min(rows_ - 1, rowOf(std::max(ya, yb) + widen));
        for (int row = r0; row <= r1; ++row) cell(col, row);
      }
    } else {  // x = -(b y + c) / a over each row
      const double widen = halfWidth_ * norm / std::abs(a);
      for (int row = 0; row < rows_; ++row) {
        const double ya = y0_ + row * kCell, yb = ya + kCell;
        const double xa = -(b * ya + c) / a, xb = -(b * yb + c) / a;
        const int c0 = std::max(0, colOf(std::min(xa, xb) - widen)), c1 = std::min(cols_ - 1, colOf(std::max(xa, xb) + widen));
        for (int col = c0; col <= c1; ++col) cell(col, row);
      }
    }
  }

 private:
  static constexpr double kCell = 32.0;  // pixels (16 and 64 were slower on KITTI 00)
  int colOf(double x) const {
    const double v = std::floor((x - x0_) / kCell);
    return v < 0 ? -1 : (v >= cols_ ? cols_ : static_cast<int>(v));
  }
  int rowOf(double y) const {
    const double v = std::floor((y - y0_) / kCell);
    return v < 0 ? -1 : (v >= rows_ ? rows_ : static_cast<int>(v));
  }
  std::size_t cellIndex(int col, int row) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(cols_) + static_cast<std::size_t>(col);
  }
  double halfWidth_, x0_ = 0, y0_ = 0;
  int cols_ = 0, rows_ = 0;
  std::vector<std::size_t> cellStart_;  ///< cell k's keypoints are order_[cellStart_[k], cellStart_[k + 1])
  std::vector<std::size_t> order_;
};

/// A candidate partner of one kf1 keypoint: a free kf2 keypoint j in its epipolar band, far enough from the
/// epipole, at descriptor distance `dist`.
struct TriangulationCandidate {
  int dist = 0;
  std::uint32_t j = 0;
};

/// The candidates of a run of kf1 keypoints, each keypoint's sorted by (distance, kf2 index).
struct CandidateChunk {
  std::vector<std::size_t> keypoints;         ///< kf1 keypoints of the chunk, ascending
  std::vector<std::uint32_t> begin;           ///< keypoints[k]'s candidates are data[begin[k], begin[k + 1])
  std::vector<TriangulationCandidate> data;
};

/// ORB-SLAM SearchForTriangulation without a vocabulary: every unmatched keypoint of kf1 against every
/// unmatched keypoint of kf2 (ascending indices): on the epipolar line (chi2 3.84 with kf2's level sigma^2),
/// far enough from the epipole; the best must be <= TH_LOW (and < nnRatio x the second best if nnRatio < 1); one kf1 keypoint
/// per kf2 keypoint (first come); then the rotation histogram.
///
/// Two phases. (1) Each free kf1 keypoint's candidates, independent of the other keypoints: split over `threads`
/// (the costly part, the descriptor distances over the band). (2) In ascending kf1 order, the best and second-best
/// among the candidates no earlier keypoint took: the one-kf1-per-kf2 rule makes this sequential, and cheap. The
/// matches are those of ORB-SLAM's single ascending scan (best = lowest distance, the lowest index among equal ones;
/// second = the next distance among the candidates still free), whatever the number of threads.
std::vector<PairMatch> searchForTriangulationImpl(const KeyFrame& kf1, const KeyFrame& kf2,
                                                  const Eigen::Matrix3d& F12, const LocalMappingParams& params,
                                                  TriangulationSearch mode, int threads) {
  // Epipole in kf2: projection of kf1's centre.
  const Eigen::Vector3d c1in2 = kf2.T_cam_world * kf1.cameraCenter();
  const bool epipoleValid = c1in2.z() > 1e-9;
  const Eigen::Vector2d epipole = epipoleValid ? kf2.camera.project(c1in2) : Eigen::Vector2d::Zero();

  std::vector<std::size_t> free2;
  for (std::size_t j = 0; j < kf2.numKeypoints(); ++j)
    if (kf2.mapPointIds[j] == map::kNoMapPoint) free2.push_back(j);
  // The epipolar band is thin: testing it first (a few flops per pair with the line of x1 precomputed) spares
  // most descriptor distances. Bound of the squared line distance: 3.84 * sigma^2 of kf2's level (chi2, 1 DoF).
  constexpr double kEpipolarChi2 = 3.84;
  std::vector<double> x2s(free2.size()), y2s(free2.size()), bound2(free2.size());
  for (std::size_t n = 0; n < free2.size(); ++n) {
    x2s[n] = kf2.keypoints[free2[n]].pt.x;
    y2s[n] = kf2.keypoints[free2[n]].pt.y;
    bound2[n] = kEpipolarChi2 * kf2.levelSigma2.at(kf2.keypoints[free2[n]].octave);
  }
  // Guided: only the kf2 keypoints in grid cells the band of x1's line crosses, visited cell by cell. The result
  // is that of the exhaustive scan: the same candidates pass the band test, and phase 2 sorts them.
  double maxBound2 = 0.0;
  for (double b : bound2) maxBound2 = std::max(maxBound2, b);
  const EpipolarBandGrid grid(x2s, y2s, std::sqrt(maxBound2));
  // The candidates' data in the grid's cell order: a crossed cell is read as one contiguous range.
  const std::vector<std::size_t>& order = grid.order();
  std::vector<double> gx(order.size()), gy(order.size()), gb(order.size());
  std::vector<std::size_t> gj(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    gx[k] = x2s[order[k]];
    gy[k] = y2s[order[k]];
    gb[k] = bound2[order[k]];
    gj[k] = free2[order[k]];
  }

  // VocabularyNode: each kf1 keypoint's node, and kf2's free keypoints by node (ascending, as the scan visits them).
  constexpr places::NodeId kNoNode = std::numeric_limits<places::NodeId>::max();
  if (mode == TriangulationSearch::VocabularyNode && (kf1.bowFeatures.empty() || kf2.bowFeatures.empty()))
    mode = TriangulationSearch::Guided;
  std::vector<places::NodeId> nodeOf1;
  std::map<places::NodeId, std::vector<std::size_t>> free2ByNode;
  if (mode == TriangulationSearch::VocabularyNode) {
    nodeOf1.assign(kf1.numKeypoints(), kNoNode);
    for (const auto& [node, idx] : kf1.bowFeatures.nodes)
      for (std::uint32_t i : idx)
        if (i < nodeOf1.size()) nodeOf1[i] = node;
    for (const auto& [node, idx] : kf2.bowFeatures.nodes)
      for (std::uint32_t j : idx)
        if (j < kf2.numKeypoints() && kf2.mapPointIds[j] == map::kNoMapPoint) free2ByNode[node].push_back(j);
  }

  // Without the ratio test (nnRatio = 1, ORB-SLAM2's) only the best distance matters and it must be <= TH_LOW:
  // farther candidates are not kept. With it, the second-best may be any distance.
  const bool keepFarCandidates = params.nnRatio < 1.0;
  const auto collect = [&](CandidateChunk& chunk) {
    chunk.begin.assign(1, 0);
    for (std::size_t i : chunk.keypoints) {
      const std::size_t first = chunk.data.size();
      const uint8_t* d1 = kf1.descriptors.ptr<uint8_t>(static_cast<int>(i));
      const Eigen::Vector2d x1 = kf1.pixel(i);
      const Eigen::Vector3d line2 = F12.transpose() * Eigen::Vector3d(x1.x(), x1.y(), 1.0);  // l2 = F12^T x1
      const double lineNorm2 = line2.head<2>().squaredNorm();
      const auto consider = [&](std::size_t j, double x2x, double x2y, double bound) {
        const double num = line2.x() * x2x + line2.y() * x2y + line2.z();
        if (num * num >= bound * lineNorm2) return;
        const int dist = features::hammingDistance256(d1, kf2.descriptors.ptr<uint8_t>(static_cast<int>(j)));
        if (dist > params.maxDescriptorDistance && !keepFarCandidates) return;
        const Eigen::Vector2d x2 = kf2.pixel(j);
        const int octave2 = kf2.keypoints[j].octave;
        if (epipoleValid) {
          const double minDist = params.epipolarMinDistancePixels;
          if ((x2 - epipole).squaredNorm() < minDist * minDist * kf2.scaleFactors.at(octave2)) return;
        }
        // Same test through the geometry library (eq. 2.46), the reference for the fast band test above.
        if (!geometry::checkDistEpipolarLine(x1, x2, F12, kf2.levelSigma2.at(octave2), kEpipolarChi2)) return;
        chunk.data.push_back({dist, static_cast<std::uint32_t>(j)});
      };
      if (!(lineNorm2 > 0.0)) {  // x1 at the epipole: no line
      } else if (mode == TriangulationSearch::VocabularyNode) {
        if (nodeOf1[i] != kNoNode)
          if (const auto it = free2ByNode.find(nodeOf1[i]); it != free2ByNode.end())
            for (std::size_t j : it->second)
              consider(j, kf2.keypoints[j].pt.x, kf2.keypoints[j].pt.y,
                       kEpipolarChi2 * kf2.levelSigma2.at(kf2.keypoints[j].octave));
      } else if (mode == TriangulationSearch::Guided) {
        grid.forEachCrossedCell(line2, [&](std::size_t begin, std::size_t end) {
          for (std::size_t k = begin; k < end; ++k) consider(gj[k], gx[k], gy[k], gb[k]);
        });
      } else {
        for (std::size_t n = 0; n < free2.size(); ++n) consider(free2[n], x2s[n], y2s[n], bound2[n]);
      }
      std::sort(chunk.data.begin() + static_cast<std::ptrdiff_t>(first), chunk.data.end(),
                [](const TriangulationCandidate& a, const TriangulationCandidate& b) {
                  return a.dist != b.dist ? a.dist < b.dist : a.j < b.j;
                });
      chunk.begin.push_back(static_cast<std::uint32_t>(chunk.data.size()));
    }
  };

  // Phase 1: the free kf1 keypoints in `threads` runs of equal size, each collected on a thread of its own.
  std::vector<std::size_t> free1;
  for (std::size_t i = 0; i < kf1.numKeypoints(); ++i)
    if (kf1.mapPointIds[i] == map::kNoMapPoint) free1.push_back(i);
  const std::size_t numChunks = std::clamp<std::size_t>(static_cast<std::size_t>(std::max(threads, 1)), 1,
                                                        std::max<std::size_t>(free1.size(), 1));
  std::vector<CandidateChunk> chunks(numChunks);
  for (std::size_t c = 0; c < numChunks; ++c)
    chunks[c].keypoints.assign(free1.begin() + static_cast<std::ptrdiff_t>(c * free1.size() / numChunks),
                               free1.begin() + static_cast<std::ptrdiff_t>((c + 1) * free1.size() / numChunks));
  {
    std::vector<std::exception_ptr> errors(numChunks);
    std::vector<std::thread> workers;
    for (std::size_t c = 1; c < numChunks; ++c)
      workers.emplace_back([&, c] {
        try {
          collect(chunks[c]);
        } catch (...) {
          errors[c] = std::current_exception();
        }
      });
    try {
      collect(chunks[0]);
    } catch (...) {
      errors[0] = std::current_exception();
    }
    for (std::thread& w : workers) w.join();
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  }

  // Phase 2: ascending kf1 order; a kf2 keypoint goes to the first kf1 keypoint that takes it.
  std::vector<bool> taken2(kf2.numKeypoints(), false);
  std::vector<PairMatch> matches;
  std::vector<int> bins;
  for (const CandidateChunk& chunk : chunks) {
    for (std::size_t k = 0; k < chunk.keypoints.size(); ++k) {
      const std::size_t i = chunk.keypoints[k];
      int best = 257, second = 257;
      std::size_t bestJ = 0;
      for (std::uint32_t n = chunk.begin[k]; n < chunk.begin[k + 1]; ++n) {
        const TriangulationCandidate& cand = chunk.data[n];
        if (taken2[cand.j]) continue;
        if (best == 257) {
          best = cand.dist;
          bestJ = cand.j;
        } else {
          second = cand.dist;
          break;
        }
      }
      if (best > params.maxDescriptorDistance) continue;  // also: no candidate
      // Optional ratio test (nnRatio < 1); ORB-SLAM2 applies none here (default nnRatio = 1).
      if (params.nnRatio < 1.0 && static_cast<double>(best) >= params.nnRatio * static_cast<double>(second)) continue;
      taken2[bestJ] = true;
      matches.push_back({i, bestJ});
      bins.push_back(features::rotationHistogramBin(kf1.keypoints[i].angle, kf2.keypoints[bestJ].angle));
    }
  }
  if (params.checkOrientation) return filterByRotation(matches, bins);
  return matches;
}

}  // namespace

std::vector<PairMatch> searchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2, const Eigen::Matrix3d& F12,
                                              const LocalMappingParams& params, TriangulationSearch mode,
                                              int threads) {
  return searchForTriangulationImpl(kf1, kf2, F12, params, mode, threads);
}

std::vector<MapPointId> LocalMapper::createNewMapPoints(KeyFrameId kfId) {
  std::vector<MapPointId> created;
  std::vector<KeyFrameId> neighbours =
      map_.bestCovisibleKeyFrames(kfId, static_cast<std::size_t>(params_.covisibleKeyFrames));
  if (static_cast<int>(neighbours.size()) < params_.minTriangulationNeighbours) {
    const std::set<KeyFrameId> have(neighbours.begin(), neighbours.end());
    for (auto it = map_.keyFrames().rbegin();
         it != map_.keyFrames().rend() && static_cast<int>(neighbours.size()) < params_.minTriangulationNeighbours; ++it)
      if (it->first != kfId && !have.count(it->first)) neighbours.push_back(it->first);
  }
  // Threaded mode: one copy of the new keyframe for every pair's search (its free keypoints refreshed per pair).
  std::optional<KeyFrame> copy1;
  for (KeyFrameId nId : neighbours) {
    const KeyFrame& kf1 = map_.keyFrame(kfId);
    const KeyFrame& kf2 = map_.keyFrame(nId);
    if (kf1.descriptors.empty() || kf2.descriptors.empty()) continue;
    const Eigen::Vector3d O1 = kf1.cameraCenter(), O2 = kf2.cameraCenter();
    const double medianDepth2 = sceneMedianDepth(map_, kf2);
    if (medianDepth2 <= 0.0 || (O2 - O1).norm() / medianDepth2 < params_.minBaselineRatio) continue;

    const Eigen::Matrix3d K1 = kf1.camera.K(), K2 = kf2.camera.K();
    const Eigen::Matrix3d R1 = kf1.T_cam_world.linear(), R2 = kf2.T_cam_world.linear();
    const Eigen::Vector3d t1 = kf1.T_cam_world.translation(), t2 = kf2.T_cam_world.translation();
    const Eigen::Matrix3d F12 = geometry::fundamentalFromPoses(K1, R1, t1, K2, R2, t2);
    std::vector<PairMatch> matches;
    if (!outsideMapLock_) {
      matches = searchForTriangulation(kf1, kf2, F12, params_, triangulationSearch_, params_.triangulationThreads);
    } else {
      // The search (most of this step's time) runs outside the map lock on copies of the two keyframes, taken
      // with the lock held: tracking may insert a keyframe and link observations (covisibility) meanwhile.
      // Only this mapper binds keypoints of kf1 and kf2, so the free keypoints the copies show are still free.
      // The previous pairs' new points bound keypoints of kf1: only its keypoint-to-point links change.
      if (!copy1)
        copy1 = kf1;
      else
        copy1->mapPointIds = kf1.mapPointIds;
      const KeyFrame copy2 = kf2;
      const int threads = params_.triangulationThreads;
      if (!runOutsideMapLock(
              [&] { matches = searchForTriangulation(*copy1, copy2, F12, params_, triangulationSearch_, threads); }))
        return {};  // the map was reset: kfId is gone
    }
    const geometry::Matrix34d P1 = geometry::projectionMatrix(K1, R1, t1), P2 = geometry::projectionMatrix(K2, R2, t2);
    const double ratioFactor = params_.scaleConsistencyFactor * kf1.scaleFactors.at(std::min(1, kf1.numLevels() - 1));

    for (const PairMatch& m : matches) {
      const cv::KeyPoint& kp1 = kf1.keypoints[m.i1];
      const cv::KeyPoint& kp2 = kf2.keypoints[m.i2];
      // Parallax of the two rays (ORB-SLAM cosParallaxRays): too small and the DLT is ill-conditioned.
      const Eigen::Vector3d ray1 = R1.transpose() * kf1.camera.bearing(kf1.pixel(m.i1));
      const Eigen::Vector3d ray2 = R2.transpose() * kf2.camera.bearing(kf2.pixel(m.i2));
      const double cosParallaxRays = ray1.dot(ray2);
      if (!(cosParallaxRays > 0.0 && cosParallaxRays < params_.maxParallaxCos)) continue;
      Eigen::Vector3d X;
      if (!geometry::triangulateDLT(P1, kf1.pixel(m.i1), P2, kf2.pixel(m.i2), X)) continue;
      if (!geometry::hasPositiveDepth(R1, t1, X) || !geometry::hasPositiveDepth(R2, t2, X)) continue;
      // Reprojection chi2 (2 DoF, 5.991) with each keypoint's level variance.
      const double sigma1 = kf1.levelSigma2.at(kp1.octave), sigma2 = kf2.levelSigma2.at(kp2.octave);
      if (!geometry::passesReprojectionTest(geometry::reprojectionErrorSquared(K1, R1, t1, X, kf1.pixel(m.i1)),
                                            sigma1, params_.chi2Threshold) ||
          !geometry::passesReprojectionTest(geometry::reprojectionErrorSquared(K2, R2, t2, X, kf2.pixel(m.i2)),
                                            sigma2, params_.chi2Threshold))
        continue;
      // Scale consistency: the distance ratio must agree with the octave ratio within ratioFactor.
      const double dist1 = (X - O1).norm(), dist2 = (X - O2).norm();
      if (dist1 <= 0.0 || dist2 <= 0.0) continue;
      const double ratioDist = dist2 / dist1;
      const double ratioOctave = kf1.scaleFactors.at(kp1.octave) / kf2.scaleFactors.at(kp2.octave);
      if (ratioDist * ratioFactor < ratioOctave || ratioDist > ratioOctave * ratioFactor) continue;

      // Inverse-depth point (eq. 3.1) anchored in the keypoint of the NEW keyframe, as ORB-SLAM's
      // reference keyframe of a point created here.
      if (kf1.mapPointIds[m.i1] != map::kNoMapPoint || kf2.mapPointIds[m.i2] != map::kNoMapPoint) continue;
      const MapPointId id = map_.addMapPoint(kfId, m.i1, X);
      map_.addObservation(id, nId, m.i2);
      map_.computeDistinctiveDescriptor(id);
      map_.updateNormalAndDepth(id);
      if (model() != landmarks::MapPointModel::Heuristic) {
        // Seed of the keypoint model: the triangulated inverse depth with the eq. 2.24-2.29 variance of
        // this pair (SVO's spread if the pair gives none).
        MapPoint& p = map_.mutableMapPoint(id);
        const Eigen::Vector3d t_ref_cur = kf1.T_cam_world * O2;
        const landmarks::DepthUncertainty tau =
            t_ref_cur.norm() > 0.0 ? landmarks::depthUncertainty(p.bearing, 1.0 / p.inverseDepth, t_ref_cur,
                                                                 kf1.camera.fx, params_.depthPixelNoise)
                                   : landmarks::DepthUncertainty{};
        const double variance = tau.valid && tau.tau2InverseDepth() > 0.0 ? tau.tau2InverseDepth()
                                                                          : initialInverseDepthVariance(params_.pointModel.keypoint);
        landmarks::KeypointState state = impl_->modelPolicy->keypointModel().initialize(p.inverseDepthAlongZ(), variance);
        const MapPointModelPolicy& policy = *impl_->modelPolicy;
        policy.keypointModel().addSemanticObservation(
            state, policy.classEvidence(kf1.semanticProbabilities.empty() ? nullptr : &kf1.semanticProbabilities.at(m.i1)),
            1.0);
        const double alpha = landmarks::matchingAccuracyFromDescriptors(
            kf1.descriptors.row(static_cast<int>(m.i1)), kf2.descriptors.row(static_cast<int>(m.i2)),
            params_.pointModel.matching.hammingMaxDistance);
        policy.keypointModel().addSemanticObservation(
            state, policy.classEvidence(kf2.semanticProbabilities.empty() ? nullptr : &kf2.semanticProbabilities.at(m.i2)),
            alpha);
        p.landmarkState = encodeKeypointState(state);
      }
      created.push_back(id);
    }
  }
  std::set<MapPointId> recent(recent_.begin(), recent_.end());
  recent.insert(created.begin(), created.end());
  recent_.assign(recent.begin(), recent.end());
  return created;
}

// ------------------------------------------------------------------------------------ 4. SearchInNeighbors

/// ORB-SLAM ORBmatcher::Fuse(pKF, vpMapPoints, th): projects each point into `kfId`, picks the best keypoint
/// in a scale-dependent radius at the predicted level (or one finer), gated by the reprojection chi2; a
/// matched keypoint with its own point means a duplicate (the one with more observations is kept), a free
/// keypoint gets the observation. Returns the number of fusions + new observations.
int LocalMapper::fuseInto(KeyFrameId kfId, const std::vector<MapPointId>& points) {
  const KeyFrame& kf0 = map_.keyFrame(kfId);
  if (kf0.descriptors.empty() || kf0.numKeypoints() == 0) return 0;
  const features::FeatureGrid grid = features::FeatureGrid::fromKeypoints(
      kf0.keypoints, cv::Rect2f(0.f, 0.f, float(kf0.camera.width), float(kf0.camera.height)));
  int fused = 0;
  for (MapPointId id : points) {
    if (!map_.hasMapPoint(id)) continue;
    const MapPoint& p = map_.mapPoint(id);
    if (p.bad || p.isObservedBy(kfId) || p.descriptor.empty()) continue;
    const KeyFrame& kf = map_.keyFrame(kfId);
    const Eigen::Vector3d X = map_.worldPosition(id);
    const Eigen::Vector3d Xc = kf.T_cam_world * X;
    if (Xc.z() <= 0.0) continue;
    const Eigen::Vector2d uv = kf.camera.project(Xc);
    if (!kf.camera.inImage(uv)) continue;
    const Eigen::Vector3d PO = X - kf.cameraCenter();
    const double dist3D = PO.norm();
    if (dist3D < (1.0 - params_.fusionDistanceBand) * p.minDistance ||
        dist3D > (1.0 + params_.fusionDistanceBand) * p.maxDistance)
      continue;
    if (PO.dot(p.normal) < 0.5 * dist3D) continue;  // viewing angle > 60 deg from the mean
    const int predictedLevel = map_.predictScale(id, dist3D, kfId);
    const double radius = params_.fusionRadiusPixels * kf.scaleFactors.at(predictedLevel);
    const std::vector<size_t> candidates = grid.featuresInRadius(
        float(uv.x()), float(uv.y()), float(radius), features::OctaveRange{predictedLevel - 1, predictedLevel});
    int bestDist = 256;
    std::size_t bestIdx = 0;
    bool found = false;
    for (size_t c : candidates) {
      const double e2 = (kf.pixel(c) - uv).squaredNorm();
      if (e2 * kf.invSigma2(c) > params_.chi2Threshold) continue;
      const int dist = features::hammingDistance(p.descriptor, 0, kf.descriptors, static_cast<int>(c));
      if (dist < bestDist) {
        bestDist = dist;
        bestIdx = c;
        found = true;
      }
    }
    if (!found || bestDist > features::kOrbThLow) continue;
    const MapPointId existing = kf.mapPointIds[bestIdx];
    if (existing != map::kNoMapPoint) {
      if (map_.mapPoint(existing).bad) continue;
      // Keep the better-established point (more observations; ties keep the one already in the keyframe).
      if (map_.mapPoint(existing).numObservations() >= p.numObservations())
        map_.fuseMapPoints(existing, id);
      else
        map_.fuseMapPoints(id, existing);
    } else {
      map_.addObservation(id, kfId, bestIdx);
    }
    ++fused;
  }
  return fused;
}

int LocalMapper::searchInNeighbors(KeyFrameId kfId) {
  // Targets: first-order neighbours and, for each, its best second-order neighbours (ascending, unique).
  std::vector<KeyFrameId> targets;
  std::set<KeyFrameId> seen{kfId};
  const auto first = map_.bestCovisibleKeyFrames(kfId, static_cast<std::size_t>(params_.fusionNeighbours));
  for (KeyFrameId n : first)
    if (seen.insert(n).second) targets.push_back(n);
  for (KeyFrameId n : first)
    for (KeyFrameId n2 : map_.bestCovisibleKeyFrames(n, static_cast<std::size_t>(params_.fusionSecondOrderNeighbours)))
      if (seen.insert(n2).second) targets.push_back(n2);

  int fused = 0;
  // The keyframe's points into every target.
  for (KeyFrameId t : targets) {
    if (!map_.hasKeyFrame(t) || !map_.hasKeyFrame(kfId)) continue;
    fused += fuseInto(t, map_.pointsOf(kfId));
  }
  // The targets' points into the keyframe.
  std::set<MapPointId> candidates;
  for (KeyFrameId t : targets)
    if (map_.hasKeyFrame(t))
      for (MapPointId id : map_.pointsOf(t)) candidates.insert(id);
  fused += fuseInto(kfId, std::vector<MapPointId>(candidates.begin(), candidates.end()));
  // Appearance of the keyframe's points after the new observations (covisibility is kept by the map).
  for (MapPointId id : map_.pointsOf(kfId)) {
    map_.computeDistinctiveDescriptor(id);
    map_.updateNormalAndDepth(id);
  }
  return fused;
}

// ------------------------------------------------------------------------------------ 5. LocalBundleAdjustment

optimize::MapUpdateSummary LocalMapper::runLocalBundleAdjustment(KeyFrameId kfId, optimize::BAResult* resultOut) {
  // Only points the policy lets us use take part (§3.4.3), and the window's fixed keyframes are those that
  // observe these points: the window is built from the active points, not filtered after it was built.
  const std::shared_ptr<const map::PointUsePolicy>& policy = impl_->usePolicy;
  optimize::PointFilter usePoint;
  if (!policy->usesEveryGoodPoint()) usePoint = [&policy](const MapPoint& p) { return policy->mayUse(p); };
  optimize::BAProblem problem = optimize::makeLocalProblem(map_, kfId, params_.ba, usePoint);
  bool anyFree = false;
  for (const auto& [id, k] : problem.keyframes) anyFree = anyFree || !k.fixed;
  if (problem.observations.empty() || !anyFree) return {};
  // Each hook's factors follow the previous hook's: [begin_h, begin_h+1) is hook h's range.
  std::vector<std::size_t> hookBegin;
  for (const BAHooks& h : baHooks_) {
    hookBegin.push_back(problem.factors.size());
    if (!h.factors) continue;
    std::vector<std::shared_ptr<optimize::BAFactor>> f = h.factors(map_, problem);
    problem.factors.insert(problem.factors.end(), f.begin(), f.end());
  }
  hookBegin.push_back(problem.factors.size());
  optimize::BAResult result;
  const auto solve = [&] { result = optimize::localBundleAdjustment(problem, params_.ba, &stopBundleAdjustment_); };
  // The problem holds copies of the poses and points, so its solve may run outside the map lock. Factors of
  // other landmark kinds optimize their landmarks in place (BAFactor::landmarkBlocks), which tracking reads: a
  // problem with any of them is solved with the lock held.
  bool landmarksInPlace = false;
  for (const auto& f : problem.factors) landmarksInPlace = landmarksInPlace || !f->landmarkBlocks().empty();
  if (landmarksInPlace)
    solve();
  else if (!runOutsideMapLock(solve))
    return {};  // the map was reset while solving: nothing to write back
  if (resultOut) *resultOut = result;
  std::vector<bool> outliers(problem.factors.size(), false);
  for (std::size_t i : result.factorOutliers)
    if (i < outliers.size()) outliers[i] = true;
  for (std::size_t h = 0; h < baHooks_.size(); ++h)
    if (baHooks_[h].applied)
      baHooks_[h].applied(std::vector<bool>(outliers.begin() + static_cast<long>(hookBegin[h]),
                                            outliers.begin() + static_cast<long>(hookBegin[h + 1])));
  const optimize::MapUpdateSummary summary = optimize::applyResult(map_, problem, result, true);
  // §3.4.3: "after the bundle adjustment we update our probabilistic model with the refined depth
  // estimates": the filter mean takes the refined inverse depth; its variance and inlier counts are kept.
  if (model() != landmarks::MapPointModel::Heuristic)
    for (const auto& [id, rho] : result.inverseDepths) {
      if (!map_.hasMapPoint(id) || map_.mapPoint(id).landmarkState.empty()) continue;
      MapPoint& p = map_.mutableMapPoint(id);
      landmarks::KeypointState st = decodeKeypointState(p.landmarkState, "map point " + std::to_string(id));
      st.mu = p.inverseDepthAlongZ();
      p.landmarkState = encodeKeypointState(st);
    }
  return summary;
}

// ------------------------------------------------------------------------------------ 6. KeyFrameCulling

int LocalMapper::cullKeyFrames(KeyFrameId kfId) {
  return map::cullRedundantKeyFrames(map_, kfId, params_.culling);
}

// ------------------------------------------------------------------------------------ all steps

bool LocalMapper::runOutsideMapLock(const std::function<void()>& computation) {
  if (!outsideMapLock_) {
    computation();
    return true;
  }
  if (!outsideMapLock_(computation)) mapChanged_ = true;
  return !mapChanged_;
}

LocalMappingReport LocalMapper::processKeyFrame(KeyFrameId kfId, const std::vector<MapPointId>& recentlyAddedByTracking,
                                                bool measuredByTracking) {
  LocalMappingReport report;
  const auto t0 = Clock::now();
  landmarkUpdates_ = 0;
  mapChanged_ = false;
  stopBundleAdjustment_ = false;
  auto t = Clock::now();
  processNewKeyFrame(kfId, recentlyAddedByTracking, measuredByTracking);
  report.processMs = msSince(t);

  t = Clock::now();
  report.culledPoints = cullRecentPoints(kfId, &report.culledInlierRatio);
  report.culledRecent = report.culledPoints - report.culledInlierRatio;
  report.cullPointsMs = msSince(t);

  t = Clock::now();
  report.newPoints = static_cast<int>(createNewMapPoints(kfId).size());
  report.triangulationMs = msSince(t);
  if (mapChanged_) {
    report.mapChanged = true;
    return report;
  }

  t = Clock::now();
  report.fusedPoints = searchInNeighbors(kfId);
  report.fusionMs = msSince(t);
  if (refiner_) {
    t = Clock::now();
    report.refinement = refiner_->refine(map_, kfId);
    report.refinementMs = msSince(t);
  }
  if (newPointsReady_) newPointsReady_(kfId);

  if (params_.localBundleAdjustment && map_.numKeyFrames() > 2) {
    t = Clock::now();
    optimize::BAResult result;
    const optimize::MapUpdateSummary summary = runLocalBundleAdjustment(kfId, &result);
    report.baObservationsErased = summary.observationsErased;
    report.baPointsErased = summary.pointsErased;
    report.baInitialRmsPixels = result.initialRmsPixels;
    report.baFinalRmsPixels = result.finalRmsPixels;
    report.baStopped = result.stopped;
    report.localBaMs = msSince(t);
    if (mapChanged_) {
      report.mapChanged = true;
      return report;
    }
  }

  if (params_.cullKeyFrames) {
    t = Clock::now();
    report.culledKeyFrames = cullKeyFrames(kfId);
    report.cullKeyFramesMs = msSince(t);
  }
  report.landmarkUpdates = landmarkUpdates_;
  report.totalMs = msSince(t0);
  return report;
}

}  // namespace pslam::mapping
