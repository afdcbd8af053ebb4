#pragma once
// Shared by the slam-batch CLI tests: two short synthetic rawlogs rendered once per test process (the room and
// the street of slam-synth), a manifest over them, and running the built tool.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "pslam/synth/SynthApp.h"

namespace batchtest {
namespace fs = std::filesystem;

inline const fs::path kBin = fs::path(PRIORSLAM_BINARY_DIR) / "bin";
inline const fs::path kSource = fs::path(PRIORSLAM_SOURCE_DIR);

struct TempRoot {
  fs::path path;
  explicit TempRoot(const std::string& prefix)
      : path(fs::temp_directory_path() / (prefix + std::to_string(::getpid()))) {
    fs::create_directories(path);
  }
  ~TempRoot() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

/// Renders `frames` frames of a slam-synth scenario into root/<scenario>; returns the rawlog path.
inline fs::path render(const fs::path& root, const std::string& scenario, int frames, std::uint32_t seed) {
  pslam::synth::SynthOptions o;
  o.scenario = scenario;
  o.frames = frames;
  o.seed = seed;
  o.noiseSigma = 1.0;
  o.outDir = root / scenario;
  o.progress = false;
  return pslam::synth::SynthApp(o).run().rawlog;
}

inline fs::path groundTruthOf(const fs::path& rawlog) {
  return rawlog.parent_path() / (rawlog.stem().string() + "_groundtruth.txt");
}

struct Dataset {
  std::string name;
  fs::path rawlog;
};

/// A manifest over `datasets` with the heuristic and the probabilistic point models (one seed), written to
/// root/<file>. `probabilisticExtra` is appended to the probabilistic variant's overrides.
inline fs::path writeManifest(const fs::path& root, const std::string& file, const std::vector<Dataset>& datasets,
                              const std::string& probabilisticExtra = "") {
  std::ostringstream m;
  m << "name: e2e\noutput: out\ndatasets:\n";
  for (const Dataset& d : datasets)
    m << "  - name: " << d.name << "\n    rawlog: " << d.rawlog.string() << "\n    groundtruth: "
      << groundTruthOf(d.rawlog).string() << "\n    config: " << (kSource / "config/slam/synthetic.ini").string()
      << "\n";
  m << "variants:\n  - name: heuristic\n    set: [PointModel.model=heuristic]\n"
    << "  - name: probabilistic\n    set: [PointModel.model=probabilistic, PointModel.semantic=false"
    << probabilisticExtra << "]\nseeds: [1]\n";
  const fs::path p = root / file;
  std::ofstream(p) << m.str();
  return p;
}

inline std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct ToolResult {
  int exitCode = -1;
  std::string output;  ///< stdout + stderr
};

/// Runs a shell command line, capturing its output.
inline ToolResult run(const std::string& commandLine) {
  ToolResult r;
  const std::string cmd = commandLine + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int st = ::pclose(pipe);
  r.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return r;
}

inline std::string batch(const std::string& args) { return (kBin / "slam-batch").string() + " " + args; }

}  // namespace batchtest
