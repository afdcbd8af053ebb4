#include "pslam/priors/NormalPriorsApp.h"

#include <chrono>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/Progress.h"
#include "pslam/core/StageTimer.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalSource.h"

namespace fs = std::filesystem;

namespace pslam::priors {

namespace {
fs::path groundTruthFor(const fs::path& rawlog) {
  return rawlog.parent_path() / (rawlog.stem().string() + "_groundtruth.txt");
}
}  // namespace

NormalPriorsConfig NormalPriorsConfig::loadFromFile(const fs::path& path) {
  NormalPriorsConfig c;
  if (path.empty()) return c;
  params::loadSectionsFromFile(c, path.string());
  c.normals.resolvePaths(path);
  return c;
}

NormalPriorsResult runNormalPriors(const NormalPriorsOptions& o) {
  require(!o.input.empty() && !o.output.empty(), "normal-priors", "input and output rawlogs are required");
  require(fs::is_regular_file(o.input), o.input.string(), "input rawlog not found");
  require(fs::weakly_canonical(o.input) != fs::weakly_canonical(o.output), o.output.string(),
          "output must differ from the input rawlog");
  const NormalPriorsConfig config = NormalPriorsConfig::loadFromFile(o.config);
  if (o.source == "network" && config.normals.network.model.empty() && !o.config.empty())
    throw Error(o.config.string() + ": [" + kNetworkNormalsSection +
                "] model: missing (the network normal source needs it)");
  auto source = makeNormalSource(o.source, config.normals);

  // The outputs are prepared before the work (none may be an input or replace a folder) and committed together.
  const fs::path gtIn = groundTruthFor(o.input);
  std::vector<fs::path> inputs = datasets::RawlogWriter::inputFilesOf(o.input);
  inputs.push_back(gtIn);
  inputs.push_back(o.config);
  OutputSet outputs(inputs);
  datasets::RawlogWriter writer(o.output, "png", &outputs);
  AtomicOutput* gtOut = fs::is_regular_file(gtIn) ? &outputs.add(groundTruthFor(o.output)) : nullptr;

  const std::size_t total = datasets::RawlogReader::countFrames(o.input);
  datasets::RawlogReader reader(o.input);
  Progress progress("normal-priors", total, o.progress);
  NormalPriorsResult r;
  double totalMs = 0.0, planarShareSum = 0.0;
  datasets::Frame frame;
  while (reader.next(frame)) {
    const auto t0 = std::chrono::steady_clock::now();
    const NormalMap nm = [&] {
      try {
        return source->compute(frame);
      } catch (const Error& e) {  // names the frame; the file is ours to add
        throw Error(o.input.string() + ": " + e.what());
      }
    }();
    totalMs += msSince(t0);
    frame.normals = encodeNormalMap(nm.normals, o.planarOnly ? nm.planarMask : cv::Mat());
    cv::Mat stored;
    cv::inRange(frame.normals, cv::Scalar(0, 0, 0), cv::Scalar(0, 0, 0), stored);  // the "no normal" pixels
    planarShareSum += 1.0 - cv::countNonZero(stored) / static_cast<double>(stored.total());
    writer.write(frame);
    ++r.frames;
    progress.update(r.frames, std::to_string(nm.planeCount) + " planes");
  }
  require(r.frames > 0, o.input.string(), "rawlog has no CAMERA frame");  // as every other reader of rawlogs
  writer.commit();
  if (gtOut) {
    std::ifstream in(gtIn, std::ios::binary);
    std::stringstream content;
    content << in.rdbuf();
    if (!in) throw Error(gtIn.string() + ": cannot read");
    writeOutputFile(*gtOut, [&](std::ostream& os) { os << content.str(); });
  }
  outputs.commit();
  if (r.frames > 0) {
    r.meanNormalsMs = totalMs / r.frames;
    r.meanPlanarShare = planarShareSum / r.frames;
  }
  progress.finish(std::to_string(r.frames) + " frames");
  return r;
}

}  // namespace pslam::priors
