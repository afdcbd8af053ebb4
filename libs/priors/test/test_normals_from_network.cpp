// Normals from a network through OpenCV DNN, with a tiny Darknet model the test writes itself: one 1x1
// convolution whose weights are known, so the expected normals are known exactly.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include <mrpt/config/CConfigFile.h>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/NormalSource.h"
#include "pslam/priors/NormalsFromNetwork.h"

namespace fs = std::filesystem;
using namespace pslam::priors;

namespace {

struct TempDir {
  fs::path path;
  TempDir() : path(fs::temp_directory_path() / ("pslam_normal_net_" + std::to_string(::getpid()))) {
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

/// Darknet model: input 3xHxW, one 1x1 convolution with `filters` outputs, linear activation.
/// weights[f][c] and bias[f]; blob channel c is the input after OpenCV's blobFromImage.
void writeDarknet(const fs::path& cfg, const fs::path& weightsFile, int size, const std::vector<std::vector<float>>& W,
                  const std::vector<float>& bias) {
  std::ofstream c(cfg);
  c << "[net]\nwidth=" << size << "\nheight=" << size << "\nchannels=3\n\n"
    << "[convolutional]\nfilters=" << W.size() << "\nsize=1\nstride=1\npad=0\nactivation=linear\n";
  std::ofstream w(weightsFile, std::ios::binary);
  const int32_t major = 0, minor = 2, revision = 0;
  const uint64_t seen = 0;
  w.write(reinterpret_cast<const char*>(&major), 4);
  w.write(reinterpret_cast<const char*>(&minor), 4);
  w.write(reinterpret_cast<const char*>(&revision), 4);
  w.write(reinterpret_cast<const char*>(&seen), 8);
  w.write(reinterpret_cast<const char*>(bias.data()), static_cast<std::streamsize>(bias.size() * 4));
  for (const auto& row : W) w.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * 4));
}

/// An image whose pixels encode known normals, BGR channel k = round((n_k + 1) / 2 * 255) as in the contract.
cv::Mat normalImage(int size, cv::Mat& truth) {
  cv::Mat img(size, size, CV_8UC3);
  truth = cv::Mat(size, size, CV_32FC3);
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      // normals facing the camera (negative z), varied over the image
      const double a = (u - size / 2.0) / size, b = (v - size / 2.0) / size;
      const cv::Vec3d n = cv::normalize(cv::Vec3d(a, b, -1.0));
      img.at<cv::Vec3b>(v, u) = pslam::datasets::encodeNormal(n);
      cv::Vec3d q;
      pslam::datasets::decodeNormal(img.at<cv::Vec3b>(v, u), q);  // the exactly representable normal
      truth.at<cv::Vec3f>(v, u) = cv::Vec3f(q);
    }
  return img;
}

double maxErrorDeg(const cv::Mat& a, const cv::Mat& b) {
  double m = 0;
  for (int v = 0; v < a.rows; ++v)
    for (int u = 0; u < a.cols; ++u) m = std::max(m, normalAngleDeg(a.at<cv::Vec3f>(v, u), b.at<cv::Vec3f>(v, u)));
  return m;
}

}  // namespace

TEST(NormalsFromNetwork, DarknetIdentityDecoderReproducesEncodedNormals) {
  TempDir dir;
  // out_k = 2 * pixel_k / 255 - 1 with blob scale 1/255 and no channel swap: the network decodes the image.
  writeDarknet(dir.path / "n.cfg", dir.path / "n.weights", 32, {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}}, {-1, -1, -1});
  NetworkNormalParams p;
  p.model = (dir.path / "n.weights").string();
  p.config = (dir.path / "n.cfg").string();
  p.inputWidth = p.inputHeight = 32;
  p.swapRB = false;
  p.orientTowardsCamera = false;
  NetworkNormalEstimator net(p);
  cv::Mat truth;
  const cv::Mat img = normalImage(32, truth);
  const NormalMap nm = net.compute(img);
  ASSERT_EQ(nm.normals.size(), img.size());
  EXPECT_LT(maxErrorDeg(nm.normals, truth), 0.05);  // float32 acos resolution near 0 is ~0.02 deg
  EXPECT_EQ(cv::countNonZero(nm.planarMask), 32 * 32);  // no planar channel: everything counts
}

