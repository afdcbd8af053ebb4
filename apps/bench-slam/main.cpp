// bench-slam: per-stage timings and per-frame wall / process-CPU time of the sequential SLAM on a rawlog.
#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/StageTimer.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"

int main(int argc, char** argv) {
  CLI::App cli{"Benchmark of slam-run's sequential pipeline: per-stage and per-frame timings"};
  std::string config, rawlog;
  std::vector<std::string> overrides;
  long long first = 0, last = -1;
  unsigned seed = 0;
  cli.add_option("--config", config, "MRPT ini (config/slam/*.ini)")->required();
  cli.add_option("--set", overrides, "override one ini value, Section.key=value (repeatable)");
  cli.add_option("--rawlog", rawlog, "input rawlog")->required();
  using pslam::params::cliCheck;
  cli.add_option("--first", first, "first frame")->check(cliCheck<long long>(pslam::params::atLeast(0)));
  cli.add_option("--last", last, "last frame (inclusive)")->check(cliCheck<long long>());
  cli.add_option("--seed", seed, "seed")->check(cliCheck<unsigned>());
  CLI11_PARSE(cli, argc, argv);
  try {
    using namespace pslam;
    system::SystemOptions options;
    options.seed = seed;
    options.threaded = false;  // per-frame CPU time includes the frame's local mapping
    system::System slam(system::loadSlamParams(config, overrides), options);
    datasets::RawlogReader reader(rawlog, system::System::channelsUsed(slam.params()));
    StageTimings perFrame;
    datasets::Frame f;
    std::size_t n = 0;
    while (reader.next(f)) {
      if (static_cast<long long>(f.index) < first) continue;
      if (last >= 0 && static_cast<long long>(f.index) > last) break;
      const double cpu0 = system::processCpuSeconds();
      const auto t0 = std::chrono::steady_clock::now();
      try {
        slam.track(f);
      } catch (const Error& e) {
        throw Error(rawlog + ": " + e.what());
      }
      perFrame.add("frame_wall", msSince(t0));
      perFrame.add("frame_cpu", (system::processCpuSeconds() - cpu0) * 1e3);
      ++n;
    }
    if (n == 0) throw Error(rawlog + ": no frame in range");
    StageTimings all = slam.timings();
    for (const auto& [stage, v] : perFrame.samples())
      for (double x : v) all.add(stage, x);
    // Tracking time per frame = everything except local mapping (which ORB-SLAM runs in another thread).
    const auto& s = all.samples();
    std::cout << "frames " << n << "\n" << std::left << std::setw(20) << "stage" << std::right << std::setw(8) << "count"
              << std::setw(11) << "mean_ms" << std::setw(11) << "median_ms" << std::setw(11) << "p90_ms" << std::setw(11)
              << "total_ms" << "\n" << std::fixed << std::setprecision(2);
    for (const auto& [stage, v] : s) {
      double tot = 0;
      for (double x : v) tot += x;
      std::cout << std::left << std::setw(20) << stage << std::right << std::setw(8) << v.size() << std::setw(11)
                << tot / v.size() << std::setw(11) << percentile(v, 50) << std::setw(11) << percentile(v, 90)
                << std::setw(11) << tot << "\n";
    }
    std::cout << "json " << all.summary().dump() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "bench-slam: error: " << e.what() << "\n";
    return 1;
  }
}
