// slam-synth: renders a synthetic scenario into a rawlog with ground truth (see doc/synthetic.md).
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/synth/SynthApp.h"

int main(int argc, char** argv) {
  try {
    pslam::synth::SynthOptions o;
    // Command-line numbers: the parsing and rule of the [synth] key they set.
    const auto key = [](const char* k) { return pslam::params::cliCheckKey<pslam::synth::SynthOptions>(k); };
    CLI::App cli{"Render a synthetic monocular sequence (image, depth, semantics, normals, class ids, ground truth)"};
    std::string config, texture = "on";
    std::string scenarioHelp = "scenario preset:";
    for (const auto& n : pslam::synth::scenarioNames()) scenarioHelp += " " + n;
    cli.add_option("--config", config, "MRPT ini file with a [synth] section (command-line options override it)");
    cli.add_option("--scenario", o.scenario, scenarioHelp)->capture_default_str();
    cli.add_option("--frames", o.frames, "number of frames (0 = scenario default)")->check(key("frames"))->capture_default_str();
    cli.add_option("--width", o.width, "image width")->check(key("width"))->capture_default_str();
    cli.add_option("--height", o.height, "image height")->check(key("height"))->capture_default_str();
    cli.add_option("--fx", o.fx, "focal length x in pixels (0 = scenario default scaled to the width)")->check(key("fx"));
    cli.add_option("--fy", o.fy, "focal length y in pixels (0 = fx)")->check(key("fy"));
    cli.add_option("--cx", o.cx, "principal point x (negative = (width-1)/2)")->check(key("cx"));
    cli.add_option("--cy", o.cy, "principal point y (negative = (height-1)/2)")->check(key("cy"));
    cli.add_option("--seed", o.seed, "seed of textures, placements, traffic, jitter, noise")
        ->check(key("seed"))
        ->capture_default_str();
    cli.add_option("--path-variant", o.pathVariant,
                   "another camera path through the same scene (same seed = same world): 0 = the preset's path; "
                   "room and corridor: 1 = offset path, 2 = reversed direction")
        // The variants depend on the scenario, which may come later on the line: checked with it (SynthOptions::check).
        ->check(pslam::params::cliCheck<int>(pslam::params::atLeast(0)))
        ->capture_default_str();
    cli.add_option("--texture", texture, "on: procedural textures; off: white surfaces, shading only")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    cli.add_option("--noise", o.noiseSigma, "Gaussian image noise std in grey levels")
        ->check(key("noise_sigma"))
        ->capture_default_str();
    cli.add_flag("--exposure", o.exposure, "per-frame affine brightness change a*I+b (smooth, seeded)");
    cli.add_option("--supersampling", o.supersampling, "N x N samples per pixel for anti-aliasing")
        ->check(key("supersampling"))
        ->capture_default_str();
    cli.add_option("--anti-aliasing", o.antiAliasing,
                   "silhouettes | adaptive (outlines + sharp texture edges) | full (every pixel, ~4x slower)")
        ->check(CLI::IsMember({"silhouettes", "adaptive", "full"}))
        ->capture_default_str();
    cli.add_option("--aa-contrast", o.aaContrast, "adaptive anti-aliasing: neighbour contrast (grey levels) that "
                   "triggers texture supersampling")
        ->check(key("aa_contrast"))
        ->capture_default_str();
    cli.add_option("--out", o.outDir, "output folder")->required();
    cli.add_option("--name", o.name, "file stem of the outputs (default: the scenario name)");
    cli.add_option("--preview", o.preview, "also write a PNG panel image|depth|normals|labels of one frame");
    cli.add_option("--preview-frame", o.previewFrame, "frame index shown in --preview (-1 = middle frame)")
        ->check(key("preview_frame"))
        ->capture_default_str();
    cli.add_option("--threads", o.threads, "renderer threads (the output is identical for any count)")
        ->check(key("threads"))
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
      pslam::synth::SynthOptions fromFile;
      pslam::params::loadSectionFromFile(fromFile, config, pslam::synth::SynthOptions::kSection);
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
