#pragma once
// vocab-train: trains the bag-of-words vocabulary (libs/places) on the ORB descriptors of rawlogs and image
// folders, and writes it as a .pvoc file (doc/places.md).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pslam/features/OrbExtractor.h"
#include "pslam/places/Vocabulary.h"

namespace pslam::apps {

struct VocabTrainOptions {
  std::vector<std::filesystem::path> rawlogs;      ///< CAMERA images of every `every`-th frame
  std::vector<std::filesystem::path> imageFolders; ///< *.png / *.jpg, by name, every `every`-th
  std::size_t every = 1;
  std::filesystem::path config;  ///< optional ini whose [ORB] section sets the extractor (other sections ignored)
  places::VocabularyParams vocabulary;
  std::filesystem::path out;     ///< the .pvoc file
  std::string description;       ///< stored as provenance (default: the inputs and parameters)
  bool progress = true;
  /// Throws pslam::Error naming the option: no inputs, every = 0, a missing input, no output, vocabulary params.
  void check() const;
};

struct VocabTrainResult {
  std::size_t images = 0;
  std::size_t descriptors = 0;
  std::size_t words = 0;
  std::size_t nodes = 0;
  double extractSeconds = 0.0, trainSeconds = 0.0;
  std::uintmax_t fileBytes = 0;
  std::string toText() const;
};

/// Extracts ORB descriptors from the inputs, trains, writes `out` atomically. Throws pslam::Error naming the file
/// for unreadable inputs (a missing rawlog, an image that cannot be decoded).
VocabTrainResult trainVocabulary(const VocabTrainOptions& options);

}  // namespace pslam::apps
