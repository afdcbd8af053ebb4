#include "pslam/core/StageTimer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <ctime>

namespace pslam {

namespace {
double cpuClockMs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}
}  // namespace

double processCpuMs() { return cpuClockMs(CLOCK_PROCESS_CPUTIME_ID); }

double threadCpuMs() { return cpuClockMs(CLOCK_THREAD_CPUTIME_ID); }

void StageTimings::add(const std::string& stage, double ms) { samples_[stage].push_back(ms); }

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * (v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - lo) * (v[hi] - v[lo]);
}

nlohmann::json StageTimings::summary() const {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [stage, v] : samples_) {
    const double total = std::accumulate(v.begin(), v.end(), 0.0);
    out[stage] = {{"count", v.size()},
                  {"total_ms", total},
                  {"mean_ms", v.empty() ? 0.0 : total / v.size()},
                  {"median_ms", percentile(v, 50)},
                  {"p90_ms", percentile(v, 90)},
                  {"max_ms", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
  }
  return out;
}

}  // namespace pslam
