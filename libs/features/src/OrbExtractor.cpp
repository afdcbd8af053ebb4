#include "pslam/features/OrbExtractor.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <exception>
#include <system_error>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/PixelCentres.h"

namespace pslam::features {
namespace {

using Clock = std::chrono::steady_clock;

// One quadtree node: an axis-aligned cell [x0,x1) x [y0,y1) and the keypoints inside it.
struct QuadNode {
  float x0, y0, x1, y1;
  std::vector<int> keys;
  bool alive = true;
  bool leafDone = false;  // holds exactly one keypoint: never divided again (ORB-SLAM's bNoMore)
};

// Splits `node` into four children at the rounded-up half of its width and height, as ORB-SLAM does.
void divideNode(const QuadNode& node, const std::vector<cv::KeyPoint>& kps, std::array<QuadNode, 4>& children) {
  const float halfX = std::ceil((node.x1 - node.x0) / 2.f);
  const float halfY = std::ceil((node.y1 - node.y0) / 2.f);
  const float xm = node.x0 + halfX, ym = node.y0 + halfY;
  children[0] = QuadNode{node.x0, node.y0, xm, ym, {}};
  children[1] = QuadNode{xm, node.y0, node.x1, ym, {}};
  children[2] = QuadNode{node.x0, ym, xm, node.y1, {}};
  children[3] = QuadNode{xm, ym, node.x1, node.y1, {}};
  for (QuadNode& c : children) c.keys.reserve(node.keys.size());
  for (int k : node.keys) {
    const cv::Point2f& p = kps[k].pt;
    const int idx = (p.x < xm ? 0 : 1) + (p.y < ym ? 0 : 2);
    children[idx].keys.push_back(k);
  }
  for (QuadNode& c : children) c.leafDone = c.keys.size() == 1;
}

}  // namespace

OrbExtractor::OrbExtractor(const OrbParams& params) : params_(params) {
  params_.check();
  const int L = params_.nLevels;
  scale_.resize(L);
  invScale_.resize(L);
  sigma2_.resize(L);
  invSigma2_.resize(L);
  scale_[0] = 1.f;
  for (int l = 1; l < L; ++l) scale_[l] = scale_[l - 1] * static_cast<float>(params_.scaleFactor);
  for (int l = 0; l < L; ++l) {
    invScale_[l] = 1.f / scale_[l];
    sigma2_[l] = scale_[l] * scale_[l];  // pixel noise grows with the level's pixel size
    invSigma2_[l] = 1.f / sigma2_[l];
  }

  // Per-level budget: a geometric series N_l = N_0 r^l with sum N (ORB-SLAM uses r = 1/s); the last level
  // takes the rounding remainder so that the budgets sum to nFeatures.
  const double r = params_.levelBudgetByArea ? 1.0 / (params_.scaleFactor * params_.scaleFactor)
                                             : 1.0 / params_.scaleFactor;
  featuresPerLevel_.assign(L, 0);
  double desired = params_.nFeatures * (1.0 - r) / (1.0 - std::pow(r, L));
  int assigned = 0;
  for (int l = 0; l < L - 1; ++l) {
    featuresPerLevel_[l] = static_cast<int>(std::lround(desired));
    assigned += featuresPerLevel_[l];
    desired *= r;
  }
  featuresPerLevel_[L - 1] = std::max(params_.nFeatures - assigned, 0);

  // Circular patch: umax[v] = half width of the disc of radius R at row offset v, made exactly symmetric
  // under transposition (so the centroid angle does not prefer the x or the y axis).
  const int R = params_.patchSize / 2;
  umax_.assign(R + 1, 0);
  const int vmax = static_cast<int>(std::floor(R * std::sqrt(2.0) / 2 + 1));
  const int vmin = static_cast<int>(std::ceil(R * std::sqrt(2.0) / 2));
  for (int v = 0; v <= vmax && v <= R; ++v) umax_[v] = static_cast<int>(std::lround(std::sqrt(double(R * R - v * v))));
  for (int v = R, v0 = 0; v >= vmin; --v) {
    while (umax_[v0] == umax_[v0 + 1]) ++v0;
    umax_[v] = v0;
    ++v0;
  }

  // Only OpenCV's descriptor code is used: one level, our keypoints (with our angles) on our padded level image.
  const int workers = std::min(params_.threads, L);
  for (int w = 0; w < workers; ++w)
    describers_.push_back(cv::ORB::create(params_.nFeatures, 1.2f, 1, params_.edgeThreshold, 0, 2,
                                          cv::ORB::HARRIS_SCORE, params_.patchSize, params_.iniThFAST));
}

struct OrbExtractor::LevelOutput {
  std::vector<cv::KeyPoint> keypoints;  ///< level-0 pixel coordinates
  cv::Mat descriptors;
  double detectMs = 0, orientationMs = 0, descriptorMs = 0;
  double detectCpuMs = 0, orientationCpuMs = 0, descriptorCpuMs = 0;
};

void OrbExtractor::buildPyramid(const cv::Mat& grey) {
  const int E = params_.edgeThreshold;
  padded_.resize(params_.nLevels);
  pyramid_.resize(params_.nLevels);
  for (int l = 0; l < params_.nLevels; ++l) {
    const cv::Size sz(std::max(1, static_cast<int>(std::lround(grey.cols * invScale_[l]))),
                      std::max(1, static_cast<int>(std::lround(grey.rows * invScale_[l]))));
    padded_[l].create(sz.height + 2 * E, sz.width + 2 * E, CV_8UC1);
    cv::Mat view = padded_[l](cv::Rect(E, E, sz.width, sz.height));
    if (l == 0) {
      grey.copyTo(view);
    } else {
      // As ORB-SLAM: each level is resized from the previous one (bilinear).
      cv::resize(pyramid_[l - 1], view, sz, 0, 0, cv::INTER_LINEAR);
    }
    // `view` already sits in the middle of padded_[l]: copyMakeBorder only fills the reflected border.
    cv::copyMakeBorder(view, padded_[l], E, E, E, E, cv::BORDER_REFLECT_101 + cv::BORDER_ISOLATED);
    pyramid_[l] = view;
  }
}

void OrbExtractor::detectLevel(int level, std::vector<cv::KeyPoint>& out) const {
  out.clear();
  const cv::Mat& img = pyramid_[level];
  const int minBorderX = params_.edgeThreshold - 3, minBorderY = minBorderX;
  const int maxBorderX = img.cols - params_.edgeThreshold + 3;
  const int maxBorderY = img.rows - params_.edgeThreshold + 3;
  const int width = maxBorderX - minBorderX, height = maxBorderY - minBorderY;
  if (width <= 6 || height <= 6 || featuresPerLevel_[level] <= 0) return;

  const int nCols = std::max(1, width / params_.cellSize);
  const int nRows = std::max(1, height / params_.cellSize);
  const int wCell = static_cast<int>(std::ceil(double(width) / nCols));
  const int hCell = static_cast<int>(std::ceil(double(height) / nRows));

  std::vector<cv::KeyPoint> candidates;
  candidates.reserve(static_cast<size_t>(featuresPerLevel_[level]) * 10);
  std::vector<cv::KeyPoint> cellKeys;
  // Cell (i, j) covers img rows [iniY, maxY) and cols [iniX, maxX); +6: FAST cannot fire within 3 px of the
  // image it is given, so overlapping cells by 6 px makes the detection areas of neighbouring cells tile the
  // level without gaps or duplicates. In coordinates relative to (minBorderX, minBorderY) the detection area of
  // cell (i, j) is [j wCell + 3, (j+1) wCell + 3) x [i hCell + 3, (i+1) hCell + 3).
  auto cellImage = [&](int i, int j) {
    const int iniY = minBorderY + i * hCell, iniX = minBorderX + j * wCell;
    if (iniY >= maxBorderY - 3 || iniX >= maxBorderX - 3) return cv::Mat();
    const int maxY = std::min(iniY + hCell + 6, maxBorderY), maxX = std::min(iniX + wCell + 6, maxBorderX);
    return img(cv::Range(iniY, maxY), cv::Range(iniX, maxX));
  };
  auto addCellKeys = [&](int i, int j) {
    for (cv::KeyPoint kp : cellKeys) {
      kp.pt.x += static_cast<float>(j * wCell);  // relative to (minBorderX, minBorderY)
      kp.pt.y += static_cast<float>(i * hCell);
      candidates.push_back(kp);
    }
  };

  if (params_.literalCellFast) {
    // ORB-SLAM verbatim: one FAST call per cell at iniThFAST, again at minThFAST if it found nothing.
    for (int i = 0; i < nRows; ++i)
      for (int j = 0; j < nCols; ++j) {
        const cv::Mat cell = cellImage(i, j);
        if (cell.empty()) continue;
        cellKeys.clear();
        cv::FAST(cell, cellKeys, params_.iniThFAST, true);
        if (cellKeys.empty()) cv::FAST(cell, cellKeys, params_.minThFAST, true);  // weak-texture cell fallback
        addCellKeys(i, j);
      }
  } else {
    // Same per-cell thresholds with one FAST call over the level at iniThFAST (the FAST score does not depend
    // on the threshold, so a cell's corners at iniThFAST are the same); only cells left empty are re-run at
    // minThFAST. Difference to ORB-SLAM: non-maximum suppression also acts across cell borders.
    cellKeys.clear();
    cv::FAST(img(cv::Range(minBorderY, maxBorderY), cv::Range(minBorderX, maxBorderX)), cellKeys,
             params_.iniThFAST, true);
    std::vector<int> perCell(static_cast<size_t>(nRows) * nCols, 0);
    for (const cv::KeyPoint& kp : cellKeys) {
      const int j = std::clamp((static_cast<int>(kp.pt.x) - 3) / wCell, 0, nCols - 1);
      const int i = std::clamp((static_cast<int>(kp.pt.y) - 3) / hCell, 0, nRows - 1);
      ++perCell[static_cast<size_t>(i) * nCols + j];
    }
    candidates = cellKeys;
    for (int i = 0; i < nRows; ++i)
      for (int j = 0; j < nCols; ++j) {
        if (perCell[static_cast<size_t>(i) * nCols + j] > 0) continue;
        const cv::Mat cell = cellImage(i, j);
        if (cell.empty()) continue;
        cellKeys.clear();
        cv::FAST(cell, cellKeys, params_.minThFAST, true);
        addCellKeys(i, j);
      }
  }

  out = distributeQuadtree(candidates, minBorderX, maxBorderX, minBorderY, maxBorderY, featuresPerLevel_[level]);
  const float scaledPatch = params_.patchSize * scale_[level];
  for (cv::KeyPoint& kp : out) {
    kp.pt.x += static_cast<float>(minBorderX);
    kp.pt.y += static_cast<float>(minBorderY);
    kp.octave = level;
    kp.size = scaledPatch;
  }
}

std::vector<cv::KeyPoint> OrbExtractor::distributeQuadtree(const std::vector<cv::KeyPoint>& kps, int minX, int maxX,
                                                           int minY, int maxY, int target) {
  std::vector<cv::KeyPoint> result;
  if (kps.empty() || target <= 0 || maxX <= minX || maxY <= minY) return result;
  const float W = static_cast<float>(maxX - minX), H = static_cast<float>(maxY - minY);

  // Root: round(W/H) side-by-side square-ish nodes so that wide images start with square cells.
  const int nIni = std::max(1, static_cast<int>(std::lround(W / H)));
  const float hX = W / nIni;
  std::vector<QuadNode> nodes;  // storage; divided nodes are flagged !alive, children appended
  nodes.reserve(static_cast<size_t>(target) * 8);
  for (int i = 0; i < nIni; ++i) nodes.push_back(QuadNode{hX * i, 0.f, hX * (i + 1), H, {}});
  for (int k = 0; k < static_cast<int>(kps.size()); ++k) {
    const int idx = std::clamp(static_cast<int>(kps[k].pt.x / hX), 0, nIni - 1);
    nodes[idx].keys.push_back(k);
  }
  int aliveCount = 0;
  for (QuadNode& n : nodes) {
    n.alive = !n.keys.empty();
    n.leafDone = n.keys.size() == 1;
    aliveCount += n.alive ? 1 : 0;
  }

  // Replaces node `idx` by its non-empty children; returns the storage indices of children with > 1 key.
  auto expand = [&](size_t idx, std::vector<size_t>& expandable) {
    std::array<QuadNode, 4> children;
    divideNode(nodes[idx], kps, children);
    nodes[idx].alive = false;
    nodes[idx].keys = {};
    --aliveCount;
    for (QuadNode& c : children) {
      if (c.keys.empty()) continue;
      const bool more = c.keys.size() > 1;
      nodes.push_back(std::move(c));
      ++aliveCount;
      if (more) expandable.push_back(nodes.size() - 1);
    }
  };

  bool finish = false;
  for (int pass = 0; !finish && pass < 64; ++pass) {
    const int prevCount = aliveCount;
    std::vector<size_t> expandable;
    // One pass divides every node that still holds several keypoints.
    const size_t storageEnd = nodes.size();
    for (size_t i = 0; i < storageEnd; ++i)
      if (nodes[i].alive && !nodes[i].leafDone) expand(i, expandable);

    if (aliveCount >= target || aliveCount == prevCount) {
      finish = true;
    } else if (aliveCount + 3 * static_cast<int>(expandable.size()) > target) {
      // The next full pass would overshoot: divide the most populated nodes first until the target is met.
      while (!finish) {
        const int prev = aliveCount;
        std::vector<size_t> toDivide;
        toDivide.swap(expandable);
        // Most keys first; ties by position so the result does not depend on memory addresses.
        std::sort(toDivide.begin(), toDivide.end(), [&](size_t a, size_t b) {
          const QuadNode &na = nodes[a], &nb = nodes[b];
          if (na.keys.size() != nb.keys.size()) return na.keys.size() > nb.keys.size();
          if (na.y0 != nb.y0) return na.y0 < nb.y0;
          return na.x0 < nb.x0;
        });
        for (size_t idx : toDivide) {
          expand(idx, expandable);
          if (aliveCount >= target) break;
        }
        if (aliveCount >= target || aliveCount == prev) finish = true;
      }
    }
  }

  // Keep the strongest corner of every leaf (first one on equal responses: input order is deterministic).
  result.reserve(aliveCount);
  for (const QuadNode& n : nodes) {
    if (!n.alive) continue;
    int best = n.keys.front();
    for (int k : n.keys)
      if (kps[k].response > kps[best].response) best = k;
    result.push_back(kps[best]);
  }
  return result;
}

float OrbExtractor::intensityCentroidAngle(const cv::Mat& image, cv::Point2f pt) const {
  const int R = params_.patchSize / 2;
  const uchar* center = image.ptr<uchar>(cvRound(pt.y)) + cvRound(pt.x);
  const int step = static_cast<int>(image.step1());
  // Moments m10 = sum u I, m01 = sum v I over the disc (eq. 2.13); rows +v and -v are visited together.
  int m10 = 0, m01 = 0;
  for (int u = -R; u <= R; ++u) m10 += u * center[u];
  for (int v = 1; v <= R; ++v) {
    int rowDiff = 0;
    const int d = umax_[v];
    for (int u = -d; u <= d; ++u) {
      const int below = center[u + v * step], above = center[u - v * step];
      rowDiff += below - above;
      m10 += u * (below + above);
    }
    m01 += v * rowDiff;
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));  // eq. 2.14, degrees
}

