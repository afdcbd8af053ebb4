// match-oracle: how many ORB correspondences ground truth allows between frames of a rawlog (doc/features.md).
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/core/Params.h"
#include "pslam/features/MatchOracleApp.h"

int main(int argc, char** argv) {
  CLI::App app{
      "match-oracle: for frame pairs (k, k+s) of a rawlog with DEPTH and ground truth, the ORB keypoints of frame k\n"
      "moved into frame k+s by the true poses, and how many find a keypoint there (repeated), a descriptor within\n"
      "--max-hamming (matchable) and the whole-image nearest neighbour (found_nn). An upper bound on what any ORB\n"
      "tracker can match between two views. Per pyramid level, where the matchable correspondences land against\n"
      "the true transfer (mean, RMS, median and 90th percentile in level pixels): how repeatably keypoints sit.\n"
      "Example: match-oracle cabinet.rawlog --config config/slam/structure.ini --steps 2 --json oracle.json"};
  pslam::features::MatchOracleOptions o;
  std::string rawlog, gt, config, json, plot;
  using pslam::params::cliCheck;
  using pslam::params::atLeast;
  app.add_option("rawlog", rawlog, "input rawlog with a DEPTH channel")->required();
  app.add_option("--ground-truth", gt, "TUM ground truth (default <stem>_groundtruth.txt)");
  app.add_option("--config", config, "SLAM ini whose [ORB] section sets the extractor")->required();
  app.add_option("--set", o.overrides, "override an ini key, Section.key=value (repeatable)");
  app.add_option("--steps", o.steps, "pairs (k, k+s) for s = 1..steps")->capture_default_str();
  app.add_option("--radius", o.radius, "search radius in pixels at level 0 (times the level scale)")
      ->capture_default_str();
  app.add_option("--max-hamming", o.maxHamming, "largest descriptor distance of a match")->capture_default_str();
  app.add_option("--ratio", o.ratio, "nearest-neighbour ratio of the whole-image search")->capture_default_str();
  app.add_option("--depth-tolerance", o.depthTolerance, "relative depth margin of the occlusion test")
      ->capture_default_str();
  app.add_option("--max-gt-dt", o.maxGroundTruthDt, "ground-truth association window (s)")->capture_default_str();
  app.add_option("--min-matches", o.minMatches, "count the pairs with at least this many matchable")
      ->capture_default_str();
  app.add_flag("--align", o.align,
               "also align each matchable second keypoint to the first keypoint's patch (warp from the true poses "
               "and depth; features::alignPatch's default parameters) and report where the aligned positions land");
  app.add_option("--json", json, "write the options, per-pair counts and per-step summary as JSON");
  app.add_option("--plot", plot, "write a PNG of the counts of neighbouring frames (k, k+1)");
  app.add_flag("-q,--quiet", [&o](int64_t) { o.progress = false; }, "no progress on stderr");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "match-oracle: error: " << e.what() << "\n";
    return 1;
  }
  try {
    o.rawlog = rawlog;
    o.groundTruth = gt;
    o.config = config;
    o.outputJson = json;
    o.outputPlot = plot;
    const auto result = pslam::features::runMatchOracle(o);
    std::cout << result.text;
  } catch (const std::exception& e) {
    std::cerr << "match-oracle: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
