#pragma once
// The short synthetic room clip and the slam-run call that the SLAM e2e tests share (header only).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pslam/apps/SlamRunApp.h"
#include "pslam/synth/SynthApp.h"

namespace pslam::test_support {

/// The SLAM config of the synthetic clips.
inline const std::filesystem::path kSyntheticConfig =
    std::filesystem::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";

/// The first `frames` frames of the room scenario (translation first: parallax for initialization) at 640x480 (at
/// 320x240 too few level-0 corners match for the two-view initialization), rendered into `folder`; returns the
/// rawlog.
inline std::filesystem::path renderRoomClip(const std::filesystem::path& folder, int frames = 60) {
  synth::SynthOptions o;
  o.scenario = "room";
  o.frames = frames;
  o.seed = 3;
  o.noiseSigma = 1.0;
  o.outDir = folder;
  o.progress = false;
  return synth::SynthApp(o).run().rawlog;
}

/// slam-run (the app class) on `rawlog` into `out`.
inline apps::SlamRunSummary runSlamRun(const std::filesystem::path& out, const std::filesystem::path& rawlog,
                                       std::uint32_t seed = 1, bool threaded = false,
                                       const std::filesystem::path& config = kSyntheticConfig,
                                       const std::vector<std::string>& overrides = {}) {
  apps::SlamRunOptions o;
  o.overrides = overrides;
  o.config = config;
  o.rawlog = rawlog;
  o.outDir = out;
  o.seed = seed;
  o.threaded = threaded;
  o.progress = false;
  return apps::SlamRunApp(o).run();
}

}  // namespace pslam::test_support
