#include "pslam/places/KeyFrameDatabase.h"

#include <algorithm>
#include <set>

#include "pslam/core/Error.h"
#include "pslam/places/Vocabulary.h"

namespace pslam::places {

void RelocalizationQueryParams::check() const {
  const std::string ctx = "RelocalizationQueryParams";
  if (!(minCommonWordsRatio > 0.0 && minCommonWordsRatio <= 1.0))
    throw Error(ctx + ": minCommonWordsRatio must be in (0, 1]");
  if (!(minAccumulatedRatio > 0.0 && minAccumulatedRatio <= 1.0))
    throw Error(ctx + ": minAccumulatedRatio must be in (0, 1]");
}

void KeyFrameDatabase::add(KeyFrameKey id, BowVector bow) {
  erase(id);
  for (const auto& [w, x] : bow.words) {
    auto& list = inverted_[w];
    list.insert(std::lower_bound(list.begin(), list.end(), id), id);
  }
  bows_.emplace(id, std::move(bow));
}

void KeyFrameDatabase::erase(KeyFrameKey id) {
  const auto it = bows_.find(id);
  if (it == bows_.end()) return;
  for (const auto& [w, x] : it->second.words) {
    auto inv = inverted_.find(w);
    if (inv == inverted_.end()) continue;
    auto& list = inv->second;
    const auto at = std::lower_bound(list.begin(), list.end(), id);
    if (at != list.end() && *at == id) list.erase(at);
    if (list.empty()) inverted_.erase(inv);
  }
  bows_.erase(it);
}

void KeyFrameDatabase::clear() {
  bows_.clear();
  inverted_.clear();
}

std::vector<KeyFrameKey> KeyFrameDatabase::keyFrames() const {
  std::vector<KeyFrameKey> out;
  out.reserve(bows_.size());
  for (const auto& [id, b] : bows_) out.push_back(id);
  return out;
}

std::vector<PlaceCandidate> KeyFrameDatabase::relocalizationCandidates(
    const BowVector& query, const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
    const RelocalizationQueryParams& params) const {
  return this->query(query, covisible, {}, 0.0, params);
}

std::vector<PlaceCandidate> KeyFrameDatabase::loopCandidates(
    const BowVector& query, const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
    const std::set<KeyFrameKey>& excluded, double minScore, const RelocalizationQueryParams& params) const {
  return this->query(query, covisible, excluded, minScore, params);
}

std::vector<PlaceCandidate> KeyFrameDatabase::query(const BowVector& query,
                                                    const std::function<std::vector<KeyFrameKey>(KeyFrameKey)>& covisible,
                                                    const std::set<KeyFrameKey>& excluded, double minScore,
                                                    const RelocalizationQueryParams& params) const {
  params.check();
  // Keyframes sharing words with the query, and how many.
  std::map<KeyFrameKey, int> common;
  for (const auto& [w, x] : query.words) {
    const auto inv = inverted_.find(w);
    if (inv == inverted_.end()) continue;
    for (KeyFrameKey kf : inv->second)
      if (!excluded.count(kf)) ++common[kf];
  }
  if (common.empty()) return {};
  int maxCommon = 0;
  for (const auto& [kf, n] : common) maxCommon = std::max(maxCommon, n);
  const double minCommon = params.minCommonWordsRatio * maxCommon;
  std::map<KeyFrameKey, PlaceCandidate> scored;
  for (const auto& [kf, n] : common) {
    if (n < minCommon) continue;
    PlaceCandidate c;
    c.keyFrame = kf;
    c.commonWords = n;
    c.score = Vocabulary::score(query, bows_.at(kf));
    scored.emplace(kf, c);
  }
  // Covisible groups: each keyframe's score plus that of its neighbours that were scored too.
  std::vector<PlaceCandidate> groups;
  double bestAcc = 0.0;
  for (const auto& [kf, c] : scored) {
    if (c.score < minScore) continue;
    PlaceCandidate best = c;
    double acc = c.score;
    if (covisible) {
      for (KeyFrameKey n : covisible(kf)) {
        const auto it = scored.find(n);
        if (it == scored.end() || n == kf) continue;
        acc += it->second.score;
        if (it->second.score > best.score) best = it->second;
      }
    }
    best.accumulatedScore = acc;
    bestAcc = std::max(bestAcc, acc);
    groups.push_back(best);
  }
  const double minAcc = params.minAccumulatedRatio * bestAcc;
  std::stable_sort(groups.begin(), groups.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    if (a.accumulatedScore != b.accumulatedScore) return a.accumulatedScore > b.accumulatedScore;
    return a.keyFrame < b.keyFrame;
  });
  std::vector<PlaceCandidate> out;
  std::set<KeyFrameKey> taken;
  for (const PlaceCandidate& g : groups) {
    if (g.accumulatedScore < minAcc) break;
    if (taken.insert(g.keyFrame).second) out.push_back(g);
  }
  return out;
}

}  // namespace pslam::places
