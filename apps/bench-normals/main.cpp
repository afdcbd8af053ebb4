// bench-normals: accuracy and speed of a normal network through OpenCV DNN on a normals-dataset split
// (see doc/normals_network.md).
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "pslam/core/Params.h"
#include "pslam/priors/BenchNormals.h"

int main(int argc, char** argv) {
  pslam::priors::BenchNormalsOptions o;
  CLI::App app{
      "bench-normals: normal accuracy (thesis eqs. 4.3-4.7, planar pixels, per scenario) and time per frame of the\n"
      "[NormalsFromNetwork] model through OpenCV DNN on a split folder written by normals-dataset.\n"
      "Example: bench-normals --config config/manhattan/network_normals.ini --data /tmp/normals-data/test"};
  using pslam::params::cliCheck;
  app.add_option("--config", o.config, "ini with [NormalsFromNetwork]")->required();
  app.add_option("--data", o.data, "split folder of normals-dataset (manifest.csv + PNG triples)")->required();
  app.add_option("--max-views", o.maxViews, "evaluate only the first N views (0 = all)")->capture_default_str();
  app.add_option("--threads", o.threads, "OpenCV threads")->check(cliCheck<int>(pslam::params::inClosed(1, 256)))
      ->capture_default_str();
  app.add_option("--runs", o.runs, "timed runs (after one warm-up)")->check(cliCheck<int>(pslam::params::atLeast(1)))
      ->capture_default_str();
  app.add_option("--frame-width", o.frameWidth, "width of the full-size frame timed")
      ->check(cliCheck<int>(pslam::params::inClosed(8, 8192)))
      ->capture_default_str();
  app.add_option("--frame-height", o.frameHeight, "height of the full-size frame timed")
      ->check(cliCheck<int>(pslam::params::inClosed(8, 8192)))
      ->capture_default_str();
  app.add_option("--panel", o.panel, "write a PNG panel input | prediction | ground truth | error");
  app.add_option("--panel-views", o.panelViews, "views in the panel")->check(cliCheck<int>(pslam::params::atLeast(1)))
      ->capture_default_str();
  app.add_option("--json", o.json, "write the report as JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    const auto r = pslam::priors::runBenchNormals(o);
    std::fputs(r.toText().c_str(), stdout);
    return 0;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    if (const auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
    std::fprintf(stderr, "bench-normals: error: %s\n", msg.c_str());
    return 1;
  }
}
