// normal-priors: adds the NORMALS channel (doc/architecture.md, "Data contracts") to a rawlog, from depth or from a network.
// Thin CLI around pslam::priors::runNormalPriors (libs/priors); see doc/manhattan.md.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "pslam/priors/NormalPriorsApp.h"

int main(int argc, char** argv) {
  pslam::priors::NormalPriorsOptions opt;
  bool quiet = false, allPixels = false;
  CLI::App app{
      "normal-priors: copy a rawlog adding the NORMALS channel (camera-frame unit normals, 8-bit) to every frame.\n"
      "Sources: depth (needs DEPTH; per-pixel PCA normals + AHC-style plane segmentation, [NormalsFromDepth]) or\n"
      "network (OpenCV DNN on the CAMERA image, [NormalsFromNetwork]). <stem>_groundtruth.txt is copied along.\n"
      "Example: normal-priors in.rawlog out.rawlog --source depth --config config/manhattan/tum_fr3_depth.ini"};
  app.add_option("input", opt.input, "Input rawlog")->required();
  app.add_option("output", opt.output, "Output rawlog (its <stem>_Images/ is written beside it)")->required();
  app.add_option("--source", opt.source, "depth | network")->capture_default_str();
  app.add_option("--config", opt.config, "ini with [NormalsFromDepth] / [NormalsFromNetwork] (default: built-in)");
  app.add_flag("--all-pixels", allPixels, "Store every valid normal, not only the planar ones");
  app.add_flag("-q,--quiet", quiet, "No progress and no summary");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    opt.planarOnly = !allPixels;
    opt.progress = !quiet;
    const auto r = pslam::priors::runNormalPriors(opt);
    if (!quiet)
      std::printf("normal-priors: %zu frames -> %s, normals %.1f ms/frame, %.1f %% of pixels with a normal\n",
                  r.frames, opt.output.string().c_str(), r.meanNormalsMs, 100.0 * r.meanPlanarShare);
    return 0;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    if (const auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
    std::fprintf(stderr, "normal-priors: error: %s\n", msg.c_str());
    return 1;
  }
}
