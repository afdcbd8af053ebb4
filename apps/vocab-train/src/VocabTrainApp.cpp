#include "pslam/apps/VocabTrainApp.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"
#include "pslam/core/Params.h"
#include "pslam/core/Progress.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;

namespace pslam::apps {

namespace {

std::vector<fs::path> imagesIn(const fs::path& folder) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(folder)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

void VocabTrainOptions::check() const {
  if (rawlogs.empty() && imageFolders.empty()) throw Error("vocab-train: no input (give --rawlog and/or --images)");
  if (every == 0) throw Error("vocab-train: --every must be >= 1");
  if (out.empty()) throw Error("vocab-train: no output file (--out)");
  for (const auto& r : rawlogs)
    if (!fs::is_regular_file(r)) throw Error(r.string() + ": rawlog not found");
  for (const auto& f : imageFolders)
    if (!fs::is_directory(f)) throw Error(f.string() + ": image folder not found");
  if (!config.empty() && !fs::is_regular_file(config)) throw Error(config.string() + ": config file not found");
  vocabulary.check();
}

std::string VocabTrainResult::toText() const {
  std::ostringstream s;
  s << "images " << images << ", descriptors " << descriptors << " -> " << words << " words (" << nodes
    << " nodes), " << fileBytes << " bytes; extraction " << extractSeconds << " s, training " << trainSeconds << " s";
  return s.str();
}

VocabTrainResult trainVocabulary(const VocabTrainOptions& options) {
  options.check();
  // The output is prepared before any work, against every input: a rawlog (with its images), each image of the
  // folders, the config (`--out` onto any of them replaced it with a vocabulary).
  std::vector<fs::path> inputs;
  for (const auto& rawlog : options.rawlogs) {
    for (const auto& p : datasets::RawlogWriter::inputFilesOf(rawlog)) inputs.push_back(p);
    // The files inside its images folder too: an output there would replace one of the rawlog's images.
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(datasets::RawlogWriter::imagesDirFor(rawlog), ec))
      inputs.push_back(e.path());
  }
  for (const auto& folder : options.imageFolders)
    for (const auto& p : imagesIn(folder)) inputs.push_back(p);
  inputs.push_back(options.config);
  OutputSet outputs(inputs);
  AtomicOutput& out = outputs.add(options.out);
  features::OrbParams orb;
  if (!options.config.empty())
    params::loadConfigFile(options.config.string(), {},
                           [&](const mrpt::config::CConfigFileBase& cfg) { orb.loadFromConfigFile(cfg, "ORB"); });
  features::OrbExtractor extractor(orb);
  std::vector<cv::Mat> descriptors;
  VocabTrainResult r;
  const auto t0 = std::chrono::steady_clock::now();
  auto add = [&](const cv::Mat& image) {
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    extractor.extract(image, k, d);
    r.descriptors += static_cast<std::size_t>(d.rows);
    descriptors.push_back(d);
  };
  for (const auto& rawlog : options.rawlogs) {
    const std::size_t total = datasets::RawlogReader::countFrames(rawlog);
    Progress progress("features " + rawlog.filename().string(), total, options.progress);
    datasets::RawlogReader reader(rawlog);
    datasets::Frame f;
    while (reader.next(f)) {
      if (f.index % options.every == 0) add(f.image);
      progress.update(f.index + 1);
    }
    progress.finish();
  }
  for (const auto& folder : options.imageFolders) {
    const auto files = imagesIn(folder);
    Progress progress("features " + folder.filename().string(), files.size(), options.progress);
    for (std::size_t i = 0; i < files.size(); ++i) {
      if (i % options.every == 0) {
        const cv::Mat image = cv::imread(files[i].string(), cv::IMREAD_GRAYSCALE);
        if (image.empty()) throw Error(files[i].string() + ": cannot read the image");
        add(image);
      }
      progress.update(i + 1);
    }
    progress.finish();
  }
  r.images = descriptors.size();
  if (r.descriptors == 0) {
    std::string names;
    for (const auto& x : options.rawlogs) names += (names.empty() ? "" : ", ") + x.string();
    for (const auto& x : options.imageFolders) names += (names.empty() ? "" : ", ") + x.string();
    throw Error("no ORB descriptors in " + names + " (" + std::to_string(r.images) +
                " images, every " + std::to_string(options.every) + "): nothing to train " + options.out.string() +
                " on (blank or very small images?)");
  }
  r.extractSeconds = secondsSince(t0);
  const auto t1 = std::chrono::steady_clock::now();
  Progress progress("clustering levels", static_cast<std::size_t>(options.vocabulary.depth), options.progress);
  places::Vocabulary v = places::Vocabulary::train(
      descriptors, options.vocabulary, [&](std::size_t done, std::size_t) { progress.update(done); });
  progress.finish();
  r.trainSeconds = secondsSince(t1);
  std::string description = options.description;
  if (description.empty()) {
    std::ostringstream s;
    s << "vocab-train";
    for (const auto& x : options.rawlogs) s << " --rawlog " << x.filename().string();
    for (const auto& x : options.imageFolders) s << " --images " << x.filename().string();
    s << " --every " << options.every << " --branching " << options.vocabulary.branching << " --depth "
      << options.vocabulary.depth << " --seed " << options.vocabulary.seed << " (ORB " << orb.nFeatures << " features, "
      << orb.nLevels << " levels, " << orb.scaleFactor << ")";
    description = s.str();
  }
  v.setProvenance({v.provenance().images, v.provenance().descriptors, description});
  try {
    v.save(out.tempPath());
    // MRPT's gzip writer ignores a failure when it closes the file (the last block on a full disk): read it back.
    verifyGzipFile(out.tempPath());
  } catch (const std::exception& e) {  // e.g. a full disk: MRPT's "Cannot write bytes to stream!" names no file
    throw Error(options.out.string() + ": cannot write the vocabulary (" + oneLineMessage(e) + ")");
  }
  r.fileBytes = fs::file_size(out.tempPath());
  outputs.commit();
  r.words = v.numWords();
  r.nodes = v.numNodes();
  return r;
}

}  // namespace pslam::apps
