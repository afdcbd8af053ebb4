#include "pslam/places/Vocabulary.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <numeric>
#include <random>

#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"
#include "pslam/features/Matching.h"

namespace pslam::places {

IMPLEMENTS_SERIALIZABLE(CVocabularyArchive, CSerializable, pslam::places)

namespace {

constexpr std::size_t kDescriptorBytes = 32;
constexpr WordId kNoWord = std::numeric_limits<WordId>::max();
constexpr std::uint32_t kEndSentinel = 0x50564F43;  // "PVOC"

void requireOrb(const cv::Mat& d, const std::string& ctx) {
  if (d.empty()) return;
  if (d.type() != CV_8UC1 || d.cols != static_cast<int>(kDescriptorBytes))
    throw Error(ctx + ": descriptors must be CV_8UC1 with 32 columns (ORB), got type " + std::to_string(d.type()) +
                " with " + std::to_string(d.cols) + " columns");
}

using Descriptor = std::array<std::uint8_t, kDescriptorBytes>;

/// Bitwise majority of a set of descriptors (the k-majority "mean" of binary descriptors): bit b is set when more
/// than half of the descriptors have it.
Descriptor majority(const std::vector<const std::uint8_t*>& members) {
  std::array<std::uint32_t, 8 * kDescriptorBytes> ones{};
  for (const std::uint8_t* d : members)
    for (std::size_t byte = 0; byte < kDescriptorBytes; ++byte) {
      const std::uint8_t v = d[byte];
      if (v == 0) continue;
      for (int bit = 0; bit < 8; ++bit) ones[8 * byte + static_cast<std::size_t>(bit)] += (v >> bit) & 1u;
    }
  Descriptor out{};
  const std::size_t half = members.size() / 2;
  for (std::size_t b = 0; b < ones.size(); ++b)
    if (ones[b] > half) out[b / 8] |= static_cast<std::uint8_t>(1u << (b % 8));
  return out;
}

/// One node's split: k-means++ seeds, then k-majority iterations. Returns the clusters (member positions in
/// `members`), non-empty, in seed order.
std::vector<std::vector<std::uint32_t>> kMajority(const std::vector<const std::uint8_t*>& members, int k,
                                                  int maxIterations, std::mt19937& rng) {
  const std::size_t n = members.size();
  // k-means++ seeding (distance-squared sampling); stops early when every descriptor equals a seed.
  std::vector<Descriptor> centres;
  std::vector<double> minDist2(n, std::numeric_limits<double>::max());
  auto addCentre = [&](std::size_t i) {
    Descriptor c;
    std::memcpy(c.data(), members[i], kDescriptorBytes);
    centres.push_back(c);
    for (std::size_t j = 0; j < n; ++j) {
      const double d = features::hammingDistance256(members[j], c.data());
      minDist2[j] = std::min(minDist2[j], d * d);
    }
  };
  addCentre(static_cast<std::size_t>(rng() % n));
  while (static_cast<int>(centres.size()) < k) {
    const double total = std::accumulate(minDist2.begin(), minDist2.end(), 0.0);
    if (!(total > 0.0)) break;
    const double cut = std::uniform_real_distribution<double>(0.0, total)(rng);
    double acc = 0.0;
    std::size_t pick = n - 1;
    for (std::size_t j = 0; j < n; ++j) {
      acc += minDist2[j];
      if (acc >= cut && minDist2[j] > 0.0) {
        pick = j;
        break;
      }
    }
    if (!(minDist2[pick] > 0.0)) break;
    addCentre(pick);
  }
  std::vector<int> assignment(n, -1);
  for (int it = 0; it < maxIterations; ++it) {
    bool changed = false;
    for (std::size_t j = 0; j < n; ++j) {
      int best = 0, bestDist = 257;
      for (std::size_t c = 0; c < centres.size(); ++c) {
        const int d = features::hammingDistance256(members[j], centres[c].data());
        if (d < bestDist) {
          bestDist = d;
          best = static_cast<int>(c);
        }
      }
      if (assignment[j] != best) {
        assignment[j] = best;
        changed = true;
      }
    }
    if (!changed) break;
    std::vector<std::vector<const std::uint8_t*>> groups(centres.size());
    for (std::size_t j = 0; j < n; ++j) groups[static_cast<std::size_t>(assignment[j])].push_back(members[j]);
    for (std::size_t c = 0; c < centres.size(); ++c)
      if (!groups[c].empty()) centres[c] = majority(groups[c]);
  }
  std::vector<std::vector<std::uint32_t>> clusters(centres.size());
  for (std::size_t j = 0; j < n; ++j) clusters[static_cast<std::size_t>(assignment[j])].push_back(static_cast<std::uint32_t>(j));
  clusters.erase(std::remove_if(clusters.begin(), clusters.end(), [](const auto& c) { return c.empty(); }),
                 clusters.end());
  return clusters;
}

}  // namespace

void VocabularyParams::check() const {
  const std::string ctx = "VocabularyParams";
  if (branching < 2 || branching > 64) throw Error(ctx + ": branching must be in [2, 64], got " + std::to_string(branching));
  if (depth < 1 || depth > 8) throw Error(ctx + ": depth must be in [1, 8], got " + std::to_string(depth));
  if (std::pow(static_cast<double>(branching), depth) > static_cast<double>(1u << 24))
    throw Error(ctx + ": branching^depth must be <= 2^24 words, got " + std::to_string(branching) + "^" +
                std::to_string(depth));
  if (maxIterations < 1) throw Error(ctx + ": maxIterations must be >= 1, got " + std::to_string(maxIterations));
}

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& imageDescriptors, const VocabularyParams& params,
                             const std::function<void(std::size_t, std::size_t)>& progress) {
  params.check();
  std::vector<const std::uint8_t*> all;
  for (std::size_t i = 0; i < imageDescriptors.size(); ++i) {
    const cv::Mat& d = imageDescriptors[i];
    requireOrb(d, "Vocabulary::train (image " + std::to_string(i) + ")");
    for (int r = 0; r < d.rows; ++r) all.push_back(d.ptr<std::uint8_t>(r));
  }
  if (all.empty()) throw Error("Vocabulary::train: no descriptors to train on");

  Vocabulary v;
  v.branching_ = params.branching;
  v.depth_ = params.depth;
  v.childBegin_.push_back(0);
  v.childCount_.push_back(0);
  v.descriptors_.assign(kDescriptorBytes, 0);
  std::mt19937 rng(params.seed);

  // Breadth-first: the children of a node are appended together, so they are contiguous.
  struct Pending {
    std::uint32_t node;
    int level;
    std::vector<const std::uint8_t*> members;
  };
  std::deque<Pending> queue;
  queue.push_back({0, 0, std::move(all)});
  int reportedLevel = -1;
  while (!queue.empty()) {
    Pending p = std::move(queue.front());
    queue.pop_front();
    if (progress && p.level != reportedLevel) {
      reportedLevel = p.level;
      progress(static_cast<std::size_t>(p.level), static_cast<std::size_t>(params.depth));
    }
    if (p.level >= params.depth) continue;  // a leaf
    std::vector<std::vector<const std::uint8_t*>> childMembers;
    std::vector<Descriptor> childDescriptors;
    if (static_cast<int>(p.members.size()) <= params.branching) {
      // DBoW2: a node with at most k descriptors gets one child per descriptor (here: a leaf).
      for (const std::uint8_t* d : p.members) {
        Descriptor c;
        std::memcpy(c.data(), d, kDescriptorBytes);
        childDescriptors.push_back(c);
        childMembers.push_back({});
      }
    } else {
      const auto clusters = kMajority(p.members, params.branching, params.maxIterations, rng);
      if (clusters.size() < 2) continue;  // all equal: this node is a leaf
      for (const auto& c : clusters) {
        std::vector<const std::uint8_t*> m;
        m.reserve(c.size());
        for (std::uint32_t j : c) m.push_back(p.members[j]);
        childDescriptors.push_back(majority(m));
        childMembers.push_back(std::move(m));
      }
    }
    const auto begin = static_cast<std::uint32_t>(v.childBegin_.size());
    v.childBegin_[p.node] = begin;
    v.childCount_[p.node] = static_cast<std::uint8_t>(childDescriptors.size());
    for (std::size_t c = 0; c < childDescriptors.size(); ++c) {
      const auto node = static_cast<std::uint32_t>(v.childBegin_.size());
      v.childBegin_.push_back(0);
      v.childCount_.push_back(0);
      v.descriptors_.insert(v.descriptors_.end(), childDescriptors[c].begin(), childDescriptors[c].end());
      if (!childMembers[c].empty()) queue.push_back({node, p.level + 1, std::move(childMembers[c])});
    }
    p.members.clear();
    p.members.shrink_to_fit();
  }
  v.weights_.clear();
  v.finalizeTree();

  // IDF: log(N / n_w) over the training images.
  std::vector<std::uint32_t> imagesWithWord(v.words_.size(), 0);
  std::vector<std::uint32_t> lastImage(v.words_.size(), std::numeric_limits<std::uint32_t>::max());
  std::uint64_t nDescriptors = 0;
  for (std::size_t i = 0; i < imageDescriptors.size(); ++i) {
    const cv::Mat& d = imageDescriptors[i];
    nDescriptors += static_cast<std::uint64_t>(d.rows);
    for (int r = 0; r < d.rows; ++r) {
      const WordId w = v.wordOf(d.ptr<std::uint8_t>(r));
      if (lastImage[w] != i) {
        lastImage[w] = static_cast<std::uint32_t>(i);
        ++imagesWithWord[w];
      }
    }
  }
  const double nImages = static_cast<double>(imageDescriptors.size());
  v.weights_.resize(v.words_.size());
  for (std::size_t w = 0; w < v.words_.size(); ++w)
    v.weights_[w] = imagesWithWord[w] > 0 ? static_cast<float>(std::log(nImages / imagesWithWord[w])) : 0.f;
  v.provenance_.images = imageDescriptors.size();
  v.provenance_.descriptors = nDescriptors;
  if (progress) progress(static_cast<std::size_t>(params.depth), static_cast<std::size_t>(params.depth));
  return v;
}