TEST(NormalsFromNetwork, AxisMappingSwapAndPlanarChannelFromIni) {
  TempDir dir;
  // A "y-up, z-towards-viewer" network on RGB input: out0 = n_x, out1 = -n_y, out2 = -n_z; out3 = planar prob.
  // With swapRB the blob is (R, G, B) = (n_z, n_y, n_x) encoded, so the weights pick channels accordingly.
  writeDarknet(dir.path / "n.cfg", dir.path / "n.weights", 16,
               {{0, 0, 2}, {0, -2, 0}, {-2, 0, 0}, {0, 0, 0}}, {-1, 1, 1, 0.8f});
  {
    std::ofstream ini(dir.path / "net.ini");
    ini << "[NormalsFromNetwork]\nmodel = n.weights\nconfig = n.cfg\ninputWidth = 16\ninputHeight = 16\n"
        << "scale = 0.00392156862745098\nswapRB = true\naxisMapping = x,-y,-z\nplanarChannel = 3\n"
        << "planarThreshold = 0.5\n";
  }
  auto source = makeNormalSource("network", dir.path / "net.ini");  // relative model paths: ini folder
  pslam::datasets::Frame f;
  cv::Mat truth;
  f.image = normalImage(16, truth);
  f.camera.ncols = f.camera.nrows = 16;
  f.camera.fx(20);
  f.camera.fy(20);
  f.camera.cx(7.5);
  f.camera.cy(7.5);
  const NormalMap nm = source->compute(f);
  EXPECT_LT(maxErrorDeg(nm.normals, truth), 0.05);  // float32 acos resolution near 0 is ~0.02 deg
  EXPECT_EQ(cv::countNonZero(nm.planarMask), 16 * 16);  // probability 0.8 >= 0.5

  // orientTowardsCamera flips normals that face away: the same network with the encoded normals negated.
  cv::Mat flipped = f.image.clone();
  for (auto it = flipped.begin<cv::Vec3b>(); it != flipped.end<cv::Vec3b>(); ++it)
    for (int k = 0; k < 3; ++k) (*it)[k] = static_cast<uchar>(255 - (*it)[k]);
  f.image = flipped;
  EXPECT_LT(maxErrorDeg(source->compute(f).normals, truth), 0.5);
}

TEST(NormalsFromNetwork, BadConfigurationsNameTheProblem) {
  TempDir dir;
  NetworkNormalParams p;
  p.model = (dir.path / "missing.onnx").string();
  try {
    NetworkNormalEstimator net(p);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.onnx"), std::string::npos);
  }
  p.axisMapping = "x,y";
  EXPECT_THROW(p.check(), pslam::Error);
  p.axisMapping = "x,x,z";
  EXPECT_THROW(p.check(), pslam::Error);
  p.axisMapping = "x,-y,w";
  EXPECT_THROW(p.check(), pslam::Error);
  p.axisMapping = "x,y,z";
  p.planarChannel = 1;  // collides with a normal component
  EXPECT_THROW(p.check(), pslam::Error);
  {
    std::ofstream ini(dir.path / "empty.ini");
    ini << "[Other]\nx = 1\n";
  }
  EXPECT_THROW(makeNormalSource("network", dir.path / "empty.ini"), pslam::Error);  // [Other]: unknown section
  {
    std::ofstream ini(dir.path / "depth_only.ini");
    ini << "[NormalsFromDepth]\nminDepth = 0.2\n";
  }
  try {
    makeNormalSource("network", dir.path / "depth_only.ini");
    FAIL();
  } catch (const pslam::Error& e) {
    EXPECT_EQ(std::string(e.what()),
              (dir.path / "depth_only.ini").string() + ": [NormalsFromNetwork] model: missing (the network normal source needs it)");
  }
  EXPECT_THROW(makeNormalSource("network", ""), pslam::Error);
  // A model that is not a network at all.
  { std::ofstream(dir.path / "junk.weights") << "not a network"; }
  { std::ofstream(dir.path / "junk.cfg") << "garbage"; }
  p.model = (dir.path / "junk.weights").string();
  p.config = (dir.path / "junk.cfg").string();
  EXPECT_THROW(NetworkNormalEstimator{p}, pslam::Error);
}

