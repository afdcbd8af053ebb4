// semantic-priors end to end on a small synthetic rawlog with a label folder.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/SemanticPriorsApp.h"

using namespace pslam;
namespace fs = std::filesystem;

namespace {
struct Fixture {
  fs::path dir;
  fs::path rawlog;
  fs::path labels;
  explicit Fixture(const std::string& name, int frames = 3) {
    dir = fs::temp_directory_path() / ("pslam_semantic_app_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    rawlog = dir / "seq.rawlog";
    labels = dir / "seq_Labels";
    fs::create_directories(labels);
    datasets::RawlogWriter w(rawlog);
    for (int i = 0; i < frames; ++i) {
      datasets::Frame f;
      f.timestamp = 0.1 * i;
      f.image = cv::Mat(24, 32, CV_8UC1, cv::Scalar(40 * i));
      f.camera.ncols = 32;
      f.camera.nrows = 24;
      f.camera.fx(30);
      f.camera.fy(30);
      f.camera.cx(16);
      f.camera.cy(12);
      w.write(f);
      cv::Mat lab(24, 32, CV_8UC1, cv::Scalar(0));         // road
      lab(cv::Rect(0, 0, 32, 6)).setTo(10);                // sky
      lab(cv::Rect(4 * i, 12, 8, 8)).setTo(13);            // a car moving right
      char name[32];
      std::snprintf(name, sizeof(name), "LABEL_%06d.png", i);
      cv::imwrite((labels / name).string(), lab);
    }
    w.commit();
  }
  ~Fixture() { fs::remove_all(dir); }
};
}  // namespace

TEST(SemanticPriorsApp, AddsOneHotSemanticChannelFromLabels) {
  Fixture fx("labels");
  priors::SemanticPriorsOptions o;
  o.input = fx.rawlog;
  o.output = fx.dir / "out" / "seq_sem.rawlog";
  o.labelsDir = "auto";  // seq_Labels beside seq.rawlog
  o.overlayDir = fx.dir / "overlays";
  o.progress = false;
  EXPECT_EQ(priors::labelsDirFor(fx.rawlog), fx.labels);
  const auto report = priors::SemanticPriorsApp(o).run();
  EXPECT_EQ(report.frames, 3u);
  EXPECT_EQ(report.overlays, 3u);
  EXPECT_TRUE(fs::exists(o.overlayDir / "overlay_000002.png"));
  // 6 of 24 rows sky, an 8x8 car in 24x32.
  EXPECT_NEAR(report.meanProbability[2], 6.0 / 24.0, 1e-9);
  EXPECT_NEAR(report.meanProbability[1], 64.0 / 768.0, 1e-9);
  datasets::RawlogReader r(o.output);
  datasets::Frame f;
  int n = 0;
  while (r.next(f)) {
    ASSERT_TRUE(f.hasSemantic());
    EXPECT_EQ(f.semantic.at<cv::Vec3b>(2, 2), cv::Vec3b(0, 0, 255));
    EXPECT_EQ(f.semantic.at<cv::Vec3b>(14, 4 * n + 1), cv::Vec3b(0, 255, 0));
    EXPECT_EQ(f.semantic.at<cv::Vec3b>(22, 30), cv::Vec3b(255, 0, 0));
    EXPECT_EQ(f.image.at<uchar>(0, 0), 40 * n);
    ++n;
  }
  EXPECT_EQ(n, 3);
}

TEST(SemanticPriorsApp, FailsCleanlyWithoutPartialOutputs) {
  Fixture fx("missing");
  fs::remove(fx.labels / "LABEL_000002.png");
  priors::SemanticPriorsOptions o;
  o.input = fx.rawlog;
  o.output = fx.dir / "seq_sem.rawlog";
  o.labelsDir = fx.labels;
  o.overlayDir = fx.dir / "overlays";
  o.progress = false;
  try {
    priors::SemanticPriorsApp(o).run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("LABEL_000002.png"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(o.output));
  EXPECT_FALSE(fs::exists(o.overlayDir));
  EXPECT_FALSE(fs::exists(datasets::RawlogWriter::imagesDirFor(o.output)));

  // A label image of the wrong size.
  cv::imwrite((fx.labels / "LABEL_000002.png").string(), cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)));
  EXPECT_THROW(priors::SemanticPriorsApp(o).run(), Error);
}

TEST(SemanticPriorsApp, OptionChecks) {
  priors::SemanticPriorsOptions o;
  o.input = "a.rawlog";
  o.output = "b.rawlog";
  EXPECT_THROW(priors::SemanticPriorsApp{o}, Error);  // no source
  o.labelsDir = "x";
  o.networkConfig = "y.ini";
  EXPECT_THROW(priors::SemanticPriorsApp{o}, Error);  // two sources
  o.networkConfig.clear();
  o.output = o.input;
  EXPECT_THROW(priors::SemanticPriorsApp{o}, Error);  // in place
}

// Reliability (doc/reliability.md): a missing input rawlog is named (not its default label folder); an output
// rawlog whose images folder is the input's is refused and the input's images are kept.
TEST(SemanticPriorsApp, MissingInputIsNamedAndInputImagesAreNeverReplaced) {
  Fixture fx("inputs");
  priors::SemanticPriorsOptions o;
  o.input = fx.dir / "missing.rawlog";
  o.output = fx.dir / "out.rawlog";
  o.labelsDir = "auto";
  o.progress = false;
  try {
    priors::SemanticPriorsApp(o).run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("missing.rawlog: rawlog file not found"), std::string::npos) << msg;
    EXPECT_EQ(msg.find("_Labels"), std::string::npos) << msg;
  }

  // seq.copy has the stem of seq.rawlog: its images folder would be seq_Images, the input's.
  const auto images = fx.dir / "seq_Images";
  std::size_t before = 0;
  for (const auto& e : fs::directory_iterator(images)) before += e.is_regular_file() ? 1 : 0;
  o.input = fx.rawlog;
  o.output = fx.dir / "seq.copy";
  try {
    priors::SemanticPriorsApp(o).run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is the input"), std::string::npos) << e.what();
  }
  std::size_t after = 0;
  for (const auto& e : fs::directory_iterator(images)) after += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(after, before);
  EXPECT_FALSE(fs::exists(o.output));
}