void Vocabulary::finalizeTree() {
  const std::size_t n = childCount_.size();
  if (n == 0 || descriptors_.size() != n * kDescriptorBytes)
    throw Error("vocabulary: " + std::to_string(n) + " nodes with " + std::to_string(descriptors_.size()) +
                " descriptor bytes");
  childBegin_.assign(n, 0);
  levelOfNode_.assign(n, 0);
  wordOfNode_.assign(n, kNoWord);
  words_.clear();
  std::size_t next = 1;
  for (std::size_t node = 0; node < n; ++node) {
    const std::size_t count = childCount_[node];
    if (count > static_cast<std::size_t>(branching_))
      throw Error("vocabulary: node " + std::to_string(node) + " has " + std::to_string(count) +
                  " children (branching " + std::to_string(branching_) + ")");
    if (count == 0) {
      if (node == 0) throw Error("vocabulary: the root has no children");
      wordOfNode_[node] = static_cast<WordId>(words_.size());
      words_.push_back(static_cast<NodeId>(node));
      continue;
    }
    if (levelOfNode_[node] >= depth_)
      throw Error("vocabulary: node " + std::to_string(node) + " below the depth " + std::to_string(depth_) + " has children");
    if (next + count > n)
      throw Error("vocabulary: node " + std::to_string(node) + "'s children run past the " + std::to_string(n) + " nodes");
    childBegin_[node] = static_cast<std::uint32_t>(next);
    for (std::size_t c = next; c < next + count; ++c) levelOfNode_[c] = static_cast<std::uint8_t>(levelOfNode_[node] + 1);
    next += count;
  }
  if (next != n)
    throw Error("vocabulary: " + std::to_string(n - next) + " of " + std::to_string(n) + " nodes are nobody's child");
}