TEST(NormalsFromNetwork, SectionReadStrictly) {
  TempDir dir;
  const auto errorFor = [&](const std::string& text) {
    std::ofstream(dir.path / "n.ini") << text;
    try {
      makeNormalSource("depth", dir.path / "n.ini");
    } catch (const pslam::Error& e) {
      const std::string what = e.what(), f = (dir.path / "n.ini").string();
      return what.rfind(f, 0) == 0 ? "F" + what.substr(f.size()) : what;
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\nmodel = m.onnx\nframework = ONNX\n"), "");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\nframework = bogus\n"),
            "F: [NormalsFromNetwork] framework = bogus: must be empty (from the model's file extension) or one of caffe, "
            "tensorflow, torch, darknet, dldt, onnx");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\nmean0 = abc\n"), "F: [NormalsFromNetwork] mean0 = abc: not a number");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\ninputWidth = 256.5\n"), "F: [NormalsFromNetwork] inputWidth = 256.5: not an integer");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\nswapRB = maybe\n"),
            "F: [NormalsFromNetwork] swapRB = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\naxisMapping = x,-y,w\n"),
            "F: [NormalsFromNetwork] axisMapping = x,-y,w: entry 'w' must be [+|-]x, y or z");
}

TEST(NormalsFromNetwork, LargerImagesAreShrunkAndTheOutputUpsampledLikeCvResize) {
  TempDir dir;
  writeDarknet(dir.path / "n.cfg", dir.path / "n.weights", 16, {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}}, {-1, -1, -1});
  NetworkNormalParams p;
  p.model = (dir.path / "n.weights").string();
  p.config = (dir.path / "n.cfg").string();
  p.inputWidth = p.inputHeight = 16;
  p.swapRB = false;
  p.orientTowardsCamera = false;
  NetworkNormalEstimator net(p);
  // A 16x16 normal image enlarged 4x by pixel replication: the area shrink gives the 16x16 image back, so the
  // result is the 16x16 decoding upsampled bilinearly (cv::resize INTER_LINEAR) and renormalized.
  cv::Mat truth16;
  const cv::Mat img16 = normalImage(16, truth16);
  cv::Mat img64;
  cv::resize(img16, img64, cv::Size(64, 48), 0, 0, cv::INTER_NEAREST);  // 4x wide, 3x high
  const NormalMap nm = net.compute(img64);
  ASSERT_EQ(nm.normals.size(), cv::Size(64, 48));
  const NormalMap small = net.compute(img16);
  cv::Mat expected;
  cv::resize(small.normals, expected, cv::Size(64, 48), 0, 0, cv::INTER_LINEAR);
  for (auto it = expected.begin<cv::Vec3f>(); it != expected.end<cv::Vec3f>(); ++it) *it = cv::normalize(*it);
  EXPECT_LT(maxErrorDeg(nm.normals, expected), 0.05);
}

TEST(NormalsFromNetwork, AModelWithTooFewOutputChannelsFailsAtLoadNamingTheFile) {
  TempDir dir;
  writeDarknet(dir.path / "two.cfg", dir.path / "two.weights", 16, {{1, 0, 0}, {0, 1, 0}}, {0, 0});
  NetworkNormalParams p;
  p.model = (dir.path / "two.weights").string();
  p.config = (dir.path / "two.cfg").string();
  p.inputWidth = p.inputHeight = 16;
  try {
    NetworkNormalEstimator net(p);
    FAIL() << "expected pslam::Error";
  } catch (const pslam::Error& e) {
    EXPECT_EQ(std::string(e.what()), p.model + ": normals output has 2 channels, needs >= 3");
  }
}
