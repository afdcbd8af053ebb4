// bench-features: per-stage timings of the ORB extractor vs cv::ORB on an image or a folder of images.
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/core/Params.h"
#include "pslam/features/BenchFeatures.h"

int main(int argc, char** argv) {
  CLI::App app{"Per-stage timings (median, p90) of the ORB-SLAM style extractor vs cv::ORB"};
  pslam::features::BenchFeaturesOptions o;
  std::string input, json;
  app.add_option("input", input, "image file or folder of images")->required();
  // Command-line numbers: the ini's strict parsing; the extractor's options by the rule of their [ORB] key.
  using pslam::params::cliCheck;
  const auto orbKey = [](const char* k) { return pslam::params::cliCheckKey<pslam::features::OrbParams>(k); };
  app.add_option("--runs", o.runs, "timed runs per image")
      ->check(cliCheck<int>(pslam::params::atLeast(1)))
      ->capture_default_str();
  app.add_option("--max-images", o.maxImages, "images taken from a folder (sorted by name)")
      ->check(cliCheck<int>(pslam::params::atLeast(1)))
      ->capture_default_str();
  app.add_option("--features", o.orb.nFeatures, "target number of features")
      ->check(orbKey("nFeatures"))
      ->capture_default_str();
  app.add_option("--levels", o.orb.nLevels, "pyramid levels")->check(orbKey("nLevels"))->capture_default_str();
  app.add_option("--scale-factor", o.orb.scaleFactor, "pyramid scale factor")
      ->check(orbKey("scaleFactor"))
      ->capture_default_str();
  app.add_option("--threads", o.orb.threads, "threads sharing out the pyramid levels")
      ->check(orbKey("threads"))
      ->capture_default_str();
  app.add_flag("--literal-cell-fast", o.orb.literalCellFast, "ORB-SLAM's one FAST call per cell (reference)");
  app.add_option("--direct", o.directPoints, "also time DSO-style direct point selection with this target (0 = off)")
      ->check(cliCheck<int>(pslam::params::atLeast(0)))
      ->capture_default_str();
  app.add_flag("--no-opencv", [&o](int64_t) { o.compareOpenCv = false; }, "do not time cv::ORB");
  app.add_option("--json", json, "also write the summary to this JSON file");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "bench-features: error: " << e.what() << "\n";
    return 1;
  }
  try {
    o.input = input;
    o.jsonOutput = json;
    pslam::features::BenchFeaturesApp(o).run(std::cout);
  } catch (const std::exception& e) {
    std::cerr << "bench-features: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
