#include "pslam/eval/Association.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "pslam/core/Error.h"

namespace pslam::eval {

AssociationRule parseAssociationRule(const std::string& name) {
  if (name == "nearest" || name == "evo") return AssociationRule::Nearest;
  if (name == "tum" || name == "one-to-one") return AssociationRule::OneToOneGreedy;
  if (name == "index") return AssociationRule::ByIndex;
  throw Error("association rule '" + name + "': expected nearest (evo), tum (one-to-one greedy) or index");
}

std::string toString(AssociationRule rule) {
  switch (rule) {
    case AssociationRule::Nearest: return "nearest";
    case AssociationRule::OneToOneGreedy: return "tum";
    case AssociationRule::ByIndex: return "index";
  }
  return "?";
}

namespace {

// evo: for each stamp of `query`, the first index of the minimum |target + targetOffset - stamp|.
// A linear scan (as numpy argmin) keeps the tie rule exact for unsorted inputs; sizes are a few 10^4 at most,
// so a sorted search is used only when `target` is sorted, which gives the same first-minimum index.
std::size_t nearestIndex(const std::vector<double>& target, bool targetSorted, double stamp, double& bestDiff) {
  if (targetSorted) {
    const auto it = std::lower_bound(target.begin(), target.end(), stamp);
    std::size_t hi = static_cast<std::size_t>(it - target.begin());
    // Candidates: the last element < stamp (and its first equal predecessor) and the first >= stamp.
    std::size_t best = hi < target.size() ? hi : target.size() - 1;
    bestDiff = std::abs(target[best] - stamp);
    if (hi > 0) {
      std::size_t lo = hi - 1;
      while (lo > 0 && target[lo - 1] == target[lo]) --lo;  // first of equal values, as argmin
      const double d = std::abs(target[lo] - stamp);
      if (d <= bestDiff) {  // on a tie the lower index wins
        best = lo;
        bestDiff = d;
      }
    }
    return best;
  }
  std::size_t best = 0;
  bestDiff = std::abs(target[0] - stamp);
  for (std::size_t j = 1; j < target.size(); ++j) {
    const double d = std::abs(target[j] - stamp);
    if (d < bestDiff) {
      bestDiff = d;
      best = j;
    }
  }
  return best;
}

std::string noPairsMessage(const AssociationOptions& o, std::size_t nGt, std::size_t nEst) {
  std::ostringstream ss;
  ss << "no matching timestamps between ground truth (" << nGt << " poses) and estimate (" << nEst
     << " poses) with max. time difference " << o.maxTimeDifference << " s and offset " << o.offset
     << " s (rule " << toString(o.rule) << ")";
  return ss.str();
}

}  // namespace

Association associate(const Trajectory& gt, const Trajectory& est, const AssociationOptions& o) {
  if (gt.empty()) throw Error("association: the ground-truth trajectory is empty");
  if (est.empty()) throw Error("association: the estimated trajectory is empty");
  if (!(o.maxTimeDifference >= 0.0) || !std::isfinite(o.offset))
    throw Error("association: max time difference must be >= 0 and the offset finite");
  Association a;
  if (o.rule == AssociationRule::ByIndex) {
    if (gt.size() != est.size())
      throw Error("association by index: ground truth has " + std::to_string(gt.size()) +
                  " poses but the estimate has " + std::to_string(est.size()));
    for (std::size_t k = 0; k < gt.size(); ++k) {
      a.gtIndex.push_back(k);
      a.estIndex.push_back(k);
    }
    return a;
  }

  std::vector<double> tGt(gt.size()), tEst(est.size());
  for (std::size_t k = 0; k < gt.size(); ++k) tGt[k] = gt[k].timestamp;
  for (std::size_t k = 0; k < est.size(); ++k) tEst[k] = est[k].timestamp + o.offset;

  if (o.rule == AssociationRule::Nearest) {
    // evo: the second trajectory (estimate) is the longer one only if strictly longer.
    const bool estLonger = est.size() > gt.size();
    const std::vector<double>& query = estLonger ? tGt : tEst;
    const std::vector<double>& target = estLonger ? tEst : tGt;
    const bool sorted = std::is_sorted(target.begin(), target.end());
    for (std::size_t i = 0; i < query.size(); ++i) {
      double diff = 0.0;
      const std::size_t j = nearestIndex(target, sorted, query[i], diff);
      if (diff <= o.maxTimeDifference) {
        a.gtIndex.push_back(estLonger ? i : j);
        a.estIndex.push_back(estLonger ? j : i);
      }
    }
  } else {
    // TUM associate.py: greedy one-to-one by smallest |dt| (strict < maxDiff), ties by (gt, est) stamp.
    std::vector<std::size_t> estOrder(est.size());
    for (std::size_t k = 0; k < est.size(); ++k) estOrder[k] = k;
    std::sort(estOrder.begin(), estOrder.end(), [&](std::size_t x, std::size_t y) { return tEst[x] < tEst[y]; });
    std::vector<double> tEstSorted(est.size());
    for (std::size_t k = 0; k < est.size(); ++k) tEstSorted[k] = tEst[estOrder[k]];
    std::vector<std::tuple<double, double, double, std::size_t, std::size_t>> candidates;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      auto lo = std::lower_bound(tEstSorted.begin(), tEstSorted.end(), tGt[i] - o.maxTimeDifference);
      for (auto it = lo; it != tEstSorted.end() && *it <= tGt[i] + o.maxTimeDifference; ++it) {
        const double d = std::abs(tGt[i] - *it);
        if (d < o.maxTimeDifference) {
          const std::size_t j = estOrder[static_cast<std::size_t>(it - tEstSorted.begin())];
          // Sort key as in the script: (diff, gt stamp, est stamp before the offset).
          candidates.emplace_back(d, gt[i].timestamp, est[j].timestamp, i, j);
        }
      }
    }
    std::sort(candidates.begin(), candidates.end());
    std::vector<bool> gtUsed(gt.size(), false), estUsed(est.size(), false);
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for (const auto& c : candidates) {
      const std::size_t i = std::get<3>(c), j = std::get<4>(c);
      if (gtUsed[i] || estUsed[j]) continue;
      gtUsed[i] = estUsed[j] = true;
      pairs.emplace_back(i, j);
    }
    std::sort(pairs.begin(), pairs.end(), [&](const auto& x, const auto& y) {
      return std::make_pair(gt[x.first].timestamp, est[x.second].timestamp) <
             std::make_pair(gt[y.first].timestamp, est[y.second].timestamp);
    });
    for (const auto& [i, j] : pairs) {
      a.gtIndex.push_back(i);
      a.estIndex.push_back(j);
    }
  }
  if (a.size() == 0) throw Error(noPairsMessage(o, gt.size(), est.size()));
  return a;
}

void selectAssociated(const Trajectory& gt, const Trajectory& est, const Association& association,
                      Trajectory& gtOut, Trajectory& estOut) {
  gtOut.clear();
  estOut.clear();
  for (std::size_t k = 0; k < association.size(); ++k) {
    gtOut.push_back(gt.at(association.gtIndex[k]));
    estOut.push_back(est.at(association.estIndex[k]));
  }
}

}  // namespace pslam::eval
