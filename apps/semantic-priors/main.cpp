// semantic-priors: reads a rawlog, adds the SEMANTIC channel (Table 3.1 classes) to every frame from
// ground-truth label images or a segmentation network, writes a new rawlog. Thin CLI around
// pslam::priors::SemanticPriorsApp.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "pslam/core/Params.h"
#include "pslam/priors/SemanticPriorsApp.h"

int main(int argc, char** argv) {
  CLI::App cli{"Add the SEMANTIC channel (static/dynamic/invalid probabilities) to a rawlog"};
  pslam::priors::SemanticPriorsOptions o;
  std::string input, output, labels, classMap, network, overlays;
  bool quiet = false;
  cli.add_option("input", input, "input rawlog")->required();
  cli.add_option("output", output, "output rawlog (images re-written into <stem>_Images)")->required();
  cli.add_option("--labels", labels, "folder of 8-bit label images (one-hot SEMANTIC); auto = <input stem>_Labels beside the input");
  cli.add_option("--label-pattern", o.labelPattern, "label file name pattern, printf of the frame index")
      ->capture_default_str();
  cli.add_option("--class-map", classMap, "class-map ini for --labels (default: Cityscapes trainIds, Table 3.1)");
  cli.add_option("--network", network, "network ini, e.g. config/semantic/enet_cityscapes_kitti.ini");
  cli.add_option("--overlay-dir", overlays, "write colour overlay PNGs (green static, red dynamic, blue invalid)");
  cli.add_option("--overlay-every", o.overlayEvery, "overlay every n-th frame")
      ->check(pslam::params::cliCheck<std::size_t>(pslam::params::atLeast(1)))
      ->capture_default_str();
  cli.add_option("--max-frames", o.maxFrames, "process only the first N frames (0 = all)")
      ->check(pslam::params::cliCheck<std::size_t>())
      ->capture_default_str();
  cli.add_flag("--quiet", quiet, "no progress output");
  CLI11_PARSE(cli, argc, argv);
  try {
    o.input = input;
    o.output = output;
    o.labelsDir = labels;
    o.classMapFile = classMap;
    o.networkConfig = network;
    o.overlayDir = overlays;
    o.progress = !quiet;
    const auto report = pslam::priors::SemanticPriorsApp(o).run();
    const auto t = report.timings.summary();
    std::cout << "frames: " << report.frames << "\nsource: " << report.source
              << "\nmean P(static, dynamic, invalid): " << report.meanProbability[0] << " "
              << report.meanProbability[1] << " " << report.meanProbability[2]
              << "\nsemantic ms/frame (median): " << t["semantic"]["median_ms"].get<double>() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "semantic-priors: error: " << e.what() << "\n";
    return 1;
  }
}
