#include "pslam/places/BowMatching.h"

#include <algorithm>

#include "pslam/core/Error.h"

namespace pslam::places {

void NodeMatchParams::check() const {
  if (maxDistance < 0 || maxDistance > 256)
    throw Error("NodeMatchParams: maxDistance must be in [0, 256], got " + std::to_string(maxDistance));
  if (!(ratio > 0.f && ratio <= 1.f)) throw Error("NodeMatchParams: ratio must be in (0, 1], got " + std::to_string(ratio));
}

namespace {

void requireIndices(const FeatureVector& fv, const cv::Mat& d, const std::vector<cv::KeyPoint>& k, const char* which) {
  if (!d.empty() && (d.type() != CV_8UC1 || d.cols != 32))
    throw Error(std::string("matchByVocabularyNode: descriptors of set ") + which + " are not ORB (CV_8UC1, 32 columns)");
  const std::size_t n = std::min(static_cast<std::size_t>(d.rows), k.size());
  for (const auto& [node, idx] : fv.nodes)
    for (std::uint32_t i : idx)
      if (i >= n)
        throw Error(std::string("matchByVocabularyNode: feature ") + std::to_string(i) + " of set " + which +
                    " (node " + std::to_string(node) + ") is outside its " + std::to_string(n) + " features");
}

}  // namespace

std::vector<features::IndexMatch> matchByVocabularyNode(
    const FeatureVector& nodes1, const cv::Mat& descriptors1, const std::vector<cv::KeyPoint>& keypoints1,
    const FeatureVector& nodes2, const cv::Mat& descriptors2, const std::vector<cv::KeyPoint>& keypoints2,
    const NodeMatchParams& params, const std::function<bool(std::size_t)>& use1,
    const std::function<bool(std::size_t)>& use2) {
  params.check();
  requireIndices(nodes1, descriptors1, keypoints1, "1");
  requireIndices(nodes2, descriptors2, keypoints2, "2");
  std::vector<features::IndexMatch> matches;
  std::vector<int> bins;
  std::vector<bool> taken2(keypoints2.size(), false);
  auto it1 = nodes1.nodes.begin(), it2 = nodes2.nodes.begin();
  while (it1 != nodes1.nodes.end() && it2 != nodes2.nodes.end()) {
    if (it1->first < it2->first) {
      ++it1;
      continue;
    }
    if (it2->first < it1->first) {
      ++it2;
      continue;
    }
    for (std::uint32_t i : it1->second) {
      if (use1 && !use1(i)) continue;
      const std::uint8_t* d1 = descriptors1.ptr<std::uint8_t>(static_cast<int>(i));
      int best = 257, second = 257;
      std::uint32_t bestJ = 0;
      for (std::uint32_t j : it2->second) {
        if (taken2[j] || (use2 && !use2(j))) continue;
        const int d = features::hammingDistance256(d1, descriptors2.ptr<std::uint8_t>(static_cast<int>(j)));
        if (d < best) {
          second = best;
          best = d;
          bestJ = j;
        } else if (d < second) {
          second = d;
        }
      }
      if (best > params.maxDistance) continue;
      if (static_cast<float>(best) >= params.ratio * static_cast<float>(second)) continue;
      taken2[bestJ] = true;
      matches.push_back({static_cast<int>(i), static_cast<int>(bestJ), best});
      bins.push_back(features::rotationHistogramBin(keypoints1[i].angle, keypoints2[bestJ].angle));
    }
    ++it1;
    ++it2;
  }
  if (params.checkOrientation) {
    std::vector<features::IndexMatch> kept;
    for (std::size_t k : features::inLargestRotationBins(bins)) kept.push_back(matches[k]);
    matches = std::move(kept);
  }
  std::sort(matches.begin(), matches.end(), [](const auto& a, const auto& b) { return a.i1 < b.i1; });
  return matches;
}

}  // namespace pslam::places
