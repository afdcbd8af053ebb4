#pragma once
// The bench-normals tool: accuracy and speed of a normal network through OpenCV DNN (the NormalsFromNetwork
// path of normal-priors and manhattan-eval) on a held-out split written by normals-dataset
// (doc/normals_network.md). Accuracy is thesis §4.5.3's (eqs. 4.3-4.7) over the planar pixels, per scenario and
// over all; speed is the median time of the network alone at its input size and of the whole estimator on a
// full-size frame (input shrink, forward pass, output upsampling and renormalization), with OpenCV limited to
// `threads` threads. Optionally a PNG panel: input | prediction | ground truth | angular error per view.
#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/priors/NormalMap.h"
#include "pslam/priors/NormalsFromNetwork.h"

namespace pslam::priors {

/// One view with ground truth, as normals-dataset writes it.
struct LabelledNormalView {
  std::string name;      ///< file stem
  std::string group;     ///< accuracy is reported per group (the scenario)
  cv::Mat image;         ///< CV_8UC1 or CV_8UC3
  cv::Mat normals;       ///< CV_32FC3 ground truth, (0,0,0) = none
  cv::Mat mask;          ///< CV_8UC1, non-zero = evaluated
  PinholeIntrinsics K;
};

/// Reads the views of one normals-dataset split folder (manifest.csv + PNG triples), the first `maxViews` of
/// them when > 0. Throws pslam::Error naming the file at fault.
std::vector<LabelledNormalView> readNormalViews(const std::filesystem::path& splitFolder, std::size_t maxViews = 0);

struct NormalViewsAccuracy {
  NormalAccuracy all;
  std::map<std::string, NormalAccuracy> perGroup;
  nlohmann::json toJson() const;
};

/// Runs the estimator on every view and accumulates eq. 4.3 errors over the mask pixels where the prediction
/// has a normal. `predictions` (optional) receives the predicted maps in order.
NormalViewsAccuracy evaluateNormalViews(NetworkNormalEstimator& estimator, const std::vector<LabelledNormalView>& views,
                                        std::vector<cv::Mat>* predictions = nullptr);

/// Colour rows input | prediction | ground truth | error (0 = black .. 45 deg and more = white), each tile
/// scaled by `scale`. Normals are shown as (x, y, z) -> (R, G, B) of (n + 1) / 2.
cv::Mat normalViewsPanel(const std::vector<LabelledNormalView>& views, const std::vector<cv::Mat>& predictions,
                         int scale = 2);

struct BenchNormalsOptions {
  std::filesystem::path config;  ///< ini with [NormalsFromNetwork]
  std::filesystem::path data;    ///< a split folder of normals-dataset (e.g. /tmp/normals-data/test)
  std::size_t maxViews = 0;      ///< 0 = all
  int threads = 1;               ///< OpenCV threads during the timings
  int runs = 20;                 ///< timed runs of each timing (after one warm-up)
  int frameWidth = 640, frameHeight = 480;  ///< full-size frame of the estimator timing
  std::filesystem::path panel;   ///< optional PNG panel
  int panelViews = 6;            ///< views in the panel, spread evenly over the split
  std::filesystem::path json;    ///< optional JSON report
};

struct BenchNormalsResult {
  NormalViewsAccuracy accuracy;
  std::size_t views = 0;
  double forwardMedianMs = 0, frameMedianMs = 0;
  nlohmann::json toJson() const;
  std::string toText() const;
};

BenchNormalsResult runBenchNormals(const BenchNormalsOptions& options);

}  // namespace pslam::priors
