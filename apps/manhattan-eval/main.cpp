// manhattan-eval: Manhattan-frame rotation tracking over a rawlog, evaluated against ground truth.
// Thin CLI around pslam::manhattan::runManhattanEval (libs/manhattan); see doc/manhattan.md.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "pslam/core/Params.h"
#include "pslam/manhattan/ManhattanEvalApp.h"

int main(int argc, char** argv) {
  pslam::manhattan::ManhattanEvalOptions opt;
  bool quiet = false;
  CLI::App app{
      "manhattan-eval: run the mean-shift Manhattan-frame tracker (thesis Algorithm 4) over a rawlog and report the\n"
      "rotation error relative to the first frame against <stem>_groundtruth.txt, the share of accepted frames,\n"
      "timings, and optionally the normal accuracy (§4.5.3) of --normals against --reference-normals.\n"
      "Example: manhattan-eval x.rawlog --normals depth --config config/manhattan/tum_fr3_depth.ini --json r.json"};
  app.add_option("rawlog", opt.rawlog, "Input rawlog")->required();
  app.add_option("--ground-truth", opt.groundTruth, "TUM ground truth (default <stem>_groundtruth.txt)");
  app.add_option("--normals", opt.normals, "Normals for the tracker: rawlog | depth | network")->capture_default_str();
  app.add_option("--reference-normals", opt.referenceNormals, "Second source for normal accuracy: rawlog|depth|network");
  app.add_option("--config", opt.config, "ini with [ManhattanTracker], [NormalsFromDepth], [NormalsFromNetwork]");
  app.add_option("--reference-config", opt.referenceConfig, "ini for the reference source (default: --config)");
  app.add_option("--accuracy-pixels", opt.accuracyPixels,
                 "Normal accuracy over: all (both sources have a normal) | reference-planar (and the reference's "
                 "planar mask is set)")
      ->check(CLI::IsMember({"all", "reference-planar"}))
      ->capture_default_str();
  app.add_option("--plot", opt.outputPlot, "Write a PNG of the per-frame rotation error");
  // Command-line numbers: the ini's strict parsing and a rule (params::cliCheck).
  using pslam::params::cliCheck;
  app.add_option("--reference-frame", opt.referenceFrame,
                 "Rotation errors relative to the first evaluated frame with index >= this")
      ->check(cliCheck<std::size_t>())
      ->capture_default_str();
  app.add_option("--normal-stride", opt.normalStride, "Pixel stride when collecting normals")
      ->check(cliCheck<int>(pslam::params::atLeast(1)))
      ->capture_default_str();
  app.add_option("--max-gt-dt", opt.maxGroundTruthDt, "Ground-truth association window (s)")
      ->check(cliCheck<double>(pslam::params::atLeast(0)))
      ->capture_default_str();
  app.add_option("--json", opt.outputJson, "Write the full report (config, per-frame, summary) as JSON");
  app.add_option("--text", opt.outputText, "Write the summary table to this file");
  app.add_flag("-q,--quiet", quiet, "No progress and no table on stdout");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    opt.progress = !quiet;
    const auto r = pslam::manhattan::runManhattanEval(opt);
    if (!quiet) std::fputs(r.text.c_str(), stdout);
    return 0;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    if (const auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
    std::fprintf(stderr, "manhattan-eval: error: %s\n", msg.c_str());
    return 1;
  }
}
