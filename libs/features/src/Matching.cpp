#include "pslam/features/Matching.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>

#include <opencv2/features2d.hpp>

#include "pslam/core/Error.h"

namespace pslam::features {
namespace {

void requireOrbDescriptors(const cv::Mat& d, const char* ctx, const char* name) {
  if (d.empty()) return;
  require(d.type() == CV_8UC1 && d.cols == 32, ctx,
          std::string(name) + " must be CV_8UC1 with 32 columns (got type " + std::to_string(d.type()) + ", " +
              std::to_string(d.cols) + " columns)");
}

}  // namespace

// The Debian toolchain targets baseline x86-64, where __builtin_popcountll is a table-free bit-twiddling call;
// on x86-64 a second clone uses the POPCNT instruction and the loader picks it when the CPU has it (GCC ifunc).
// Not in sanitizer builds: the loader runs the ifunc resolver before the sanitizer runtime is up, and the
// instrumented resolver crashes there (seen with -fsanitize=thread).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_ADDRESS__) && \
    !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("popcnt", "default")))
#endif
int hammingDistance256(const uint8_t* a, const uint8_t* b) {
  int dist = 0;
  for (int k = 0; k < 4; ++k) {
    uint64_t wa, wb;  // memcpy: descriptor rows need not be 8-byte aligned
    std::memcpy(&wa, a + 8 * k, 8);
    std::memcpy(&wb, b + 8 * k, 8);
    dist += __builtin_popcountll(wa ^ wb);
  }
  return dist;
}

int hammingDistance(const cv::Mat& a, int ia, const cv::Mat& b, int ib) {
  return hammingDistance256(a.ptr<uint8_t>(ia), b.ptr<uint8_t>(ib));
}

BestCandidate bestCandidate(const uint8_t* descriptor, const cv::Mat& descriptors,
                            const std::vector<size_t>& candidates) {
  requireOrbDescriptors(descriptors, "bestCandidate", "descriptors");
  BestCandidate r;
  for (size_t c : candidates) {
    require(c < static_cast<size_t>(descriptors.rows), "bestCandidate",
            "candidate " + std::to_string(c) + " out of range (" + std::to_string(descriptors.rows) + " rows)");
    const int d = hammingDistance256(descriptor, descriptors.ptr<uint8_t>(static_cast<int>(c)));
    if (d < r.distance) {
      r.secondDistance = r.distance;
      r.distance = d;
      r.index = static_cast<int>(c);
    } else if (d < r.secondDistance) {
      r.secondDistance = d;
    }
  }
  return r;
}

void InitMatchParams::check() const {
  const std::string ctx = "InitMatchParams";
  require(nnRatio > 0 && nnRatio <= 1, ctx, "nnRatio must be in (0, 1]");
  require(maxDistance >= 0 && maxDistance <= 256, ctx, "maxDistance must be in [0, 256]");
  require(windowHalfSize > 0, ctx, "windowHalfSize must be > 0");
  require(histogramBins >= 3, ctx, "histogramBins must be >= 3");
  require(octaveSlack >= 0, ctx, "octaveSlack must be >= 0");
}

void BruteForceParams::check() const {
  const std::string ctx = "BruteForceParams";
  require(ratio > 0, ctx, "ratio must be > 0");
  require(maxDistance >= 0 && maxDistance <= 256, ctx, "maxDistance must be in [0, 256]");
}

void threeLargestBins(const std::vector<std::vector<int>>& histogram, int& first, int& second, int& third) {
  size_t m1 = 0, m2 = 0, m3 = 0;
  first = second = third = -1;
  for (int i = 0; i < static_cast<int>(histogram.size()); ++i) {
    const size_t s = histogram[i].size();
    if (s == 0) continue;
    if (s > m1) {
      m3 = m2; third = second;
      m2 = m1; second = first;
      m1 = s; first = i;
    } else if (s > m2) {
      m3 = m2; third = second;
      m2 = s; second = i;
    } else if (s > m3) {
      m3 = s; third = i;
    }
  }
  // Secondary modes only count when they are substantial.
  if (m2 < 0.1 * m1) {
    second = third = -1;
  } else if (m3 < 0.1 * m1) {
    third = -1;
  }
}

