#include "pslam/priors/BenchNormals.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/priors/NormalSource.h"

namespace fs = std::filesystem;

namespace pslam::priors {

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string tok;
  while (std::getline(ss, tok, ',')) out.push_back(tok);
  return out;
}

double medianOf(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Restores OpenCV's thread count when the timings end (or throw).
struct ThreadsGuard {
  int previous = cv::getNumThreads();
  explicit ThreadsGuard(int n) { cv::setNumThreads(n); }
  ~ThreadsGuard() { cv::setNumThreads(previous); }
};

cv::Mat normalsToBgr(const cv::Mat& n32) {
  cv::Mat out(n32.size(), CV_8UC3, cv::Scalar::all(0));
  for (int v = 0; v < n32.rows; ++v)
    for (int u = 0; u < n32.cols; ++u) {
      const cv::Vec3f n = n32.at<cv::Vec3f>(v, u);
      if (n == cv::Vec3f(0, 0, 0)) continue;
      auto c = [](float x) { return cv::saturate_cast<uchar>((x + 1.f) * 127.5f); };
      out.at<cv::Vec3b>(v, u) = cv::Vec3b(c(n[2]), c(n[1]), c(n[0]));  // (x, y, z) shown as (R, G, B)
    }
  return out;
}

}  // namespace

std::vector<LabelledNormalView> readNormalViews(const fs::path& folder, std::size_t maxViews) {
  const fs::path manifest = folder / "manifest.csv";
  std::ifstream in(manifest);
  require(static_cast<bool>(in), manifest.string(), "cannot read (a split folder written by normals-dataset?)");
  std::string line;
  std::getline(in, line);
  const auto header = splitCsv(line);
  auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    require(it != header.end(), manifest.string(), "has no column '" + name + "'");
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t cStem = column("stem"), cScenario = column("scenario"), cFx = column("fx"), cFy = column("fy"),
                    cCx = column("cx"), cCy = column("cy");
  std::vector<LabelledNormalView> views;
  std::size_t lineNo = 1;
  while (std::getline(in, line) && (maxViews == 0 || views.size() < maxViews)) {
    ++lineNo;
    if (line.empty()) continue;
    const auto f = splitCsv(line);
    require(f.size() == header.size(), manifest.string() + ":" + std::to_string(lineNo), "wrong number of fields");
    LabelledNormalView v;
    v.name = f[cStem];
    v.group = f[cScenario];
    v.K = {std::stod(f[cFx]), std::stod(f[cFy]), std::stod(f[cCx]), std::stod(f[cCy])};
    const auto read = [&](const std::string& suffix, int flags) {
      const fs::path p = folder / (v.name + suffix);
      cv::Mat m = cv::imread(p.string(), flags);
      require(!m.empty(), p.string(), "cannot read image");
      return m;
    };
    v.image = read("_image.png", cv::IMREAD_UNCHANGED);
    v.normals = decodeNormalMap(read("_normal.png", cv::IMREAD_UNCHANGED), (folder / (v.name + "_normal.png")).string());
    v.mask = read("_mask.png", cv::IMREAD_GRAYSCALE);
    views.push_back(std::move(v));
  }
  require(!views.empty(), manifest.string(), "lists no views");
  return views;
}

nlohmann::json NormalViewsAccuracy::toJson() const {
  nlohmann::json j = {{"all", all.toJson()}};
  for (const auto& [g, a] : perGroup) j["per_group"][g] = a.toJson();
  return j;
}

