// normals-dataset: renders image + normal + planar-mask triples of the indoor synthetic scenarios for the
// monocular normal network (see doc/normals_network.md).
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "pslam/core/Params.h"
#include "pslam/synth/NormalsDataset.h"

int main(int argc, char** argv) {
  try {
    pslam::synth::NormalsDatasetOptions o;
    const auto key = [](const char* k) { return pslam::params::cliCheckKey<pslam::synth::NormalsDatasetOptions>(k); };
    CLI::App cli{
        "normals-dataset: randomized views of synthetic scenes as image + normal + planar-mask PNG triples,\n"
        "split into train/ and test/ by scene seed (see doc/normals_network.md).\n"
        "Example: normals-dataset --out /tmp/normals-data --train-seeds 24 --test-seeds 3 --views 40"};
    std::string config;
    bool quiet = false, fixedLighting = false;
    cli.add_option("--config", config, "MRPT ini file with a [normals_dataset] section (options override it)");
    cli.add_option("--out", o.outDir, "output folder (train/, test/, dataset.json)")->required();
    cli.add_option("--scenarios", o.scenarios, "comma-separated scenario presets")
        ->check(key("scenarios"))
        ->capture_default_str();
    cli.add_option("--first-train-seed", o.firstTrainSeed, "first training seed")
        ->check(key("first_train_seed"))
        ->capture_default_str();
    cli.add_option("--train-seeds", o.trainSeeds, "training seeds per scenario")
        ->check(key("train_seeds"))
        ->capture_default_str();
    cli.add_option("--first-test-seed", o.firstTestSeed, "first held-out seed")
        ->check(key("first_test_seed"))
        ->capture_default_str();
    cli.add_option("--test-seeds", o.testSeeds, "held-out seeds per scenario")->check(key("test_seeds"))->capture_default_str();
    cli.add_option("--views", o.views, "views per sequence (scenario + seed)")->check(key("views"))->capture_default_str();
    cli.add_option("--width", o.width, "image width")->check(key("width"))->capture_default_str();
    cli.add_option("--height", o.height, "image height")->check(key("height"))->capture_default_str();
    cli.add_option("--focal-min", o.focalMin, "smallest focal length factor on the scenario's default")
        ->check(key("focal_min"))
        ->capture_default_str();
    cli.add_option("--focal-max", o.focalMax, "largest focal length factor")->check(key("focal_max"))->capture_default_str();
    cli.add_option("--untextured-share", o.untexturedShare, "share of sequences with white surfaces")
        ->check(key("untextured_share"))
        ->capture_default_str();
    cli.add_option("--max-tilt", o.maxTiltDeg, "extra camera roll/pitch/yaw, uniform in +- this (deg)")
        ->check(key("max_tilt_deg"))
        ->capture_default_str();
    cli.add_option("--look-down-share", o.lookDownShare, "share of views that also look down at floor and furniture")
        ->check(key("look_down_share"))
        ->capture_default_str();
    cli.add_option("--look-down-min", o.lookDownMinDeg, "smallest extra downward pitch of those (deg)")
        ->check(key("look_down_min_deg"))
        ->capture_default_str();
    cli.add_option("--look-down-max", o.lookDownMaxDeg, "largest extra downward pitch of those (deg)")
        ->check(key("look_down_max_deg"))
        ->capture_default_str();
    cli.add_flag("--fixed-lighting", fixedLighting, "keep the scenarios' lighting (no light randomization)");
    cli.add_option("--max-exposure-gain", o.maxExposureGain, "exposure gain uniform in 1 +- this")
        ->check(key("max_exposure_gain"))
        ->capture_default_str();
    cli.add_option("--max-exposure-offset", o.maxExposureOffset, "exposure offset uniform in +- this (grey levels)")
        ->check(key("max_exposure_offset"))
        ->capture_default_str();
    cli.add_option("--max-noise", o.maxNoise, "noise std uniform in [0, this] grey levels")
        ->check(key("max_noise"))
        ->capture_default_str();
    cli.add_option("--blur-share", o.blurShare, "share of blurred views")->check(key("blur_share"))->capture_default_str();
    cli.add_option("--max-blur", o.maxBlurSigma, "blur sigma uniform in [0.3, this] pixels")
        ->check(key("max_blur_sigma"))
        ->capture_default_str();
    cli.add_option("--supersampling", o.supersampling, "N x N samples per anti-aliased pixel")
        ->check(key("supersampling"))
        ->capture_default_str();
    cli.add_option("--threads", o.threads, "renderer threads (the output is identical for any count)")
        ->check(key("threads"))
        ->capture_default_str();
    cli.add_flag("-q,--quiet", quiet, "no progress line");
    try {
      cli.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return cli.exit(e);
    }
    if (!config.empty()) {
      // Re-parse on top of the file values so that only options given on the command line override them.
      pslam::synth::NormalsDatasetOptions fromFile;
      pslam::params::loadSectionFromFile(fromFile, config, pslam::synth::NormalsDatasetOptions::kSection);
      o = fromFile;
      cli.parse(argc, argv);
    }
    if (fixedLighting) o.randomLighting = false;
    o.progress = !quiet;
    const auto sum = pslam::synth::NormalsDataset(o).run();
    if (!quiet)
      std::printf("normals-dataset: %zu train + %zu held-out views in %.1f s, %.1f %% planar pixels -> %s\n",
                  sum.trainViews, sum.testViews, sum.seconds, 100.0 * sum.meanMaskShare, o.outDir.string().c_str());
    return 0;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    if (const auto nl = msg.find('\n'); nl != std::string::npos) msg = msg.substr(0, nl);
    std::fprintf(stderr, "normals-dataset: error: %s\n", msg.c_str());
    return 1;
  }
}
