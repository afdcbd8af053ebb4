// vocab-train's app class: its output never replaces an input (a rawlog, an image of an --images folder, the
// --config file), and its errors name the file.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "pslam/apps/VocabTrainApp.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

fs::path tempDir(const std::string& name) {
  static const pslam::test_support::TempDir root("pslam_test_vocab_train");
  return pslam::test_support::freshSubDir(root, name);
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

cv::Mat texture(int seed) {
  cv::Mat m(120, 160, CV_8UC1);
  cv::theRNG().state = static_cast<std::uint64_t>(seed) + 1;
  cv::randu(m, 0, 256);
  return m;
}

/// d/seq.rawlog (3 textured frames), d/images/ (3 PNGs), d/orb.ini.
void writeInputs(const fs::path& d) {
  datasets::RawlogWriter w(d / "seq.rawlog");
  for (int i = 0; i < 3; ++i) {
    datasets::Frame f;
    f.timestamp = 1.0 + i;
    f.image = texture(i);
    f.camera.ncols = 160;
    f.camera.nrows = 120;
    f.camera.fx(100.0);
    f.camera.fy(100.0);
    f.camera.cx(80.0);
    f.camera.cy(60.0);
    w.write(f);
  }
  w.commit();
  fs::create_directories(d / "images");
  for (int i = 0; i < 3; ++i) cv::imwrite((d / "images" / ("im" + std::to_string(i) + ".png")).string(), texture(10 + i));
  std::ofstream(d / "orb.ini") << "[ORB]\nnFeatures = 300\n";
}

std::string errorOf(const apps::VocabTrainOptions& o) {
  try {
    apps::trainVocabulary(o);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// Reliability (doc/reliability.md): `vocab-train --rawlog R --out R` replaced the rawlog with a vocabulary and
// exited 0; so did --out onto an input image or the --config file. Refused before any work, the input unchanged.
TEST(VocabTrainApp, OutputIsNeverAnInput) {
  const fs::path d = tempDir("inputs");
  writeInputs(d);
  apps::VocabTrainOptions base;
  base.rawlogs = {d / "seq.rawlog"};
  base.imageFolders = {d / "images"};
  base.config = d / "orb.ini";
  base.vocabulary.branching = 4;
  base.vocabulary.depth = 2;
  base.progress = false;
  for (const fs::path& input : {d / "seq.rawlog", d / "images" / "im1.png", d / "orb.ini",
                                d / "seq_Images" / "CAMERA_000000.png"}) {
    SCOPED_TRACE(input.string());
    const std::string before = readText(input);
    apps::VocabTrainOptions o = base;
    o.out = input;
    const std::string msg = errorOf(o);
    EXPECT_NE(msg.find(input.string() + ": is the input"), std::string::npos) << msg;
    EXPECT_EQ(readText(input), before);
  }
  // The same output, elsewhere, is written.
  apps::VocabTrainOptions o = base;
  o.out = d / "vocab.pvoc";
  EXPECT_EQ(errorOf(o), "");
  EXPECT_TRUE(fs::is_regular_file(d / "vocab.pvoc"));
}

// Reliability: nothing to train on names the inputs (it named no file).
TEST(VocabTrainApp, NoDescriptorsNamesTheInputs) {
  const fs::path d = tempDir("blank");
  fs::create_directories(d / "blank");
  cv::imwrite((d / "blank" / "flat.png").string(), cv::Mat(120, 160, CV_8UC1, cv::Scalar(128)));
  apps::VocabTrainOptions o;
  o.imageFolders = {d / "blank"};
  o.out = d / "v.pvoc";
  o.progress = false;
  const std::string msg = errorOf(o);
  EXPECT_NE(msg.find("no ORB descriptors in " + (d / "blank").string()), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(d / "v.pvoc"));
}

// Reliability: a full disk while the vocabulary is written said MRPT's "Cannot write bytes to stream!" without a
// file; the message names the output. A file-size limit stands in for the full disk.
TEST(VocabTrainApp, AFullDiskNamesTheOutput) {
  const fs::path d = tempDir("full");
  writeInputs(d);
  apps::VocabTrainOptions o;
  o.imageFolders = {d / "images"};
  o.vocabulary.branching = 4;
  o.vocabulary.depth = 2;
  o.out = d / "v.pvoc";
  o.progress = false;
  struct rlimit old {};
  ::getrlimit(RLIMIT_FSIZE, &old);
  const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit tiny = old;
  tiny.rlim_cur = 64;
  ::setrlimit(RLIMIT_FSIZE, &tiny);
  const std::string msg = errorOf(o);
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, oldHandler);
  EXPECT_EQ(msg.rfind((d / "v.pvoc").string() + ": cannot write the vocabulary (", 0), 0u) << msg;
  EXPECT_FALSE(fs::exists(d / "v.pvoc"));
}
