#pragma once
// The app class behind `bench-features`: per-stage timings of OrbExtractor (pyramid, FAST + quadtree,
// orientation, descriptors) against cv::ORB on the same images, as median and 90th percentile over N runs.
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/StageTimer.h"
#include "pslam/features/OrbExtractor.h"

namespace pslam::features {

/// How evenly keypoints cover an image: counts on a cols x rows grid.
struct GridSpread {
  int emptyCells = 0;
  int minCount = 0, maxCount = 0;
  double coefficientOfVariation = 0;  ///< std / mean of the cell counts (0 = perfectly even)
};
GridSpread gridSpread(const std::vector<cv::KeyPoint>& keypoints, cv::Size imageSize, int cols = 16, int rows = 6);

struct BenchFeaturesOptions {
  std::filesystem::path input;      ///< an image file or a folder of images (.png/.jpg/.jpeg/.bmp/.pgm/.ppm)
  int runs = 20;                    ///< timed runs per image (after one untimed warm-up run)
  int maxImages = 10;               ///< first N images of a folder (sorted by name)
  OrbParams orb;                    ///< extractor parameters; cv::ORB uses the same nFeatures/levels/scale/FAST
  bool compareOpenCv = true;        ///< also time cv::ORB::detectAndCompute
  int directPoints = 0;             ///< > 0: also time DirectPointSelector with this target (stage direct_points)
  std::filesystem::path jsonOutput; ///< optional: write the summary as JSON (atomically)
  void check() const;
};

struct BenchFeaturesResult {
  /// Wall-clock stages pyramid, fast+quadtree, orientation, descriptors, total, opencv_orb, direct_points; the
  /// same with suffix _cpu in process CPU time (robust to a loaded machine).
  StageTimings timings;
  std::vector<std::string> images;
  double meanKeypoints = 0;         ///< OrbExtractor keypoints per image
  double meanKeypointsOpenCv = 0;   ///< cv::ORB keypoints per image
  double meanDirectPoints = 0;      ///< DirectPointSelector points per image (if timed)
  std::vector<GridSpread> spread, spreadOpenCv;  ///< per image, 16 x 6 grid
  nlohmann::json toJson(const BenchFeaturesOptions& options) const;
};

class BenchFeaturesApp {
 public:
  explicit BenchFeaturesApp(BenchFeaturesOptions options);
  /// Runs the benchmark, prints a table to `out`, writes the JSON if asked. Throws pslam::Error naming the file
  /// for missing/unreadable inputs.
  BenchFeaturesResult run(std::ostream& out) const;
  /// The images a path stands for: the file itself, or the first maxImages image files of a folder by name.
  static std::vector<std::filesystem::path> listImages(const std::filesystem::path& input, int maxImages);

 private:
  BenchFeaturesOptions options_;
};

}  // namespace pslam::features
