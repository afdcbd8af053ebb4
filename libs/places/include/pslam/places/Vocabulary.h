#pragma once
// A vocabulary tree of 256-bit ORB descriptors (Nister & Stewenius' tree, DBoW2's binary version as ORB-SLAM
// uses it): hierarchical k-majority clustering with k-means++ seeding, TF-IDF word weights, the L1 score, and the
// direct index by node. Saved as one versioned MRPT CSerializable object in a gz archive (`.pvoc`).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <mrpt/serialization/CSerializable.h>
#include <opencv2/core.hpp>

#include "pslam/places/BowTypes.h"

namespace pslam::places {

struct VocabularyParams {
  int branching = 10;     ///< k: children per node
  int depth = 5;          ///< L: levels below the root (k^L words at most)
  int maxIterations = 10; ///< k-majority iterations per node (stops earlier when no assignment changes)
  std::uint32_t seed = 0; ///< k-means++ seeding
  /// Throws pslam::Error naming the field: branching in [2, 64], depth in [1, 8], branching^depth <= 2^24,
  /// maxIterations >= 1.
  void check() const;
};

/// What a vocabulary was trained on (kept in the file, printed by `vocab-train` and `slam-map info`).
struct VocabularyProvenance {
  std::uint64_t images = 0;       ///< training images (the IDF's document count)
  std::uint64_t descriptors = 0;  ///< training descriptors
  std::string description;        ///< free text: the command / data recipe
};

class Vocabulary {
 public:
  Vocabulary() = default;

  /// Trains on the ORB descriptors of a set of images (each a CV_8U matrix with 32 columns, one row per feature;
  /// empty matrices are allowed). The tree is built by k-majority clustering level by level; a node with at most
  /// k descriptors gets one child per descriptor (a leaf). IDF weight of a word: log(N / n_w) over the N images,
  /// n_w = images with a feature in that word. Deterministic for a given seed. `progress(level, depth)` is called
  /// when the clustering starts a tree level and once at the end. Throws pslam::Error for non-ORB matrices or no descriptors at all.
  static Vocabulary train(const std::vector<cv::Mat>& imageDescriptors, const VocabularyParams& params,
                          const std::function<void(std::size_t, std::size_t)>& progress = {});

  bool empty() const { return words_.empty(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  std::size_t numWords() const { return words_.size(); }
  std::size_t numNodes() const { return childBegin_.size(); }
  const VocabularyProvenance& provenance() const { return provenance_; }
  /// Identifies the vocabulary in a saved map: "k 16, L 4, 65228 words, fnv1a64 <16 hex digits>", the hash over
  /// the tree, the node descriptors and the word weights (not the provenance text).
  std::string fingerprint() const;
  void setProvenance(VocabularyProvenance p) { provenance_ = std::move(p); }

  /// The word of one descriptor: descends from the root to a leaf by the nearest child (Hamming; ties: the
  /// first child). `nodeAtLevel` (optional) receives the node passed at tree level `level` (1 = the root's
  /// children), or the leaf when the branch ends above that level.
  WordId wordOf(const std::uint8_t* descriptor, NodeId* nodeAtLevel = nullptr, int level = 0) const;
  /// Weight (IDF) of a word.
  float wordWeight(WordId w) const { return weights_.at(w); }

  /// BoW vector of an image's descriptors (DBoW2 TF-IDF: each feature adds its word's IDF; words of weight 0 are
  /// skipped; then L1 normalization) and, if `features` is given, its direct index at `levelsUp` levels above
  /// the leaves (ORB-SLAM: 4 with its depth-6 tree, i.e. level 2). Throws pslam::Error for non-ORB descriptors or
  /// an empty vocabulary.
  void transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector* features = nullptr,
                 int levelsUp = 0) const;

  /// DBoW2's L1 score of two L1-normalized BoW vectors: 1 - 0.5 * |a - b|_1, in [0, 1] (1 = same histogram).
  static double score(const BowVector& a, const BowVector& b);

  /// Writes the `.pvoc` file atomically (temporary + rename). Throws pslam::Error naming the path.
  void save(const std::filesystem::path& path) const;
  /// Reads a `.pvoc` file. Throws pslam::Error naming the file when it is missing, not a vocabulary, truncated,
  /// corrupt (gzip CRC checked), of an unsupported version, or structurally invalid.
  static Vocabulary load(const std::filesystem::path& path);

  bool operator==(const Vocabulary& o) const;

 private:
  friend class CVocabularyArchive;
  /// Rebuilds the derived tables (parents' levels, word ids) from childBegin_/childCount_; throws on an invalid
  /// tree.
  void finalizeTree();

  int branching_ = 0, depth_ = 0;
  // The tree in breadth-first order: node 0 is the root; the children of node n are the childCount_[n] nodes from
  // childBegin_[n] on. Leaves (childCount_ 0) are the words.
  std::vector<std::uint32_t> childBegin_;
  std::vector<std::uint8_t> childCount_;
  std::vector<std::uint8_t> descriptors_;  ///< 32 bytes per node (the root's are zero)
  std::vector<WordId> wordOfNode_;         ///< per node: its word id (leaves) or UINT32_MAX
  std::vector<NodeId> words_;              ///< per word: its node
  std::vector<float> weights_;             ///< per word: IDF
  std::vector<std::uint8_t> levelOfNode_;  ///< per node: 0 = root
  VocabularyProvenance provenance_;
};

/// The serializable wrapper of a vocabulary (format version kFormatVersion; other versions are refused).
class CVocabularyArchive : public mrpt::serialization::CSerializable {
  DEFINE_SERIALIZABLE(CVocabularyArchive, pslam::places)
 public:
  static constexpr std::uint8_t kFormatVersion = 0;
  Vocabulary vocabulary;
  std::string readFailure;  ///< why the last serializeFrom() failed (MRPT replaces exception messages)

 private:
  void readContent(mrpt::serialization::CArchive& in, std::uint8_t version);
};

}  // namespace pslam::places
