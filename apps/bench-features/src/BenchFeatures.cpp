#include "pslam/features/BenchFeatures.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <ostream>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/features/DirectPointSelector.h"

namespace pslam::features {
namespace fs = std::filesystem;
GridSpread gridSpread(const std::vector<cv::KeyPoint>& keypoints, cv::Size imageSize, int cols, int rows) {
  require(cols > 0 && rows > 0 && imageSize.width > 0 && imageSize.height > 0, "gridSpread", "empty grid or image");
  std::vector<int> counts(static_cast<size_t>(cols) * rows, 0);
  for (const cv::KeyPoint& kp : keypoints) {
    const int cx = std::clamp(static_cast<int>(kp.pt.x * cols / imageSize.width), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(kp.pt.y * rows / imageSize.height), 0, rows - 1);
    ++counts[static_cast<size_t>(cy) * cols + cx];
  }
  GridSpread g;
  g.minCount = *std::min_element(counts.begin(), counts.end());
  g.maxCount = *std::max_element(counts.begin(), counts.end());
  double mean = 0, var = 0;
  for (int c : counts) {
    g.emptyCells += c == 0;
    mean += c;
  }
  mean /= counts.size();
  for (int c : counts) var += (c - mean) * (c - mean);
  var /= counts.size();
  g.coefficientOfVariation = mean > 0 ? std::sqrt(var) / mean : 0;
  return g;
}

void BenchFeaturesOptions::check() const {
  require(runs >= 1, "--runs", "must be >= 1");
  require(maxImages >= 1, "--max-images", "must be >= 1");
  require(directPoints >= 0, "--direct", "must be >= 0");
  orb.check();
}

BenchFeaturesApp::BenchFeaturesApp(BenchFeaturesOptions options) : options_(std::move(options)) { options_.check(); }

std::vector<fs::path> BenchFeaturesApp::listImages(const fs::path& input, int maxImages) {
  require(fs::exists(input), input.string(), "no such file or folder");
  if (!fs::is_directory(input)) return {input};
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(input)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".pgm" || ext == ".ppm")
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  require(!files.empty(), input.string(), "folder contains no image files");
  if (static_cast<int>(files.size()) > maxImages) files.resize(maxImages);
  return files;
}

nlohmann::json BenchFeaturesResult::toJson(const BenchFeaturesOptions& o) const {
  nlohmann::json j;
  j["input"] = o.input.string();
  j["images"] = images;
  j["runs_per_image"] = o.runs;
  j["nFeatures"] = o.orb.nFeatures;
  j["nLevels"] = o.orb.nLevels;
  j["scaleFactor"] = o.orb.scaleFactor;
  j["mean_keypoints"] = meanKeypoints;
  j["mean_keypoints_opencv"] = meanKeypointsOpenCv;
  j["direct_points_target"] = o.directPoints;
  j["mean_direct_points"] = meanDirectPoints;
  j["timings_ms"] = timings.summary();
  auto spreadJson = [](const std::vector<GridSpread>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& g : v)
      a.push_back({{"empty_cells", g.emptyCells}, {"min", g.minCount}, {"max", g.maxCount}, {"cv", g.coefficientOfVariation}});
    return a;
  };
  j["spread_16x6"] = spreadJson(spread);
  j["spread_16x6_opencv"] = spreadJson(spreadOpenCv);
  return j;
}

