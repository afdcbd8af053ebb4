// slam-map: inspects and exports saved maps (thin CLI around pslam::apps in SlamMapApp.h; doc/maps.md).
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/apps/SlamMapApp.h"
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"

namespace {
/// A subcommand's result on stdout: indented JSON with --json, else its text.
template <class Result>
void print(const Result& result, bool json) {
  if (json)
    std::cout << result.toJson().dump(2) << "\n";
  else
    std::cout << result.toText();
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"Saved maps (.slammap): what is in them, and a PLY / PNG view of them"};
  cli.require_subcommand(1);
  std::string infoMap;
  bool json = false;
  CLI::App* infoCmd = cli.add_subcommand("info", "keyframes, points, camera, format version, file size, point-model statistics");
  infoCmd->add_option("map", infoMap, "map file (map.slammap of slam-run)")->required();
  infoCmd->add_flag("--json", json, "print JSON instead of text");
  pslam::apps::MapExportOptions ex;
  std::string exportMap, ply, png;
  CLI::App* exportCmd = cli.add_subcommand("export", "PLY of the points and keyframe centres, PNG top view");
  exportCmd->add_option("map", exportMap, "map file")->required();
  exportCmd->add_option("--ply", ply, "ASCII PLY: good map points (coloured by inlier ratio when the map has the point model) "
                                "and keyframe centres (red)");
  exportCmd->add_option("--png", png, "top view from above: points and the keyframe trajectory");
  // A PNG of 16384 x 16384 is already 768 MB in memory; more is no view of a map (65536 x 65536 took 12.8 GB).
  using pslam::params::cliCheck;
  exportCmd->add_option("--width", ex.pngWidth, "PNG width in pixels (200 to 16384)")
      ->check(cliCheck<int>(pslam::params::inClosed(200, 16384)))
      ->capture_default_str();
  exportCmd->add_option("--height", ex.pngHeight, "PNG height in pixels (200 to 16384)")
      ->check(cliCheck<int>(pslam::params::inClosed(200, 16384)))
      ->capture_default_str();
  std::string residualsMap;
  bool residualsJson = false;
  CLI::App* residualsCmd =
      cli.add_subcommand("residuals", "reprojection residuals per pyramid level: mean offsets (bias) and RMS");
  residualsCmd->add_option("map", residualsMap, "map file")->required();
  residualsCmd->add_flag("--json", residualsJson, "print JSON instead of text");
  pslam::apps::OptimumOptions opt;
  bool optimumJson = false;
  CLI::App* optimumCmd = cli.add_subcommand(
      "optimum", "keyframe ATE of the map, after a global BA from it and after one from the ground-truth poses");
  optimumCmd->add_option("map", opt.map, "map file")->required();
  optimumCmd->add_option("groundtruth", opt.groundTruth, "ground truth of the run (TUM, KITTI or EuRoC)")->required();
  optimumCmd->add_option("--iterations", opt.iterations, "iterations per global BA")->capture_default_str();
  optimumCmd->add_option("--segments", opt.segments, "stretches of the keyframe path for the scale spread (>= 1)")
      ->check(cliCheck<std::size_t>(pslam::params::atLeast(1)))
      ->capture_default_str();
  optimumCmd->add_option("--max-diff", opt.maxTimeDifference, "keyframe stamp to ground truth, seconds")
      ->capture_default_str();
  optimumCmd->add_flag("--json", optimumJson, "print JSON instead of text");
  CLI11_PARSE(cli, argc, argv);
  try {
    if (*infoCmd) {
      print(pslam::apps::mapInfo(infoMap), json);
    } else if (*residualsCmd) {
      print(pslam::apps::mapResiduals(residualsMap), residualsJson);
    } else if (*optimumCmd) {
      print(pslam::apps::mapOptimum(opt), optimumJson);
    } else {
      ex.map = exportMap;
      ex.ply = ply;
      ex.png = png;
      std::cout << pslam::apps::exportMap(ex).toText() << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "slam-map: error: " << pslam::oneLineMessage(e) << "\n";
    return 1;
  }
}
