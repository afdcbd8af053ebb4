// ENet (Cityscapes, Caffe) through OpenCV DNN on real images: the Cityscapes test image shipped with the
// model and KITTI 00 grey frames through the whole semantic-priors app. Skips without ../shared/data.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <mrpt/config/CConfigFileMemory.h>
#include <opencv2/imgcodecs.hpp>

#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/SemanticImage.h"
#include "pslam/priors/SemanticNetwork.h"
#include "pslam/priors/SemanticPriorsApp.h"

using namespace pslam;
using namespace pslam::priors;
namespace fs = std::filesystem;

namespace {
const fs::path kData = PRIORSLAM_SHARED_DATA_DIR;
const fs::path kModel = kData / "models" / "enet_cityscapes_caffe";
const fs::path kKitti = kData / "kitti_odometry" / "sequences" / "00" / "image_0";

// The shipped network ini (pre-processing under test), with the model files taken from the data folder.
SemanticNetworkParams enetParams(const std::string& iniName) {
  const fs::path ini = fs::path(PRIORSLAM_SOURCE_DIR) / "config" / "semantic" / iniName;
  std::ifstream in(ini);
  std::stringstream text;
  text << in.rdbuf();
  mrpt::config::CConfigFileMemory cfg(text.str());
  cfg.write("SemanticNetwork", "model", (kModel / "cityscapes_weights.caffemodel").string());
  cfg.write("SemanticNetwork", "config", (kModel / "enet_opencv46_DERIVED.prototxt").string());
  SemanticNetworkParams p;
  p.loadFromConfigFile(cfg, "SemanticNetwork", ini.parent_path());
  return p;
}

// Every pixel's three probabilities sum to one up to the 8-bit rounding of each channel.
void expectNormalized(const cv::Mat& semantic) {
  int bad = 0;
  for (int y = 0; y < semantic.rows; ++y)
    for (int x = 0; x < semantic.cols; ++x) {
      const cv::Vec3b p = semantic.at<cv::Vec3b>(y, x);
      if (std::abs(int(p[0]) + p[1] + p[2] - 255) > 2) ++bad;
    }
  EXPECT_EQ(bad, 0);
}
}  // namespace

TEST(EnetData, CityscapesTestImageHasAPlausibleHistogram) {
  if (!fs::exists(kModel / "cityscapes_weights.caffemodel")) GTEST_SKIP() << "no ENet model in " << kModel;
  SemanticNetwork net(enetParams("enet_cityscapes.ini"));
  const cv::Mat img = cv::imread((kModel / "test_munich_000000_000019_leftImg8bit.png").string());
  ASSERT_FALSE(img.empty());
  const cv::Mat scores = net.scores(img);
  ASSERT_EQ(scores.size[1], 19);
  const auto classes = argmaxClassHistogram(scores);
  // SOURCE.txt (checked independently with python3-opencv): road 32%, sky 16%, building 16%, sidewalk 14%,
  // vegetation 10%, car 3%. Road is the largest class; each of these is present.
  EXPECT_EQ(std::max_element(classes.begin(), classes.end()) - classes.begin(), 0);  // road
  for (int c : {0, 1, 2, 8, 10, 13}) EXPECT_GT(classes[c], 0.01) << net.classMap().classNames[c];
  const cv::Mat semantic = net.semanticFromScores(scores, img.size());
  ASSERT_EQ(semantic.size(), img.size());
  ASSERT_EQ(semantic.type(), CV_8UC3);
  expectNormalized(semantic);
  const auto h = semanticHistogram(semantic);
  EXPECT_GT(h[0], 0.5);               // a street: mostly static
  EXPECT_GT(h[2], 0.05);              // sky at the top ...
  EXPECT_LT(h[2], 0.3);
  EXPECT_GT(h[1], 0.01);              // cars, cyclists, pedestrians
  EXPECT_LT(h[1], h[0]);
  // Sky is at the top: the invalid probability of the top tenth exceeds that of the bottom tenth.
  const int band = img.rows / 10;
  const auto top = semanticHistogram(semantic.rowRange(0, band));
  const auto bottom = semanticHistogram(semantic.rowRange(img.rows - band, img.rows));
  EXPECT_GT(top[2], bottom[2] + 0.1);
}

TEST(EnetData, KittiGreyFramesThroughTheSemanticPriorsApp) {
  if (!fs::exists(kModel / "cityscapes_weights.caffemodel") || !fs::exists(kKitti / "000000.png"))
    GTEST_SKIP() << "no ENet model or KITTI 00 frames under " << kData;
  const fs::path dir = fs::temp_directory_path() / "pslam_test_data_semantic_enet";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    datasets::RawlogWriter w(dir / "kitti.rawlog");
    for (int i = 0; i < 2; ++i) {
      char name[16];
      std::snprintf(name, sizeof(name), "%06d.png", i);
      datasets::Frame f;
      f.timestamp = 0.1 * i;
      f.image = cv::imread((kKitti / name).string(), cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(f.image.empty());
      f.camera.ncols = f.image.cols;
      f.camera.nrows = f.image.rows;
      f.camera.fx(718.856);
      f.camera.fy(718.856);
      f.camera.cx(607.1928);
      f.camera.cy(185.2157);
      w.write(f);
    }
    w.commit();
  }
  // The app reads its network from an ini: write the KITTI one with absolute model paths.
  const SemanticNetworkParams params = enetParams("enet_cityscapes_kitti.ini");
  mrpt::config::CConfigFileMemory out;
  params.saveToConfigFile(out, "SemanticNetwork");
  std::string text;
  out.getContent(text);
  std::ofstream(dir / "net.ini") << text;

  SemanticPriorsOptions o;
  o.input = dir / "kitti.rawlog";
  o.output = dir / "kitti_sem.rawlog";
  o.networkConfig = dir / "net.ini";
  o.progress = false;
  const auto report = SemanticPriorsApp(o).run();
  EXPECT_EQ(report.frames, 2u);
  datasets::RawlogReader r(o.output);
  datasets::Frame f;
  int n = 0;
  while (r.next(f)) {
    ++n;
    ASSERT_TRUE(f.hasSemantic());
    ASSERT_EQ(f.semantic.size(), f.image.size());
    expectNormalized(f.semantic);
    const auto h = semanticHistogram(f.semantic);
    // SOURCE.txt, frame 0 at 1024x320: road, vegetation, building and cars; a few false trucks.
    EXPECT_GT(h[0], 0.4);
    EXPECT_GT(h[1], 0.05);  // parked cars on both sides
    EXPECT_LT(h[1], h[0]);
    EXPECT_LT(h[2], 0.25);
  }
  EXPECT_EQ(n, 2);
  fs::remove_all(dir);
}