void OrbExtractor::processLevel(int l, cv::ORB& describer, LevelOutput& out) const {
  auto start = Clock::now();
  double cpu = threadCpuMs();
  std::vector<cv::KeyPoint> kps;
  detectLevel(l, kps);
  out.detectMs = msSince(start);
  out.detectCpuMs = threadCpuMs() - cpu;

  start = Clock::now();
  cpu = threadCpuMs();
  for (cv::KeyPoint& kp : kps) kp.angle = intensityCentroidAngle(pyramid_[l], kp.pt);
  out.orientationMs = msSince(start);
  out.orientationCpuMs = threadCpuMs() - cpu;

  start = Clock::now();
  cpu = threadCpuMs();
  out.keypoints.clear();
  out.descriptors.release();
  if (!kps.empty()) {
    // OpenCV's ORB blurs the image (7x7 Gaussian, sigma 2) and evaluates the steered pattern at each keypoint
    // with the keypoint's own angle; we hand it the padded level so that no keypoint is dropped at the border.
    const int E = params_.edgeThreshold;
    std::vector<cv::KeyPoint> inPadded = kps;
    for (cv::KeyPoint& kp : inPadded) {
      kp.pt.x += E;
      kp.pt.y += E;
      kp.octave = 0;
    }
    describer.compute(padded_[l], inPadded, out.descriptors);
    // OpenCV must have used exactly our keypoints, in order, with our angles (it would otherwise silently drop
    // border keypoints or reorder them); cheap to verify, fatal if violated.
    bool same = inPadded.size() == kps.size() && out.descriptors.rows == static_cast<int>(kps.size()) &&
                out.descriptors.cols == 32 && out.descriptors.type() == CV_8UC1;
    for (size_t i = 0; same && i < inPadded.size(); ++i)
      same = inPadded[i].angle == kps[i].angle && inPadded[i].pt.x == kps[i].pt.x + E &&
             inPadded[i].pt.y == kps[i].pt.y + E;
    if (!same) throw Error("OrbExtractor::extract: OpenCV ORB changed the keypoints of level " + std::to_string(l));
    // ORB-SLAM's level -> image mapping, x_0 = x_l s^l (the exact inverse of the resize was tried and did not
    // pay end to end: doc/features.md, step 7).
    out.keypoints = std::move(kps);
    for (cv::KeyPoint& kp : out.keypoints) kp.pt *= scale_[l];
  }
  out.descriptorMs = msSince(start);
  out.descriptorCpuMs = threadCpuMs() - cpu;
}