NormalViewsAccuracy evaluateNormalViews(NetworkNormalEstimator& estimator, const std::vector<LabelledNormalView>& views,
                                        std::vector<cv::Mat>* predictions) {
  NormalErrorAccumulator all;
  std::map<std::string, NormalErrorAccumulator> groups;
  for (const auto& v : views) {
    const NormalMap nm = estimator.compute(v.image, &v.K);
    cv::Mat truth(v.normals.size(), CV_32FC3, cv::Scalar::all(0));
    v.normals.copyTo(truth, v.mask);
    all.addMaps(nm.normals, truth);
    groups[v.group].addMaps(nm.normals, truth);
    if (predictions) predictions->push_back(nm.normals);
  }
  NormalViewsAccuracy r;
  r.all = all.summary();
  for (const auto& [g, acc] : groups) r.perGroup[g] = acc.summary();
  return r;
}

cv::Mat normalViewsPanel(const std::vector<LabelledNormalView>& views, const std::vector<cv::Mat>& predictions,
                         int scale) {
  require(views.size() == predictions.size() && !views.empty(), "normalViewsPanel", "one prediction per view needed");
  std::vector<cv::Mat> rows;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const auto& v = views[i];
    cv::Mat img;
    if (v.image.channels() == 1) cv::cvtColor(v.image, img, cv::COLOR_GRAY2BGR);
    else img = v.image.clone();
    cv::Mat truth(v.normals.size(), CV_32FC3, cv::Scalar::all(0));
    v.normals.copyTo(truth, v.mask);
    cv::Mat err8(v.normals.size(), CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < err8.rows; ++y)
      for (int x = 0; x < err8.cols; ++x) {
        const cv::Vec3f t = truth.at<cv::Vec3f>(y, x), p = predictions[i].at<cv::Vec3f>(y, x);
        if (t == cv::Vec3f(0, 0, 0) || p == cv::Vec3f(0, 0, 0)) continue;
        err8.at<uchar>(y, x) = cv::saturate_cast<uchar>(normalAngleDeg(p, t) / 45.0 * 255.0);
      }
    cv::Mat errColour;
    cv::applyColorMap(err8, errColour, cv::COLORMAP_INFERNO);
    std::vector<cv::Mat> tiles = {img, normalsToBgr(predictions[i]), normalsToBgr(truth), errColour};
    for (auto& t : tiles) cv::resize(t, t, cv::Size(), scale, scale, cv::INTER_NEAREST);
    cv::Mat row;
    cv::hconcat(tiles, row);
    rows.push_back(row);
  }
  cv::Mat panel;
  cv::vconcat(rows, panel);
  return panel;
}

nlohmann::json BenchNormalsResult::toJson() const {
  return {{"views", views},
          {"accuracy", accuracy.toJson()},
          {"forward_median_ms", forwardMedianMs},
          {"frame_median_ms", frameMedianMs}};
}

std::string BenchNormalsResult::toText() const {
  std::ostringstream t;
  char buf[256];
  t << "normal accuracy over " << views << " views (planar pixels; deg):\n";
  std::snprintf(buf, sizeof(buf), "  %-12s %10s %7s %7s %7s %8s %7s %7s\n", "group", "pixels", "mean", "median", "rmse",
                "<11.25", "<22.5", "<30");
  t << buf;
  auto row = [&](const std::string& name, const NormalAccuracy& a) {
    std::snprintf(buf, sizeof(buf), "  %-12s %10zu %7.2f %7.2f %7.2f %7.1f%% %6.1f%% %6.1f%%\n", name.c_str(), a.count,
                  a.meanDeg, a.medianDeg, a.rmseDeg, 100 * a.under11_25, 100 * a.under22_5, 100 * a.under30);
    t << buf;
  };
  for (const auto& [g, a] : accuracy.perGroup) row(g, a);
  row("all", accuracy.all);
  std::snprintf(buf, sizeof(buf), "time: network forward %.2f ms (median), whole estimator on a frame %.2f ms (median)\n",
                forwardMedianMs, frameMedianMs);
  t << buf;
  return t.str();
}