std::vector<IndexMatch> matchForInitialization(const std::vector<cv::KeyPoint>& kps1, const cv::Mat& desc1,
                                               const std::vector<cv::KeyPoint>& kps2, const cv::Mat& desc2,
                                               const FeatureGrid& grid2, std::vector<cv::Point2f>& prevMatched,
                                               const InitMatchParams& params) {
  const char* ctx = "matchForInitialization";
  params.check();
  requireOrbDescriptors(desc1, ctx, "desc1");
  requireOrbDescriptors(desc2, ctx, "desc2");
  require(desc1.rows == static_cast<int>(kps1.size()), ctx, "desc1 rows differ from kps1 size");
  require(desc2.rows == static_cast<int>(kps2.size()), ctx, "desc2 rows differ from kps2 size");
  require(grid2.size() == kps2.size(), ctx, "grid2 does not index kps2");
  require(prevMatched.size() == kps1.size(), ctx, "prevMatched must have one position per kps1 keypoint");

  const int n1 = static_cast<int>(kps1.size()), n2 = static_cast<int>(kps2.size());
  std::vector<int> match12(n1, -1), match21(n2, -1), dist12(n1, INT_MAX), bestDist21(n2, INT_MAX);
  const int bins = params.histogramBins;
  std::vector<std::vector<int>> rotHist(bins);
  const float binPerDeg = bins / 360.f;

  for (int i1 = 0; i1 < n1; ++i1) {
    const int octave = kps1[i1].octave;
    if (octave > params.maxOctave1) continue;
    const auto candidates = grid2.featuresInWindow(prevMatched[i1].x, prevMatched[i1].y, params.windowHalfSize,
                                                   OctaveRange{octave - params.octaveSlack, octave + params.octaveSlack});
    int best = INT_MAX, second = INT_MAX, bestI2 = -1;
    const uint8_t* d1 = desc1.ptr<uint8_t>(i1);
    for (size_t c : candidates) {
      const int i2 = static_cast<int>(c);
      const int d = hammingDistance256(d1, desc2.ptr<uint8_t>(i2));
      if (bestDist21[i2] <= d) continue;  // i2 already has an at least as good frame-1 partner
      if (d < best) {
        second = best;
        best = d;
        bestI2 = i2;
      } else if (d < second) {
        second = d;
      }
    }
    if (bestI2 < 0 || best > params.maxDistance) continue;
    if (!(static_cast<float>(best) < params.nnRatio * static_cast<float>(second))) continue;
    if (match21[bestI2] >= 0) match12[match21[bestI2]] = -1;  // i2 switches to the better i1
    match12[i1] = bestI2;
    match21[bestI2] = i1;
    bestDist21[bestI2] = best;
    dist12[i1] = best;
    if (params.checkOrientation) {
      float rot = kps1[i1].angle - kps2[bestI2].angle;
      if (rot < 0) rot += 360.f;
      int bin = static_cast<int>(std::lround(rot * binPerDeg));
      if (bin >= bins) bin = 0;
      rotHist[bin].push_back(i1);
    }
  }

  if (params.checkOrientation) {
    int b1, b2, b3;
    threeLargestBins(rotHist, b1, b2, b3);
    for (int b = 0; b < bins; ++b) {
      if (b == b1 || b == b2 || b == b3) continue;
      for (int i1 : rotHist[b]) match12[i1] = -1;
    }
  }

  std::vector<IndexMatch> matches;
  for (int i1 = 0; i1 < n1; ++i1) {
    if (match12[i1] < 0) continue;
    matches.push_back({i1, match12[i1], dist12[i1]});
    prevMatched[i1] = kps2[match12[i1]].pt;
  }
  return matches;
}

int rotationHistogramBin(float angle1, float angle2, int bins) {
  float rot = angle1 - angle2;
  if (rot < 0.0f) rot += 360.0f;
  int bin = static_cast<int>(std::round(rot * (1.0f / 360.0f) * bins));
  if (bin == bins) bin = 0;
  return std::clamp(bin, 0, bins - 1);
}

std::vector<std::size_t> inLargestRotationBins(const std::vector<int>& bins, int numBins) {
  std::vector<std::vector<int>> histogram(static_cast<std::size_t>(numBins));
  for (std::size_t i = 0; i < bins.size(); ++i) histogram.at(static_cast<std::size_t>(bins[i])).push_back(static_cast<int>(i));
  int b1 = -1, b2 = -1, b3 = -1;
  threeLargestBins(histogram, b1, b2, b3);
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < bins.size(); ++i)
    if (bins[i] == b1 || bins[i] == b2 || bins[i] == b3) kept.push_back(i);
  return kept;
}

std::vector<IndexMatch> matchBruteForce(const cv::Mat& query, const cv::Mat& train, const BruteForceParams& params) {
  const char* ctx = "matchBruteForce";
  params.check();
  requireOrbDescriptors(query, ctx, "query");
  requireOrbDescriptors(train, ctx, "train");
  std::vector<IndexMatch> out;
  if (query.empty() || train.empty()) return out;

  cv::BFMatcher matcher(cv::NORM_HAMMING, false);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 2);
  std::vector<int> bestQueryOfTrain;
  if (params.crossCheck) {
    std::vector<cv::DMatch> back;
    matcher.match(train, query, back);
    bestQueryOfTrain.assign(train.rows, -1);
    for (const cv::DMatch& m : back) bestQueryOfTrain[m.queryIdx] = m.trainIdx;
  }
  for (const auto& candidates : knn) {
    if (candidates.empty()) continue;
    const cv::DMatch& best = candidates[0];
    const int d = static_cast<int>(std::lround(best.distance));
    if (d > params.maxDistance) continue;
    if (params.ratio < 1.f && candidates.size() > 1 && !(best.distance < params.ratio * candidates[1].distance))
      continue;
    if (params.crossCheck && bestQueryOfTrain[best.trainIdx] != best.queryIdx) continue;
    out.push_back({best.queryIdx, best.trainIdx, d});
  }
  std::sort(out.begin(), out.end(), [](const IndexMatch& a, const IndexMatch& b) { return a.i1 < b.i1; });
  return out;
}

}  // namespace pslam::features