WordId Vocabulary::wordOf(const std::uint8_t* descriptor, NodeId* nodeAtLevel, int level) const {
  NodeId node = 0;
  if (nodeAtLevel && level <= 0) *nodeAtLevel = 0;
  while (childCount_[node] > 0) {
    const std::uint32_t begin = childBegin_[node];
    const std::uint32_t end = begin + childCount_[node];
    NodeId best = begin;
    int bestDist = 257;
    for (std::uint32_t c = begin; c < end; ++c) {
      const int d = features::hammingDistance256(descriptor, &descriptors_[static_cast<std::size_t>(c) * kDescriptorBytes]);
      if (d < bestDist) {
        bestDist = d;
        best = c;
      }
    }
    node = best;
    if (nodeAtLevel && levelOfNode_[node] == level) *nodeAtLevel = node;
  }
  // A branch that ends above the requested level: the leaf stands for it.
  if (nodeAtLevel && level > 0 && levelOfNode_[node] < level) *nodeAtLevel = node;
  return wordOfNode_[node];
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector* features, int levelsUp) const {
  if (empty()) throw Error("Vocabulary::transform: the vocabulary is empty");
  requireOrb(descriptors, "Vocabulary::transform");
  bow.words.clear();
  if (features) features->nodes.clear();
  const int level = std::max(0, depth_ - std::max(0, levelsUp));
  std::vector<std::pair<WordId, float>> entries;
  std::vector<std::pair<NodeId, std::uint32_t>> byNode;
  entries.reserve(static_cast<std::size_t>(descriptors.rows));
  for (int r = 0; r < descriptors.rows; ++r) {
    NodeId node = 0;
    const WordId w = wordOf(descriptors.ptr<std::uint8_t>(r), features ? &node : nullptr, level);
    const float weight = weights_[w];
    if (!(weight > 0.f)) continue;  // a word seen in every training image says nothing
    entries.emplace_back(w, weight);
    if (features) byNode.emplace_back(node, static_cast<std::uint32_t>(r));
  }
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double total = 0.0;
  for (const auto& [w, x] : entries) {
    if (!bow.words.empty() && bow.words.back().first == w)
      bow.words.back().second += x;
    else
      bow.words.emplace_back(w, x);
    total += x;
  }
  if (total > 0.0)
    for (auto& e : bow.words) e.second = static_cast<float>(e.second / total);
  if (features) {
    std::sort(byNode.begin(), byNode.end());
    for (const auto& [node, f] : byNode) {
      if (features->nodes.empty() || features->nodes.back().first != node) features->nodes.push_back({node, {}});
      features->nodes.back().second.push_back(f);
    }
  }
}

