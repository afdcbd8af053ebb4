// slam-synth: renders a synthetic scenario into a rawlog with ground truth (see doc/synthetic.md).
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>
#include <mrpt/config/CConfigFile.h>

#include "pslam/core/Error.h"
#include "pslam/synth/SynthApp.h"

int main(int argc, char** argv) {
  try {
    pslam::synth::SynthOptions o;
    CLI::App cli{"Render a synthetic monocular sequence (image, depth, semantics, normals, class ids, ground truth)"};
    std::string config, texture = "on";
    std::string scenarioHelp = "scenario preset:";
    for (const auto& n : pslam::synth::scenarioNames()) scenarioHelp += " " + n;
    cli.add_option("--config", config, "MRPT ini file with a [synth] section (command-line options override it)");
    cli.add_option("--scenario", o.scenario, scenarioHelp)->capture_default_str();
    cli.add_option("--frames", o.frames, "number of frames (0 = scenario default)")->capture_default_str();
    cli.add_option("--width", o.width, "image width")->capture_default_str();
    cli.add_option("--height", o.height, "image height")->capture_default_str();
    cli.add_option("--fx", o.fx, "focal length x in pixels (0 = scenario default scaled to the width)");
    cli.add_option("--fy", o.fy, "focal length y in pixels (0 = fx)");
    cli.add_option("--cx", o.cx, "principal point x (negative = (width-1)/2)");
    cli.add_option("--cy", o.cy, "principal point y (negative = (height-1)/2)");
    cli.add_option("--seed", o.seed, "seed of textures, placements, traffic, jitter, noise")->capture_default_str();
    cli.add_option("--texture", texture, "on: procedural textures; off: white surfaces, shading only")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    cli.add_option("--noise", o.noiseSigma, "Gaussian image noise std in grey levels")->capture_default_str();
    cli.add_flag("--exposure", o.exposure, "per-frame affine brightness change a*I+b (smooth, seeded)");
    cli.add_option("--supersampling", o.supersampling, "N x N samples per pixel for anti-aliasing")->capture_default_str();
    cli.add_option("--anti-aliasing", o.antiAliasing,
                   "silhouettes | adaptive (outlines + sharp texture edges) | full (every pixel, ~4x slower)")
        ->check(CLI::IsMember({"silhouettes", "adaptive", "full"}))
        ->capture_default_str();
    cli.add_option("--aa-contrast", o.aaContrast, "adaptive anti-aliasing: neighbour contrast (grey levels) that "
                   "triggers texture supersampling")->capture_default_str();
    cli.add_option("--out", o.outDir, "output folder")->required();
    cli.add_option("--name", o.name, "file stem of the outputs (default: the scenario name)");
    cli.add_option("--preview", o.preview, "also write a PNG panel image|depth|normals|labels of one frame");
    cli.add_option("--preview-frame", o.previewFrame, "frame index shown in --preview (-1 = middle frame)")
        ->capture_default_str();
    cli.add_option("--threads", o.threads, "renderer threads (the output is identical for any count)")
        ->capture_default_str();
    bool quiet = false;
    cli.add_flag("--quiet", quiet, "no progress line");
    // Load the ini first so that explicit command-line options win.
    cli.allow_config_extras(false);
    try {
      cli.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return cli.exit(e);
    }
    if (!config.empty()) {
      if (!std::filesystem::is_regular_file(config)) throw pslam::Error(config + ": config file not found");
      pslam::synth::SynthOptions fromFile;
      mrpt::config::CConfigFile cfg(config);
      fromFile.loadFromConfigFile(cfg, "synth");
      // Re-parse on top of the file values so that only options given on the command line override them.
      o = fromFile;
      texture = o.textured ? "on" : "off";
      cli.parse(argc, argv);
    }
    o.textured = texture == "on";
    o.progress = !quiet;
    pslam::synth::SynthApp app(o, {config});
    const auto summary = app.run();
    std::cout << summary.toText();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "slam-synth: error: " << e.what() << "\n";
    return 1;
  }
}
