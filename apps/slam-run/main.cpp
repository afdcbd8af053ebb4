// slam-run: monocular SLAM on a rawlog (thin CLI around pslam::apps::SlamRunApp, which drives the System façade).
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/apps/SlamRunApp.h"
#include "pslam/core/Params.h"

int main(int argc, char** argv) {
  CLI::App cli{"Monocular SLAM on a rawlog: trajectory.txt, keyframes.txt, map.slammap, depths.txt, report.json.\n"
               "With --map-in it continues on a saved map (--localization: tracking in the fixed map only)."};
  pslam::apps::SlamRunOptions o;
  std::string config, rawlog, out;
  long long first = 0;
  bool quiet = false;
  cli.add_option("--config", config, "MRPT ini file (config/slam/*.ini)")->required();
  cli.add_option("--set", o.overrides,
                 "override one ini value, Section.key=value (repeatable), e.g. --set PointModel.model=probabilistic");
  cli.add_option("--rawlog", rawlog, "input rawlog (doc/architecture.md, Data contracts)")->required();
  cli.add_option("--out", out, "output folder")->required();
  using pslam::params::cliCheck;
  cli.add_option("--seed", o.seed, "seed of all random processes (default 0)")->check(cliCheck<decltype(o.seed)>());
  cli.add_option("--first", first, "first frame index (0-based)")
      ->check(cliCheck<long long>(pslam::params::atLeast(0)));
  cli.add_option("--last", o.last, "last frame index (inclusive; default: the end)")->check(cliCheck<long long>());
  cli.add_flag("--threaded", o.threaded, "local mapping in a second thread (not deterministic)");
  cli.add_flag("--realtime", o.realtime,
               "hand frames over at the pace of their timestamps, as a live camera (none dropped; late ones counted)");
  cli.add_option("--realtime-max-wait", o.realtimeMaxWait,
                 "with --realtime: the longest wait for one frame, in seconds (a longer gap in the stamps is cut "
                 "to it, with a warning)")
      ->check(cliCheck<double>(pslam::params::atLeast(0.0)))
      ->capture_default_str();
  cli.add_flag("--sort-stamps", o.sortStamps,
               "read frames whose stamps go back or repeat in stamp order, with a warning (default: an error)");
  std::string mapIn;
  cli.add_option("--map-in", mapIn,
                 "start from this saved map (map.slammap of an earlier run): relocalize in it, then extend it");
  cli.add_flag("--localization", o.localization,
               "with --map-in: the map stays fixed (no keyframes, no changes); frames are only localized in it");
  cli.add_flag("-q,--quiet", quiet, "no progress output");
  CLI11_PARSE(cli, argc, argv);
  try {
    o.config = config;
    o.rawlog = rawlog;
    o.outDir = out;
    o.mapIn = mapIn;
    o.first = static_cast<std::size_t>(first);
    o.progress = !quiet;
    pslam::apps::SlamRunApp app(o);
    const auto s = app.run();
    if (!s.vocabularyWarning.empty()) std::cerr << "slam-run: warning: " << s.vocabularyWarning << "\n";
    for (const std::string& w : s.warnings) std::cerr << "slam-run: warning: " << w << "\n";
    if (!s.hasMap())
      std::cerr << "slam-run: warning: initialization never succeeded; wrote an empty trajectory\n";
    else if (s.mapLoaded && s.framesLocalized == 0)
      std::cerr << "slam-run: warning: no frame was localized in the loaded map; wrote an empty trajectory\n";
    std::cout << s.toText() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "slam-run: error: " << e.what() << "\n";
    return 1;
  }
}
