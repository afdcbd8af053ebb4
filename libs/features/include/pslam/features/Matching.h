#pragma once
// Binary descriptor matching (thesis eq. 2.18): Hamming distance, ORB-SLAM's two-view initialization search
// (SearchForInitialization) and a global brute-force ratio matcher for relocalization.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/features/FeatureGrid.h"

namespace pslam::features {

/// Hamming distance of two 256-bit (32-byte) ORB descriptors: popcount of their XOR (eq. 2.18).
int hammingDistance256(const uint8_t* a, const uint8_t* b);
/// Hamming distance between row `ia` of `a` and row `ib` of `b` (CV_8UC1, 32 columns). Hot path: the caller
/// guarantees types and row indices (no checks).
int hammingDistance(const cv::Mat& a, int ia, const cv::Mat& b, int ib);

/// One correspondence: descriptor/keypoint index in the first (query) and the second (train) set.
struct IndexMatch {
  int i1 = -1;
  int i2 = -1;
  int distance = 0;  ///< Hamming distance
};

/// Best and second-best candidate of one descriptor among `candidates` (rows of `descriptors`): the building block
/// of ORB-SLAM's projection searches (FeatureGrid window -> best candidate -> threshold and ratio test).
struct BestCandidate {
  int index = -1;                ///< row of the best candidate, -1 if there were no candidates
  int distance = 256 + 1;        ///< its Hamming distance (> 256 if none)
  int secondDistance = 256 + 1;  ///< second-best distance (> 256 if fewer than two candidates)
  /// ORB-SLAM's acceptance: distance <= maxDistance and distance < ratio * secondDistance.
  bool accepted(int maxDistance, float ratio) const {
    return index >= 0 && distance <= maxDistance &&
           static_cast<float>(distance) < ratio * static_cast<float>(secondDistance);
  }
};
/// Ties keep the earlier candidate. Throws pslam::Error for non-ORB descriptors or out-of-range candidates.
BestCandidate bestCandidate(const uint8_t* descriptor, const cv::Mat& descriptors, const std::vector<size_t>& candidates);

/// ORB-SLAM's matcher constants.
constexpr int kOrbThLow = 50;    ///< TH_LOW: strict acceptance (initialization, fusion)
constexpr int kOrbThHigh = 100;  ///< TH_HIGH: loose acceptance (tracking, relocalization)

struct InitMatchParams {
  float nnRatio = 0.9f;          ///< accept only if best < nnRatio * second best
  int maxDistance = kOrbThLow;   ///< accept only if best <= maxDistance
  float windowHalfSize = 100.f;  ///< square search window around the previous matched position (px)
  int maxOctave1 = 0;            ///< frame-1 keypoints above this octave are skipped (ORB-SLAM: only level 0)
  int octaveSlack = 0;           ///< frame-2 candidates within +-this many octaves of the frame-1 one (ORB-SLAM: 0)
  bool checkOrientation = true;  ///< rotation-histogram consistency
  int histogramBins = 30;        ///< bins over 360 deg of angle differences; the 3 largest bins are kept
  void check() const;
};

/// ORB-SLAM's SearchForInitialization between a reference frame (1) and the current frame (2).
/// For every frame-1 keypoint of octave <= maxOctave1, candidates are frame-2 keypoints of the SAME octave (+-
/// octaveSlack; ORB-SLAM: 0) in a window of half size windowHalfSize around prevMatched[i1] (found via grid2, built
/// over kps2). The best
/// candidate must pass maxDistance and the nnRatio test; a frame-2 keypoint keeps only its best frame-1 match.
/// With checkOrientation, matches whose angle difference falls outside the three most populated histogram bins
/// (bins 2/3 dropped when below 10 % of the largest) are removed. On return prevMatched[i1] holds the position
/// of the new match of i1 (unchanged where none). Returns the matches sorted by i1.
std::vector<IndexMatch> matchForInitialization(const std::vector<cv::KeyPoint>& kps1, const cv::Mat& desc1,
                                               const std::vector<cv::KeyPoint>& kps2, const cv::Mat& desc2,
                                               const FeatureGrid& grid2, std::vector<cv::Point2f>& prevMatched,
                                               const InitMatchParams& params = {});

/// Indices of the (up to) three largest bins of `histogram` by count (ties: lower index), -1 where none;
/// the second/third are dropped (-1) when below 10 % of the largest, as ORB-SLAM's ComputeThreeMaxima.
void threeLargestBins(const std::vector<std::vector<int>>& histogram, int& first, int& second, int& third);

/// ORB-SLAM's rotation histogram: 30 bins over 360 degrees of keypoint angle differences.
constexpr int kRotationHistogramBins = 30;
/// Bin of the angle difference angle1 - angle2 (degrees) among `bins` bins over 360 degrees.
int rotationHistogramBin(float angle1, float angle2, int bins = kRotationHistogramBins);
/// Rotation consistency of a match set: the positions (ascending) of the entries of `bins` that fall into one of
/// the three most populated bins (threeLargestBins' rule). bins[k] must be in [0, numBins).
std::vector<std::size_t> inLargestRotationBins(const std::vector<int>& bins, int numBins = kRotationHistogramBins);

struct BruteForceParams {
  float ratio = 0.8f;             ///< Lowe ratio best < ratio * second best; >= 1 disables the test
  int maxDistance = kOrbThHigh;   ///< accept only if best <= maxDistance
  bool crossCheck = false;        ///< also require that query i1 is the best match of train i2
  void check() const;
};

/// Global matching of every query descriptor against all train descriptors (relocalization). Uses OpenCV's
/// BFMatcher (NORM_HAMMING). Returns matches sorted by i1. Throws pslam::Error on non-ORB descriptor matrices.
std::vector<IndexMatch> matchBruteForce(const cv::Mat& query, const cv::Mat& train, const BruteForceParams& params = {});

}  // namespace pslam::features