BenchNormalsResult runBenchNormals(const BenchNormalsOptions& o) {
  params::checkOption("--threads", o.threads, params::inClosed(1, 256));
  params::checkOption("--runs", o.runs, params::atLeast(1));
  params::checkOption("--panel-views", o.panelViews, params::atLeast(1));
  require(!o.config.empty(), "bench-normals", "a config file with [NormalsFromNetwork] is required");
  require(fs::is_regular_file(o.config), o.config.string(), "config file not found");
  // The shared Manhattan configs also hold [NormalsFromDepth] and [ManhattanTracker]: allowed, not read here.
  NetworkNormalParams np;
  params::loadConfigFile(o.config.string(), {kNetworkNormalsSection, kDepthNormalsSection, "ManhattanTracker"},
                         [&](const mrpt::config::CConfigFileBase& cfg) { np.loadFromConfigFile(cfg); });
  np.resolvePaths(fs::absolute(o.config).parent_path().string());
  if (np.model.empty())
    throw Error(o.config.string() + ": [" + kNetworkNormalsSection + "] model: missing (the network normal source needs it)");

  OutputSet outputs({o.config, np.model});
  AtomicOutput* panelOut = o.panel.empty() ? nullptr : &outputs.add(o.panel);
  AtomicOutput* jsonOut = o.json.empty() ? nullptr : &outputs.add(o.json);

  const auto views = readNormalViews(o.data, o.maxViews);
  ThreadsGuard threads(o.threads);
  NetworkNormalEstimator estimator(np);
  BenchNormalsResult r;
  r.views = views.size();
  std::vector<cv::Mat> predictions;
  r.accuracy = evaluateNormalViews(estimator, views, &predictions);

  // Timings: one warm-up, then `runs` timed runs each.
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  cv::Mat small = views.front().image;
  if (small.channels() == 1) cv::cvtColor(small, small, cv::COLOR_GRAY2BGR);
  cv::resize(small, small, cv::Size(np.inputWidth, np.inputHeight), 0, 0, cv::INTER_AREA);
  cv::Mat frame;
  cv::resize(small, frame, cv::Size(o.frameWidth, o.frameHeight), 0, 0, cv::INTER_LINEAR);
  PinholeIntrinsics K = views.front().K;
  const double sx = double(o.frameWidth) / views.front().image.cols, sy = double(o.frameHeight) / views.front().image.rows;
  K = {K.fx * sx, K.fy * sy, (K.cx + 0.5) * sx - 0.5, (K.cy + 0.5) * sy - 0.5};
  std::vector<double> forward, whole;
  for (int k = 0; k <= o.runs; ++k) {
    const auto t0 = Clock::now();
    (void)estimator.compute(small, &K);  // input size: no resizing, the forward pass dominates
    const auto t1 = Clock::now();
    (void)estimator.compute(frame, &K);
    const auto t2 = Clock::now();
    if (k == 0) continue;
    forward.push_back(ms(t0, t1));
    whole.push_back(ms(t1, t2));
  }
  r.forwardMedianMs = medianOf(forward);
  r.frameMedianMs = medianOf(whole);

  if (panelOut) {
    std::vector<LabelledNormalView> shown;
    std::vector<cv::Mat> shownPred;
    const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(o.panelViews), views.size());
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = i * views.size() / n;
      shown.push_back(views[k]);
      shownPred.push_back(predictions[k]);
    }
    std::vector<uchar> png;
    require(cv::imencode(".png", normalViewsPanel(shown, shownPred), png), o.panel.string(), "cannot encode");
    writeOutputFile(*panelOut, [&](std::ostream& os) { os.write(reinterpret_cast<const char*>(png.data()), png.size()); });
  }
  if (jsonOut) {
    nlohmann::json j = r.toJson();
    j["config"] = o.config.string();
    j["model"] = np.model;
    j["data"] = o.data.string();
    j["threads"] = o.threads;
    j["runs"] = o.runs;
    j["frame"] = {o.frameWidth, o.frameHeight};
    writeOutputFile(*jsonOut, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
  }
  outputs.commit();
  return r;
}

}  // namespace pslam::priors
