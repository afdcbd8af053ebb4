#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/dnn.hpp>

#include "pslam/core/Error.h"
#include "pslam/priors/SemanticImage.h"
#include "pslam/priors/SemanticNetwork.h"

using namespace pslam::priors;

TEST(SemanticImage, LabelsBecomeOneHotThroughTheClassMap) {
  cv::Mat labels = (cv::Mat_<uchar>(2, 3) << 0, 10, 13, 255, 8, 11);
  const cv::Mat s = semanticFromLabels(labels, SemanticClassMap::cityscapes());
  ASSERT_EQ(s.type(), CV_8UC3);
  EXPECT_EQ(s.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 0, 0));  // road: static
  EXPECT_EQ(s.at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 255));  // sky: invalid
  EXPECT_EQ(s.at<cv::Vec3b>(0, 2), cv::Vec3b(0, 255, 0));  // car: dynamic
  EXPECT_EQ(s.at<cv::Vec3b>(1, 0), cv::Vec3b(0, 0, 255));  // 255 ignore: invalid
  EXPECT_EQ(s.at<cv::Vec3b>(1, 1), cv::Vec3b(255, 0, 0));  // vegetation
  EXPECT_EQ(s.at<cv::Vec3b>(1, 2), cv::Vec3b(0, 255, 0));  // person
  EXPECT_THROW(semanticFromLabels(cv::Mat(), SemanticClassMap::cityscapes()), pslam::Error);
  EXPECT_THROW(semanticFromLabels(cv::Mat(2, 2, CV_16U), SemanticClassMap::cityscapes()), pslam::Error);
}

TEST(SemanticImage, SoftmaxScoresSumIntoGroups) {
  const auto map = SemanticClassMap::cityscapes();
  const int C = 19, H = 4, W = 5;
  const int shape[4] = {1, C, H, W};
  cv::Mat scores(4, shape, CV_32F);
  std::mt19937 rng(2);
  std::normal_distribution<float> n(0.f, 3.f);
  for (std::size_t i = 0; i < scores.total(); ++i) scores.ptr<float>()[i] = n(rng);
  const cv::Mat probs = groupProbabilitiesFromScores(scores, map, true);
  ASSERT_EQ(probs.type(), CV_32FC3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double e[19], sum = 0, group[3] = {0, 0, 0};
      for (int c = 0; c < C; ++c) sum += (e[c] = std::exp(double(scores.at<float>(cv::Vec4i(0, c, y, x)))));
      for (int c = 0; c < C; ++c) group[int(map.groups[c])] += e[c] / sum;
      const cv::Vec3f p = probs.at<cv::Vec3f>(y, x);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(p[k], group[k], 1e-6);
      EXPECT_NEAR(p[0] + p[1] + p[2], 1.0, 1e-6);
    }
  // Encoding: round(255 p), resized to the image.
  const cv::Mat sem = encodeSemantic(probs, cv::Size(W, H));
  const cv::Vec3f p = probs.at<cv::Vec3f>(1, 2);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(sem.at<cv::Vec3b>(1, 2)[k], int(std::lround(255 * p[k])));
  EXPECT_EQ(encodeSemantic(probs, cv::Size(10, 8)).size(), cv::Size(10, 8));
  // Wrong number of classes for the map.
  const int bad[4] = {1, 5, H, W};
  EXPECT_THROW(groupProbabilitiesFromScores(cv::Mat(4, bad, CV_32F, cv::Scalar(0)), map, true), pslam::Error);
  // Histogram of arg-max classes.
  const auto hist = argmaxClassHistogram(scores);
  double total = 0;
  for (double h : hist) total += h;
  EXPECT_NEAR(total, 1.0, 1e-12);
}

TEST(SemanticImage, HistogramAndOverlay) {
  cv::Mat sem(10, 10, CV_8UC3, cv::Scalar(255, 0, 0));
  sem(cv::Rect(0, 0, 10, 5)).setTo(cv::Scalar(0, 255, 0));
  const auto h = semanticHistogram(sem);
  EXPECT_NEAR(h[0], 0.5, 1e-12);
  EXPECT_NEAR(h[1], 0.5, 1e-12);
  EXPECT_NEAR(h[2], 0.0, 1e-12);
  const cv::Mat grey(10, 10, CV_8U, cv::Scalar(0));
  const cv::Mat ov = semanticOverlay(grey, sem, 1.0);
  EXPECT_EQ(ov.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));  // dynamic -> red (BGR)
  EXPECT_EQ(ov.at<cv::Vec3b>(9, 9), cv::Vec3b(0, 255, 0));  // static -> green
  EXPECT_THROW(semanticOverlay(cv::Mat(5, 5, CV_8U), sem), pslam::Error);
}

// The caffe-enet Upsample layer: max-unpooling puts each pooled value back where its maximum was.
TEST(SemanticNetwork, EnetUpsampleLayerUnpoolsToTheArgmax) {
  registerEnetUpsampleLayer();
  const std::string proto = R"(
name: "unpool"
layer { name: "data" type: "Input" top: "data" input_param { shape { dim: 1 dim: 2 dim: 4 dim: 6 } } }
layer { name: "pool" type: "Pooling" bottom: "data" top: "pooled" top: "mask"
        pooling_param { pool: MAX kernel_size: 2 stride: 2 } }
layer { name: "up" type: "Upsample" bottom: "pooled" bottom: "mask" top: "up" }
)";
  cv::dnn::Net net = cv::dnn::readNetFromCaffe(proto.data(), proto.size());
  const int shape[4] = {1, 2, 4, 6};
  cv::Mat input(4, shape, CV_32F);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (std::size_t i = 0; i < input.total(); ++i) input.ptr<float>()[i] = u(rng);
  net.setInput(input);
  const cv::Mat out = net.forward("up");
  ASSERT_EQ(out.size[2], 4);
  ASSERT_EQ(out.size[3], 6);
  for (int c = 0; c < 2; ++c)
    for (int by = 0; by < 2; ++by)
      for (int bx = 0; bx < 3; ++bx) {
        // Brute force: the maximum of each 2x2 block stays, the rest is zero.
        int my = 0, mx = 0;
        float best = -1;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const float v = input.at<float>(cv::Vec4i(0, c, 2 * by + dy, 2 * bx + dx));
            if (v > best) best = v, my = dy, mx = dx;
          }
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const float v = out.at<float>(cv::Vec4i(0, c, 2 * by + dy, 2 * bx + dx));
            EXPECT_FLOAT_EQ(v, (dy == my && dx == mx) ? best : 0.f);
          }
      }
}
