// MapPoint::landmarkState is an opaque vector of doubles for the map (it stores and serializes it); the
// layout below is owned by local mapping, the only writer of the probabilistic state.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "pslam/core/Error.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping {
namespace {
// mu, sigma2, aObs, bObs, semanticNll[3], depthUpdates, semanticUpdates
constexpr std::size_t kEncodedSize = 4 + landmarks::kNumSemanticClasses + 2;
}  // namespace

std::vector<double> encodeKeypointState(const landmarks::KeypointState& s) {
  std::vector<double> v{s.mu, s.sigma2, s.aObs, s.bObs};
  for (double nll : s.semanticNll) v.push_back(nll);
  v.push_back(static_cast<double>(s.depthUpdates));
  v.push_back(static_cast<double>(s.semanticUpdates));
  return v;
}

landmarks::KeypointState decodeKeypointState(const std::vector<double>& v, const std::string& context) {
  if (v.size() != kEncodedSize)
    throw Error(context + ": landmark state has " + std::to_string(v.size()) + " values, expected " +
                std::to_string(kEncodedSize));
  for (double x : v)
    if (!std::isfinite(x)) throw Error(context + ": landmark state holds a non-finite value");
  landmarks::KeypointState s;
  s.mu = v[0];
  s.sigma2 = v[1];
  s.aObs = v[2];
  s.bObs = v[3];
  for (int k = 0; k < landmarks::kNumSemanticClasses; ++k) s.semanticNll[k] = v[4 + k];
  const double depthUpdates = v[4 + landmarks::kNumSemanticClasses];
  const double semanticUpdates = v[5 + landmarks::kNumSemanticClasses];
  if (depthUpdates < 0 || semanticUpdates < 0)
    throw Error(context + ": landmark state has a negative update count");
  // A count beyond uint32 would make the conversion below undefined (e.g. from a corrupt map file).
  constexpr double kMaxCount = static_cast<double>(std::numeric_limits<std::uint32_t>::max());
  if (depthUpdates > kMaxCount || semanticUpdates > kMaxCount)
    throw Error(context + ": landmark state has an implausible update count");
  s.depthUpdates = static_cast<std::uint32_t>(depthUpdates);
  s.semanticUpdates = static_cast<std::uint32_t>(semanticUpdates);
  if (!landmarks::isValidState(s)) throw Error(context + ": invalid landmark state (sigma2 or counts <= 0)");
  return s;
}

}  // namespace pslam::mapping
