// semantic-bench: runs a segmentation network (config/semantic/*.ini) on images, measures the time per
// frame, prints the per-class and Table 3.1 group histograms, and optionally writes the overlay of the first
// image and a class-histogram plot. Timings exclude image loading; the first `--warmup` runs are not timed.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <iostream>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/StageTimer.h"
#include "pslam/eval/Plot.h"
#include "pslam/priors/SemanticImage.h"
#include "pslam/priors/SemanticNetwork.h"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  using namespace pslam::priors;
  CLI::App cli{"Segmentation time and class histograms of a network on images"};
  std::string network, imagesDir, overlayPath, histPath;
  std::vector<std::string> images;
  std::size_t maxImages = 5, warmup = 1;
  cli.add_option("--network", network, "network ini")->required();
  cli.add_option("images", images, "image files");
  cli.add_option("--images-dir", imagesDir, "folder of images (sorted by name)");
  cli.add_option("--max-images", maxImages, "images from --images-dir")
      ->check(pslam::params::cliCheck<std::size_t>(pslam::params::atLeast(1)))
      ->capture_default_str();
  cli.add_option("--warmup", warmup, "untimed runs on the first image")
      ->check(pslam::params::cliCheck<std::size_t>())
      ->capture_default_str();
  cli.add_option("--overlay", overlayPath, "PNG: overlay of the first image");
  cli.add_option("--histogram-plot", histPath, "PNG: class histogram over all images");
  CLI11_PARSE(cli, argc, argv);
  try {
    if (!imagesDir.empty()) {
      if (!fs::is_directory(imagesDir)) throw pslam::Error(imagesDir + ": folder not found");
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(imagesDir))
        if (e.is_regular_file()) found.push_back(e.path().string());
      std::sort(found.begin(), found.end());
      if (found.size() > maxImages) found.resize(maxImages);
      images.insert(images.end(), found.begin(), found.end());
    }
    if (images.empty()) throw pslam::Error("no images given");
    SemanticNetwork net(SemanticNetworkParams::loadFromFile(network));
    const auto& map = net.classMap();
    std::vector<double> classHist(map.numClasses(), 0.0);
    std::array<double, 3> groupHist{};
    pslam::StageTimings timings;
    for (std::size_t i = 0; i < images.size(); ++i) {
      const cv::Mat img = cv::imread(images[i], cv::IMREAD_UNCHANGED);
      if (img.empty()) throw pslam::Error(images[i] + ": cannot read image");
      if (i == 0)
        for (std::size_t w = 0; w < warmup; ++w) net.segment(img);
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat scores = net.scores(img);
      const auto t1 = std::chrono::steady_clock::now();
      const cv::Mat semantic = net.semanticFromScores(scores, img.size());
      const auto t2 = std::chrono::steady_clock::now();
      timings.add("network", std::chrono::duration<double, std::milli>(t1 - t0).count());
      timings.add("softmax+groups+resize", std::chrono::duration<double, std::milli>(t2 - t1).count());
      timings.add("total", std::chrono::duration<double, std::milli>(t2 - t0).count());
      const auto h = argmaxClassHistogram(scores);
      const auto g = semanticHistogram(semantic);
      for (int c = 0; c < map.numClasses(); ++c) classHist[c] += h[c] / images.size();
      for (int k = 0; k < 3; ++k) groupHist[k] += g[k] / images.size();
      std::cout << fs::path(images[i]).filename().string() << " " << img.cols << "x" << img.rows
                << ": P(static, dynamic, invalid) = " << std::fixed << std::setprecision(3) << g[0] << " " << g[1]
                << " " << g[2] << "\n";
      if (i == 0 && !overlayPath.empty()) pslam::eval::savePngAtomically(overlayPath, semanticOverlay(img, semantic));
    }
    std::cout << "class histogram (arg-max pixels, mean over images):\n";
    std::vector<int> order(map.numClasses());
    for (int c = 0; c < map.numClasses(); ++c) order[c] = c;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return classHist[a] > classHist[b]; });
    for (int c : order)
      if (classHist[c] >= 0.005)
        std::cout << "  " << std::setw(14) << map.classNames[c] << " (" << toString(map.groups[c])
                  << "): " << std::setprecision(1) << 100 * classHist[c] << "%\n";
    std::cout << std::setprecision(3) << "group histogram P(static, dynamic, invalid): " << groupHist[0] << " "
              << groupHist[1] << " " << groupHist[2] << "\n";
    std::cout << "timings over " << images.size() << " images (ms): " << timings.summary().dump() << "\n";
    if (!histPath.empty()) {
      pslam::eval::Plot plot("Class histogram (" + map.name + ", " + std::to_string(images.size()) + " images)",
                             "class index", "fraction of pixels");
      const cv::Scalar groupColor[3] = {pslam::eval::colors::green(), pslam::eval::colors::red(),
                                        pslam::eval::colors::blue()};
      for (int c = 0; c < map.numClasses(); ++c)
        plot.addLine({double(c), double(c)}, {0.0, classHist[c]}, "", groupColor[int(map.groups[c])], 14);
      plot.addLine({}, {}, "static", groupColor[0]);
      plot.addLine({}, {}, "dynamic", groupColor[1]);
      plot.addLine({}, {}, "invalid", groupColor[2]);
      plot.setXRange(-1, map.numClasses());
      plot.setYRange(0, std::max(0.05, *std::max_element(classHist.begin(), classHist.end()) * 1.1));
      plot.save(histPath);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "semantic-bench: error: " << e.what() << "\n";
    return 1;
  }
}
