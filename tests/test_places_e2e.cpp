// End-to-end tests of place recognition (doc/places.md): a vocabulary trained on a rendered room, then SLAM runs
// through the System façade that use it: a blank frame loses tracking and the vocabulary's relocalization finds
// the camera again within three frames; a bad vocabulary file fails the run before its first frame.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/places/Vocabulary.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/system/System.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_places_e2e");
  return root.path;
}

/// The room (seed 3, noise 1), 60 frames, and its frames in memory.
const std::vector<datasets::Frame>& roomFrames() {
  static const std::vector<datasets::Frame> frames = [] {
    synth::SynthOptions o;
    o.scenario = "room";
    o.frames = 60;
    o.seed = 3;
    o.noiseSigma = 1.0;
    o.outDir = tempRoot() / "synth";
    o.progress = false;
    const fs::path rawlog = synth::SynthApp(o).run().rawlog;
    std::vector<datasets::Frame> out;
    datasets::RawlogReader reader(rawlog);
    datasets::Frame f;
    while (reader.next(f)) out.push_back(f);
    return out;
  }();
  return frames;
}

/// A small vocabulary (k 10, L 3) trained on the ORB descriptors of 20 frames of another seed's room,
/// so that the run's own frames are not the training images.
const fs::path& vocabularyFile() {
  static const fs::path path = [] {
    synth::SynthOptions o;
    o.scenario = "room";
    o.frames = 20;
    o.seed = 9;
    o.outDir = tempRoot() / "train";
    o.progress = false;
    const fs::path rawlog = synth::SynthApp(o).run().rawlog;
    features::OrbExtractor orb(features::OrbParams{});
    std::vector<cv::Mat> descriptors;
    datasets::RawlogReader reader(rawlog);
    datasets::Frame f;
    while (reader.next(f)) {
      std::vector<cv::KeyPoint> k;
      cv::Mat d;
      orb.extract(f.image, k, d);
      descriptors.push_back(d);
    }
    places::VocabularyParams p;
    p.depth = 3;
    const fs::path file = tempRoot() / "room.pvoc";
    places::Vocabulary::train(descriptors, p).save(file);
    return file;
  }();
  return path;
}

system::SlamParams paramsWith(const std::vector<std::string>& overrides) {
  return system::loadSlamParams(kConfig.string(), overrides);
}

}  // namespace

TEST(PlacesE2E, ABlankFrameIsFollowedByARelocalizationWithinThreeFrames) {
  const auto& frames = roomFrames();
  ASSERT_EQ(frames.size(), 60u);
  system::System sys(paramsWith({"Places.vocabulary=" + vocabularyFile().string()}), {1, false, std::nullopt});
  constexpr std::size_t kBlank = 40;
  bool lostAtBlank = false;
  std::size_t relocalizedAt = 0, lostAfter = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    datasets::Frame f = frames[i];
    if (i == kBlank) f.image = cv::Mat::zeros(f.image.size(), f.image.type());
    const system::TrackResult r = sys.track(f);
    if (i == kBlank) {
      ASSERT_TRUE(sys.initialized()) << "the room must be mapped before the blank frame";
      lostAtBlank = r.status == tracking::FrameStatus::Lost;
    }
    if (i > kBlank && relocalizedAt == 0 && r.status == tracking::FrameStatus::Relocalized) relocalizedAt = i;
    if (relocalizedAt > 0 && i > relocalizedAt && r.status == tracking::FrameStatus::Lost) ++lostAfter;
  }
  EXPECT_TRUE(lostAtBlank);
  ASSERT_GT(relocalizedAt, kBlank) << "never relocalized after the blank frame";
  EXPECT_LE(relocalizedAt, kBlank + 3);
  // Tracking goes on from the relocalized pose to the end of the clip.
  EXPECT_EQ(lostAfter, 0u);
}

TEST(PlacesE2E, WithoutAVocabularyTheSameBlankFrameAlsoRelocalizesByExhaustiveMatching) {
  // The reference the vocabulary replaces: the exhaustive search finds the camera again too (only slower).
  const auto& frames = roomFrames();
  system::System sys(paramsWith({}), {1, false, std::nullopt});
  std::size_t relocalizedAt = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    datasets::Frame f = frames[i];
    if (i == 40) f.image = cv::Mat::zeros(f.image.size(), f.image.type());
    const system::TrackResult r = sys.track(f);
    if (i > 40 && relocalizedAt == 0 && r.status == tracking::FrameStatus::Relocalized) relocalizedAt = i;
  }
  EXPECT_GT(relocalizedAt, 40u);
  EXPECT_LE(relocalizedAt, 43u);
}

TEST(PlacesE2E, ABadVocabularyFailsTheSystemBeforeItsFirstFrame) {
  const std::string missing = test_support::errorOf(
      [&] { system::System sys(paramsWith({"Places.vocabulary=" + (tempRoot() / "none.pvoc").string()})); });
  EXPECT_NE(missing.find("none.pvoc: vocabulary file not found"), std::string::npos) << missing;
  const fs::path notVoc = tempRoot() / "text.pvoc";
  std::ofstream(notVoc) << "hello";
  const std::string bad =
      test_support::errorOf([&] { system::System sys(paramsWith({"Places.vocabulary=" + notVoc.string()})); });
  EXPECT_NE(bad.find("text.pvoc: not a vocabulary file"), std::string::npos) << bad;
}

TEST(PlacesE2E, ARelativeVocabularyPathIsRelativeToTheConfigFile) {
  const fs::path dir = tempRoot() / "cfg";
  fs::create_directories(dir);
  fs::copy_file(vocabularyFile(), dir / "v.pvoc", fs::copy_options::overwrite_existing);
  std::ofstream(dir / "slam.ini") << "[Places]\nvocabulary = v.pvoc\n";
  const system::SlamParams p = system::loadSlamParams((dir / "slam.ini").string(), {});
  EXPECT_EQ(fs::path(p.places.vocabulary), (dir / "v.pvoc").lexically_normal());
  EXPECT_NO_THROW(system::System sys(p));
}