void OrbExtractor::extract(const cv::Mat& image, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                           OrbStageTimes* times) {
  require(!image.empty(), "OrbExtractor::extract", "empty image");
  require(image.depth() == CV_8U, "OrbExtractor::extract",
          "image must be 8-bit (got depth " + std::to_string(image.depth()) + ")");
  cv::Mat grey;
  switch (image.channels()) {
    case 1: grey = image; break;
    case 3: cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY); break;
    default:
      throw Error("OrbExtractor::extract: unsupported number of channels " + std::to_string(image.channels()));
  }
  OrbStageTimes local;
  OrbStageTimes& t = times ? *times : local;
  t = OrbStageTimes{};

  auto start = Clock::now();
  double cpu = processCpuMs();
  buildPyramid(grey);
  t.pyramidMs = msSince(start);
  t.pyramidCpuMs = processCpuMs() - cpu;

  // The levels are independent once the pyramid is built: the workers take them in order, largest first (a
  // level's cost falls with its area), each into its own slot, so any number of threads gives the same output.
  const int L = params_.nLevels;
  std::vector<LevelOutput> levels(L);
  std::atomic<int> nextLevel{0};
  auto work = [&](cv::ORB& describer) {
    for (int l = nextLevel++; l < L; l = nextLevel++) processLevel(l, describer, levels[l]);
  };
  start = Clock::now();
  cpu = processCpuMs();
  const int workers = static_cast<int>(describers_.size());
  std::vector<std::exception_ptr> failures(workers);
  std::vector<std::thread> pool;
  for (int w = 1; w < workers; ++w) {
    try {
      pool.emplace_back([&, w] {
        try {
          work(*describers_[w]);
        } catch (...) {
          failures[w] = std::current_exception();
          nextLevel = L;  // the others stop after their current level
        }
      });
    } catch (const std::system_error&) {
      break;  // no thread to be had: the threads there are take every level, with the same output
    }
  }
  try {
    work(*describers_[0]);
  } catch (...) {
    failures[0] = std::current_exception();
    nextLevel = L;
  }
  for (std::thread& th : pool) th.join();
  for (const std::exception_ptr& f : failures)
    if (f) std::rethrow_exception(f);
  t.levelsMs = msSince(start);
  t.levelsCpuMs = processCpuMs() - cpu;

  size_t total = 0;
  for (const LevelOutput& lo : levels) {
    total += lo.keypoints.size();
    t.detectMs += lo.detectMs;
    t.orientationMs += lo.orientationMs;
    t.descriptorMs += lo.descriptorMs;
    t.detectCpuMs += lo.detectCpuMs;
    t.orientationCpuMs += lo.orientationCpuMs;
    t.descriptorCpuMs += lo.descriptorCpuMs;
  }
  keypoints.clear();
  keypoints.reserve(total);
  descriptors.create(static_cast<int>(total), 32, CV_8UC1);
  int row = 0;
  for (const LevelOutput& lo : levels) {
    if (lo.keypoints.empty()) continue;
    keypoints.insert(keypoints.end(), lo.keypoints.begin(), lo.keypoints.end());
    lo.descriptors.copyTo(descriptors.rowRange(row, row + lo.descriptors.rows));
    row += lo.descriptors.rows;
  }
}

}  // namespace pslam::features
