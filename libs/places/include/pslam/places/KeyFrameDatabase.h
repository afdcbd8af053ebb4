#pragma once
// The keyframe database of place recognition (ORB-SLAM's KeyFrameDatabase): an inverted index word -> keyframes
// over the keyframes' BoW vectors, queried for relocalization candidates. Keyframes are plain ids here, so the
// database does not depend on the map; the covisibility graph enters as a function.
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <vector>

#include "pslam/places/BowTypes.h"

namespace pslam::places {

using KeyFrameKey = std::uint64_t;

struct PlaceCandidate {
  KeyFrameKey keyFrame = 0;
  double score = 0.0;             ///< L1 score of this keyframe against the query
  double accumulatedScore = 0.0;  ///< summed over its covisible group (the ranking key)
  int commonWords = 0;
};

struct RelocalizationQueryParams {
  double minCommonWordsRatio = 0.8;  ///< ORB-SLAM: keyframes sharing >= 0.8 x the best count of words
  double minAccumulatedRatio = 0.75; ///< ORB-SLAM: groups scoring >= 0.75 x the best group
  void check() const;
};

class KeyFrameDatabase {
 public:
  /// Adds (or replaces) keyframe `id`'s BoW vector.
  void add(KeyFrameKey id, BowVector bow);
  /// Removes keyframe `id` (no-op when absent).
  void erase(KeyFrameKey id);
  void clear();
  bool contains(KeyFrameKey id) const { return bows_.count(id) != 0; }
  std::size_t size() const { return bows_.size(); }
  const BowVector& bow(KeyFrameKey id) const { return bows_.at(id); }
  /// The keyframes held, ascending.
  std::vector<KeyFrameKey> keyFrames() const;

  /// ORB-SLAM's DetectRelocalizationCandidates: keyframes sharing a word with the query; those with at least
  /// minCommonWordsRatio x the largest count of shared words are scored (L1); each one's score is accumulated over
  /// its `covisible(kf)` neighbours that also passed (the best-scoring keyframe of the group represents it); the
  /// groups reaching minAccumulatedRatio x the best accumulated score are returned, best first (ties: lower id),
  /// each keyframe once. `covisible` may be empty (no grouping).
  std::vector<PlaceCandidate> relocalizationCandidates(
      const BowVector& query, const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
      const RelocalizationQueryParams& params = {}) const;

  /// ORB-SLAM's DetectLoopCandidates: the same query for a keyframe, without the keyframes in `excluded` (the
  /// keyframe itself and its covisible neighbours) and keeping only keyframes scoring at least `minScore` (the
  /// lowest score of the keyframe against its neighbours); neighbours below it still add to a group's score.
  std::vector<PlaceCandidate> loopCandidates(const BowVector& query,
                                             const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
                                             const std::set<KeyFrameKey>& excluded, double minScore,
                                             const RelocalizationQueryParams& params = {}) const;

 private:
  std::vector<PlaceCandidate> query(const BowVector& query,
                                    const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
                                    const std::set<KeyFrameKey>& excluded, double minScore,
                                    const RelocalizationQueryParams& params) const;
  std::map<KeyFrameKey, BowVector> bows_;
  std::map<WordId, std::vector<KeyFrameKey>> inverted_;  ///< keyframes per word, ascending
};

}  // namespace pslam::places