std::string Vocabulary::fingerprint() const {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a 64
  const auto mix = [&h](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  };
  const std::int32_t shape[2] = {branching_, depth_};
  mix(shape, sizeof shape);
  mix(childBegin_.data(), childBegin_.size() * sizeof(std::uint32_t));
  mix(childCount_.data(), childCount_.size());
  mix(descriptors_.data(), descriptors_.size());
  mix(weights_.data(), weights_.size() * sizeof(float));
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return "k " + std::to_string(branching_) + ", L " + std::to_string(depth_) + ", " + std::to_string(words_.size()) +
         " words, fnv1a64 " + hex;
}

double Vocabulary::score(const BowVector& a, const BowVector& b) {
  double s = 0.0;
  auto ia = a.words.begin(), ib = b.words.begin();
  while (ia != a.words.end() && ib != b.words.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      const double va = ia->second, vb = ib->second;
      s += std::abs(va) + std::abs(vb) - std::abs(va - vb);
      ++ia;
      ++ib;
    }
  }
  return 0.5 * s;
}

bool Vocabulary::operator==(const Vocabulary& o) const {
  return branching_ == o.branching_ && depth_ == o.depth_ && childCount_ == o.childCount_ &&
         descriptors_ == o.descriptors_ && weights_ == o.weights_ && provenance_.images == o.provenance_.images &&
         provenance_.descriptors == o.provenance_.descriptors && provenance_.description == o.provenance_.description;
}

// ---- serialization ----

uint8_t CVocabularyArchive::serializeGetVersion() const { return kFormatVersion; }

void CVocabularyArchive::serializeTo(mrpt::serialization::CArchive& out) const {
  const Vocabulary& v = vocabulary;
  out << std::int32_t(v.branching_) << std::int32_t(v.depth_);
  out << std::uint64_t(v.provenance_.images) << std::uint64_t(v.provenance_.descriptors) << v.provenance_.description;
  out << std::uint64_t(v.childCount_.size());
  out.WriteBuffer(v.childCount_.data(), v.childCount_.size());
  out.WriteBuffer(v.descriptors_.data(), v.descriptors_.size());
  out << std::uint64_t(v.weights_.size());
  out.WriteBufferFixEndianness(v.weights_.data(), v.weights_.size());
  out << kEndSentinel;
}

