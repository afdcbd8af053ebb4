#include "pslam/priors/SemanticPriorsApp.h"

#include <cstdio>
#include <memory>
#include <optional>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/SemanticImage.h"
#include "pslam/priors/SemanticSource.h"

namespace pslam::priors {

void SemanticPriorsOptions::check() const {
  if (input.empty()) throw Error("semantic-priors: --input is required");
  if (output.empty()) throw Error("semantic-priors: --output is required");
  if (std::filesystem::weakly_canonical(input) == std::filesystem::weakly_canonical(output))
    throw Error("semantic-priors: --output must differ from --input (" + output.string() + ")");
  if (labelsDir.empty() == networkConfig.empty())
    throw Error("semantic-priors: give exactly one source: --labels <folder> or --network <ini>");
  if (!classMapFile.empty() && labelsDir.empty())
    throw Error("semantic-priors: --class-map applies to --labels (a network config names its own class map)");
  if (overlayEvery == 0) throw Error("semantic-priors: --overlay-every must be >= 1");
}

std::filesystem::path labelsDirFor(const std::filesystem::path& rawlogPath) {
  return rawlogPath.parent_path() / (rawlogPath.stem().string() + "_Labels");
}

SemanticPriorsApp::SemanticPriorsApp(SemanticPriorsOptions options) : options_(std::move(options)) {
  options_.check();
  if (options_.labelsDir == "auto") options_.labelsDir = labelsDirFor(options_.input);
}

SemanticPriorsReport SemanticPriorsApp::run() {
  const auto& o = options_;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(o.input, ec)) throw Error(o.input.string() + ": rawlog file not found");
  // The outputs are prepared before the work (none may be an input or replace a folder) and committed together.
  std::vector<std::filesystem::path> inputs = datasets::RawlogWriter::inputFilesOf(o.input);
  for (const auto& p : {o.labelsDir, o.classMapFile, o.networkConfig}) inputs.push_back(p);
  OutputSet outputs(inputs);
  datasets::RawlogWriter writer(o.output, "png", &outputs);
  AtomicOutput* overlays =
      o.overlayDir.empty() ? nullptr : &outputs.add(o.overlayDir, OutputKind::folder("overlay_[0-9]{6,}\\.png"));

  std::unique_ptr<SemanticSource> source;
  if (!o.labelsDir.empty()) {
    SemanticClassMap map = o.classMapFile.empty() ? SemanticClassMap::cityscapes()
                                                  : SemanticClassMap::loadFromFile(o.classMapFile);
    source = std::make_unique<LabelFolderSource>(o.labelsDir, std::move(map), o.labelPattern);
  } else {
    source = std::make_unique<NetworkSource>(SemanticNetworkParams::loadFromFile(o.networkConfig));
  }

  SemanticPriorsReport report;
  report.source = source->description();
  std::size_t total = datasets::RawlogReader::countFrames(o.input);
  if (o.maxFrames > 0) total = std::min(total, o.maxFrames);

  datasets::RawlogReader reader(o.input);

  Progress progress("semantic-priors", total, o.progress);
  std::array<double, kNumSemanticGroups> sum{};
  datasets::Frame frame;
  while (report.frames < total) {
    {
      ScopedStage t(report.timings, "read");
      if (!reader.next(frame)) break;
    }
    {
      ScopedStage t(report.timings, "semantic");
      frame.semantic = source->compute(frame);
    }
    const auto hist = semanticHistogram(frame.semantic);
    for (int k = 0; k < kNumSemanticGroups; ++k) sum[k] += hist[k];
    {
      ScopedStage t(report.timings, "write");
      writer.write(frame);
      if (overlays && frame.index % o.overlayEvery == 0) {
        char name[64];
        std::snprintf(name, sizeof(name), "overlay_%06zu.png", frame.index);
        const auto path = overlays->tempPath() / name;
        if (!cv::imwrite(path.string(), semanticOverlay(frame.image, frame.semantic)))
          throw Error(path.string() + ": cannot write overlay PNG");
        ++report.overlays;
      }
    }
    ++report.frames;
    char detail[96];
    std::snprintf(detail, sizeof(detail), "static %.2f dynamic %.2f invalid %.2f", hist[0], hist[1], hist[2]);
    progress.update(report.frames, detail);
  }
  if (report.frames == 0) throw Error(o.input.string() + ": rawlog has no frames");
  writer.commit();
  outputs.commit();
  for (int k = 0; k < kNumSemanticGroups; ++k) report.meanProbability[k] = sum[k] / double(report.frames);
  progress.finish(std::to_string(report.frames) + " frames -> " + o.output.string());
  return report;
}

}  // namespace pslam::priors
