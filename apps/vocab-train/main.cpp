// vocab-train: trains the bag-of-words vocabulary on rawlogs and image folders (thin CLI around
// pslam::apps::trainVocabulary in VocabTrainApp.h; doc/places.md).
#include <iostream>

#include <CLI/CLI.hpp>

#include "pslam/apps/VocabTrainApp.h"
#include "pslam/core/Error.h"

int main(int argc, char** argv) {
  CLI::App cli{"Trains the ORB bag-of-words vocabulary (.pvoc) used by relocalization and guided matching"};
  pslam::apps::VocabTrainOptions o;
  std::vector<std::string> rawlogs, folders;
  std::string out, config;
  bool quiet = false;
  cli.add_option("--rawlog", rawlogs, "rawlog whose CAMERA images are used (repeatable)");
  cli.add_option("--images", folders, "folder of .png / .jpg images, by name (repeatable)");
  cli.add_option("--every", o.every, "use every N-th frame / image")->capture_default_str();
  cli.add_option("--config", config, "ini file whose [ORB] section sets the extractor (default: ORB defaults)");
  cli.add_option("--branching", o.vocabulary.branching, "k: children per node")->capture_default_str();
  cli.add_option("--depth", o.vocabulary.depth, "L: levels (at most k^L words)")->capture_default_str();
  cli.add_option("--iterations", o.vocabulary.maxIterations, "k-majority iterations per node")->capture_default_str();
  cli.add_option("--seed", o.vocabulary.seed, "k-means++ seed")->capture_default_str();
  cli.add_option("--description", o.description, "provenance text stored in the file (default: the command)");
  cli.add_option("--out", out, "output .pvoc file")->required();
  cli.add_flag("-q,--quiet", quiet, "no progress on stderr");
  CLI11_PARSE(cli, argc, argv);
  try {
    for (const auto& r : rawlogs) o.rawlogs.emplace_back(r);
    for (const auto& f : folders) o.imageFolders.emplace_back(f);
    o.out = out;
    o.config = config;
    o.progress = !quiet;
    std::cout << pslam::apps::trainVocabulary(o).toText() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vocab-train: error: " << pslam::oneLineMessage(e) << "\n";
    return 1;
  }
}