void CVocabularyArchive::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  readRecordingFailure(readFailure, "vocabulary", [&] { readContent(in, version); });
}

void CVocabularyArchive::readContent(mrpt::serialization::CArchive& in, uint8_t version) {
  if (version != kFormatVersion)
    throw Error("unsupported vocabulary format version " + std::to_string(version) + " (this build reads version " +
                std::to_string(kFormatVersion) + ")");
  Vocabulary v;
  std::int32_t k = 0, depth = 0;
  in >> k >> depth;
  VocabularyParams p;
  p.branching = k;
  p.depth = depth;
  p.check();
  v.branching_ = k;
  v.depth_ = depth;
  std::uint64_t images = 0, descriptors = 0, nodes = 0, nWeights = 0;
  in >> images >> descriptors >> v.provenance_.description;
  v.provenance_.images = images;
  v.provenance_.descriptors = descriptors;
  in >> nodes;
  // At most every node of a full tree.
  double maxNodes = 0.0;
  for (int l = 0; l <= depth; ++l) maxNodes += std::pow(static_cast<double>(k), l);
  if (nodes < 2 || static_cast<double>(nodes) > maxNodes)
    throw Error("implausible node count " + std::to_string(nodes) + " for branching " + std::to_string(k) +
                " and depth " + std::to_string(depth));
  v.childCount_.resize(nodes);
  v.descriptors_.resize(nodes * kDescriptorBytes);
  if (in.ReadBuffer(v.childCount_.data(), v.childCount_.size()) != v.childCount_.size() ||
      in.ReadBuffer(v.descriptors_.data(), v.descriptors_.size()) != v.descriptors_.size())
    throw Error("the vocabulary ends inside its tree");
  v.finalizeTree();
  in >> nWeights;
  if (nWeights != v.words_.size())
    throw Error(std::to_string(nWeights) + " word weights for " + std::to_string(v.words_.size()) + " words");
  v.weights_.resize(nWeights);
  if (in.ReadBufferFixEndianness(v.weights_.data(), v.weights_.size()) != v.weights_.size() * sizeof(float))
    throw Error("the vocabulary ends inside its word weights");
  for (std::size_t w = 0; w < v.weights_.size(); ++w)
    if (!std::isfinite(v.weights_[w]) || v.weights_[w] < 0.f)
      throw Error("word " + std::to_string(w) + " has the invalid weight " + std::to_string(v.weights_[w]));
  std::uint32_t sentinel = 0;
  in >> sentinel;
  if (sentinel != kEndSentinel) throw Error("missing end-of-vocabulary marker");
  vocabulary = std::move(v);
}

void Vocabulary::save(const std::filesystem::path& path) const {
  if (empty()) throw Error(path.string() + ": refusing to save an empty vocabulary");
  AtomicOutput out(path);
  {
    mrpt::io::CFileGZOutputStream stream;
    if (!stream.open(out.tempPath().string(), 6)) throw Error(path.string() + ": cannot open for writing");
    CVocabularyArchive wrapper;
    wrapper.vocabulary = *this;
    try {
      auto arch = mrpt::serialization::archiveFrom(stream);
      arch << wrapper;
    } catch (const std::exception& e) {
      throw Error(path.string() + ": writing the vocabulary failed (" + e.what() + ")");
    }
    stream.close();
  }
  out.commit();
}

Vocabulary Vocabulary::load(const std::filesystem::path& path) {
  static std::once_flag registered;
  std::call_once(registered, [] { mrpt::rtti::registerClass(CLASS_ID(CVocabularyArchive)); });
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path.string() + ": vocabulary file not found");
  GzipInputStream stream(path);
  if (!stream.compressed()) throw Error(path.string() + ": not a vocabulary file (not gzip-compressed)");
  verifyGzipFile(path);
  CVocabularyArchive wrapper;
  try {
    auto arch = mrpt::serialization::archiveFrom(stream);
    arch.ReadObject(&wrapper);
    stream.requireEnd();
  } catch (const std::exception& e) {
    throwArchiveReadError(path, e, stream, wrapper.readFailure, "vocabulary file");
  }
  return std::move(wrapper.vocabulary);
}

}  // namespace pslam::places
