#pragma once
// The two views of an image in a bag-of-binary-words vocabulary (Galvez-Lopez & Tardos' DBoW2, as ORB-SLAM
// uses it): the weighted word histogram that place recognition scores, and the direct index that groups the
// image's features by vocabulary node for guided matching. Plain data: keyframes carry them.
#include <cstdint>
#include <utility>
#include <vector>

namespace pslam::places {

using WordId = std::uint32_t;
using NodeId = std::uint32_t;

/// TF-IDF weighted word histogram, L1-normalized, sorted by word id (one entry per word present).
struct BowVector {
  std::vector<std::pair<WordId, float>> words;
  bool empty() const { return words.empty(); }
  bool operator==(const BowVector& o) const { return words == o.words; }
};

/// Direct index: the features of an image grouped by their vocabulary node at one tree level, sorted by node id;
/// the feature indices of a node ascend. Features sharing a node are the candidates of guided matching.
struct FeatureVector {
  std::vector<std::pair<NodeId, std::vector<std::uint32_t>>> nodes;
  bool empty() const { return nodes.empty(); }
};

}  // namespace pslam::places
