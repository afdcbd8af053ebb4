// ORB-SLAM's SearchForTriangulation (thesis §2.4.1; ORBmatcher.cc): the keypoint pairs of two keyframes that local
// mapping triangulates, found without a vocabulary (exhaustively, or guided by a grid over the epipolar band) or by
// vocabulary node. Both searches without a vocabulary give the same matches; the number of threads never changes
// them.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include <Eigen/Dense>

#include "pslam/features/FeatureGrid.h"
#include "pslam/features/Matching.h"
#include "pslam/geometry/Epipolar.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping {

using map::KeyFrame;

namespace {

/// Keeps only the matches whose rotation bin is one of the three most populated (ORB-SLAM).
template <typename Match>
std::vector<Match> filterByRotation(const std::vector<Match>& matches, const std::vector<int>& bins) {
  std::vector<Match> kept;
  for (std::size_t i : features::inLargestRotationBins(bins)) kept.push_back(matches[i]);
  return kept;
}

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

}  // namespace pslam::mapping