BenchFeaturesResult BenchFeaturesApp::run(std::ostream& out) const {
  const auto files = listImages(options_.input, options_.maxImages);
  if (!options_.jsonOutput.empty()) {  // checked before the work: the JSON must not replace an input or a folder
    requireNotAnInput(options_.jsonOutput, OutputKind::file(), files);
    requireReplaceable(options_.jsonOutput, OutputKind::file());
  }
  OrbExtractor extractor(options_.orb);
  const OrbParams& p = options_.orb;
  // cv::ORB with the same budget and pyramid; its own (non-quadtree) selection and Harris ranking.
  cv::Ptr<cv::ORB> cvOrb = cv::ORB::create(p.nFeatures, static_cast<float>(p.scaleFactor), p.nLevels,
                                           p.edgeThreshold, 0, 2, cv::ORB::HARRIS_SCORE, p.patchSize, p.iniThFAST);
  DirectSelectorParams directParams;
  directParams.targetPoints = std::max(1, options_.directPoints);
  const DirectPointSelector direct(directParams);
  BenchFeaturesResult result;
  size_t nOurs = 0, nCv = 0, nTimed = 0, nDirect = 0;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (const fs::path& f : files) {
    const cv::Mat img = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
    require(!img.empty(), f.string(), "cannot read image (missing, unreadable or not an image)");
    result.images.push_back(f.string());
    for (int r = 0; r <= options_.runs; ++r) {  // r == 0: warm-up (caches, allocations), not timed
      OrbStageTimes t;
      extractor.extract(img, kps, desc, &t);
      if (options_.compareOpenCv) {
        std::vector<cv::KeyPoint> cvKps;
        cv::Mat cvDesc;
        const auto start = std::chrono::steady_clock::now();
        const double cpu1 = processCpuMs();
        cvOrb->detectAndCompute(img, cv::noArray(), cvKps, cvDesc);
        const double cpuCv = processCpuMs() - cpu1;
        const double ms = msSince(start);
        if (r == 0) result.spreadOpenCv.push_back(gridSpread(cvKps, img.size()));
        if (r > 0) {
          result.timings.add("opencv_orb", ms);
          result.timings.add("opencv_orb_cpu", cpuCv);
          nCv += cvKps.size();
        }
      }
      if (options_.directPoints > 0) {
        const auto start = std::chrono::steady_clock::now();
        const double cpu = processCpuMs();
        const size_t n = direct.select(img).size();
        const double cpuMs = processCpuMs() - cpu;
        const double ms = msSince(start);
        if (r > 0) {
          result.timings.add("direct_points", ms);
          result.timings.add("direct_points_cpu", cpuMs);
          nDirect += n;
        }
      }
      if (r == 0) {
        result.spread.push_back(gridSpread(kps, img.size()));
        continue;
      }
      result.timings.add("pyramid_cpu", t.pyramidCpuMs);
      result.timings.add("fast+quadtree_cpu", t.detectCpuMs);
      result.timings.add("orientation_cpu", t.orientationCpuMs);
      result.timings.add("descriptors_cpu", t.descriptorCpuMs);
      result.timings.add("levels_cpu", t.levelsCpuMs);
      result.timings.add("total_cpu", t.totalCpuMs());
      result.timings.add("pyramid", t.pyramidMs);
      result.timings.add("fast+quadtree", t.detectMs);
      result.timings.add("orientation", t.orientationMs);
      result.timings.add("descriptors", t.descriptorMs);
      result.timings.add("levels", t.levelsMs);
      result.timings.add("total", t.totalMs());
      nOurs += kps.size();
      ++nTimed;
    }
  }
  result.meanKeypoints = nTimed ? double(nOurs) / nTimed : 0;
  result.meanKeypointsOpenCv = nTimed ? double(nCv) / nTimed : 0;
  result.meanDirectPoints = nTimed ? double(nDirect) / nTimed : 0;

  const cv::Mat first = cv::imread(files.front().string(), cv::IMREAD_GRAYSCALE);
  char line[256];
  out << "bench-features: " << files.size() << " image(s) from " << options_.input.string() << " ("
      << first.cols << "x" << first.rows << " first), " << options_.runs << " runs each, nFeatures "
      << p.nFeatures << ", " << p.threads << " thread(s) for the levels\n"
      << "(fast+quadtree, orientation, descriptors: the work summed over the levels; levels: their wall time)\n";
  std::snprintf(line, sizeof line, "%-18s %10s %10s %10s\n", "stage", "median_ms", "p90_ms", "min_ms");
  out << line;
  for (const char* stage : {"pyramid", "fast+quadtree", "orientation", "descriptors", "levels", "total",
                            "pyramid_cpu", "fast+quadtree_cpu", "orientation_cpu", "descriptors_cpu", "levels_cpu",
                            "total_cpu", "opencv_orb", "opencv_orb_cpu", "direct_points", "direct_points_cpu"}) {
    const auto it = result.timings.samples().find(stage);
    if (it == result.timings.samples().end()) continue;
    std::snprintf(line, sizeof line, "%-18s %10.2f %10.2f %10.2f\n", stage, percentile(it->second, 50),
                  percentile(it->second, 90), percentile(it->second, 0));
    out << line;
  }
  std::snprintf(line, sizeof line, "keypoints: OrbExtractor %.1f, cv::ORB %.1f (mean per image)\n",
                result.meanKeypoints, result.meanKeypointsOpenCv);
  out << line;
  auto meanSpread = [](const std::vector<GridSpread>& v, double& empty, double& cv) {
    empty = cv = 0;
    for (const auto& g : v) {
      empty += g.emptyCells;
      cv += g.coefficientOfVariation;
    }
    if (!v.empty()) {
      empty /= v.size();
      cv /= v.size();
    }
  };
  double empty, cvar;
  meanSpread(result.spread, empty, cvar);
  std::snprintf(line, sizeof line, "spread on a 16x6 grid: OrbExtractor %.1f empty cells, count CV %.2f", empty, cvar);
  out << line;
  if (!result.spreadOpenCv.empty()) {
    meanSpread(result.spreadOpenCv, empty, cvar);
    std::snprintf(line, sizeof line, "; cv::ORB %.1f empty cells, count CV %.2f", empty, cvar);
    out << line;
  }
  out << " (mean per image)\n";
  if (options_.directPoints > 0) {
    std::snprintf(line, sizeof line, "direct points: %.1f (mean per image, target %d)\n", result.meanDirectPoints,
                  options_.directPoints);
    out << line;
  }

  if (!options_.jsonOutput.empty()) {
    const nlohmann::json j = result.toJson(options_);
    writeFileAtomically(options_.jsonOutput, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
  }
  return result;
}

}  // namespace pslam::features
