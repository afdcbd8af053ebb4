#include "pslam/synth/SynthApp.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <mrpt/system/datetime.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;

namespace pslam::synth {

namespace {

constexpr double kFirstStamp = 1000.0;  // seconds; stamps are whole microseconds from here

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

// ------------------------------------------------------------------------------------------------ options
std::optional<std::string> pathVariantProblem(const std::string& scenario, int pathVariant) {
  const auto& names = scenarioNames();
  if (std::find(names.begin(), names.end(), scenario) == names.end()) return std::nullopt;
  try {
    requirePathVariant(scenario, pathVariant);
  } catch (const Error& e) {
    return std::string(e.what());
  }
  return std::nullopt;
}

void SynthOptions::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  // The rules only: out_dir may still come from the command line.
  params::load(*this, cfg, section);
}

void SynthOptions::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  params::save(*this, cfg, section);
}

void SynthOptions::check() const {
  params::check(*this, kSection);
  if (outDir.empty()) throw params::ParamError(kSection, "out_dir", "", "output folder is required");
}

AntiAliasing SynthOptions::antiAliasingMode() const {
  if (antiAliasing == "silhouettes") return AntiAliasing::Silhouettes;
  if (antiAliasing == "full") return AntiAliasing::Full;
  return AntiAliasing::Adaptive;
}

PinholeCamera SynthOptions::camera() const {
  const ScenarioInfo info = scenarioInfo(scenario);
  PinholeCamera c;
  c.width = width;
  c.height = height;
  c.fx = fx > 0 ? fx : info.focalAt640 * width / 640.0;
  c.fy = fy > 0 ? fy : c.fx;
  c.cx = cx >= 0 ? cx : 0.5 * (width - 1);
  c.cy = cy >= 0 ? cy : 0.5 * (height - 1);
  return c;
}

nlohmann::json SynthOptions::toJson() const {
  return {{"scenario", scenario}, {"frames", frames}, {"width", width}, {"height", height}, {"fx", fx},
          {"fy", fy}, {"cx", cx}, {"cy", cy}, {"seed", seed}, {"path_variant", pathVariant}, {"texture", textured}, {"noise_sigma", noiseSigma},
          {"exposure", exposure}, {"supersampling", supersampling}, {"anti_aliasing", antiAliasing}, {"aa_contrast", aaContrast},
          {"out_dir", outDir.string()}, {"name", effectiveName()}, {"preview_frame", previewFrame},
          {"threads", threads}};
}

// ------------------------------------------------------------------------------------------------ sensor
Exposure Exposure::at(double t, std::uint32_t seed) {
  // Auto-exposure drifts over seconds, not frames: noise with a 2 s correlation length.
  Exposure e;
  e.gain = 1.0 + 0.25 * smoothNoise1D(t / 2.0, seed ^ 0xE1E1E1E1U);
  e.offset = 15.0 * smoothNoise1D(t / 2.0, seed ^ 0x0FF5E7U);
  return e;
}

cv::Mat applySensor(const cv::Mat& radiance, const Exposure& exposure, double noiseSigma, std::uint64_t noiseSeed) {
  require(radiance.type() == CV_32FC1 && !radiance.empty(), "applySensor", "radiance must be a non-empty CV_32FC1");
  cv::Mat v;
  radiance.convertTo(v, CV_32F, exposure.gain, exposure.offset);
  if (noiseSigma > 0) {
    cv::Mat n(v.size(), CV_32F);
    cv::RNG rng(noiseSeed == 0 ? 0x9E3779B97F4A7C15ULL : noiseSeed);
    rng.fill(n, cv::RNG::NORMAL, 0.0, noiseSigma);
    v += n;
  }
  cv::Mat out;
  v.convertTo(out, CV_8U);  // rounds and saturates to [0, 255]
  return out;
}

cv::Vec3b cityscapesColour(std::uint8_t id) {
  static const unsigned char rgb[19][3] = {
      {128, 64, 128}, {244, 35, 232}, {70, 70, 70},   {102, 102, 156}, {190, 153, 153}, {153, 153, 153}, {250, 170, 30},
      {220, 220, 0},  {107, 142, 35}, {152, 251, 152}, {70, 130, 180},  {220, 20, 60},   {255, 0, 0},     {0, 0, 142},
      {0, 0, 70},     {0, 60, 100},   {0, 80, 100},   {0, 0, 230},     {119, 11, 32}};
  if (id >= 19) return {0, 0, 0};
  return {rgb[id][2], rgb[id][1], rgb[id][0]};
}

cv::Mat makePreviewPanel(const cv::Mat& grey, const cv::Mat& depth, const cv::Mat& normals, const cv::Mat& ids,
                         int panelWidth) {
  const cv::Size size(panelWidth, static_cast<int>(std::lround(double(panelWidth) * grey.rows / grey.cols)));
  cv::Mat img, d, n, l;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  // Inverse depth, normalized to the valid range, so near structure is resolved.
  cv::Mat inv(depth.size(), CV_32F, cv::Scalar(0)), valid = depth > 0;
  cv::divide(1.0, depth, inv, CV_32F);
  inv.setTo(0, ~valid);
  double lo = 0, hi = 1;
  cv::minMaxLoc(inv, &lo, &hi, nullptr, nullptr, valid);
  cv::Mat inv8;
  inv.convertTo(inv8, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -255.0 * lo / (hi - lo) : 0.0);
  cv::applyColorMap(inv8, d, cv::COLORMAP_TURBO);
  d.setTo(cv::Scalar(0, 0, 0), ~valid);
  n.create(normals.size(), CV_8UC3);
  l.create(ids.size(), CV_8UC3);
  for (int y = 0; y < normals.rows; ++y)
    for (int x = 0; x < normals.cols; ++x) {
      const cv::Vec3f v = normals.at<cv::Vec3f>(y, x);
      const cv::Vec3b e = (v == cv::Vec3f(0, 0, 0)) ? cv::Vec3b(0, 0, 0) : datasets::encodeNormal(cv::Vec3d(v[0], v[1], v[2]));
      n.at<cv::Vec3b>(y, x) = cv::Vec3b(e[2], e[1], e[0]);  // show (x, y, z) as (R, G, B)
      l.at<cv::Vec3b>(y, x) = cityscapesColour(ids.at<std::uint8_t>(y, x));
    }
  cv::resize(img, img, size, 0, 0, cv::INTER_AREA);
  cv::resize(d, d, size, 0, 0, cv::INTER_NEAREST);
  cv::resize(n, n, size, 0, 0, cv::INTER_NEAREST);
  cv::resize(l, l, size, 0, 0, cv::INTER_NEAREST);
  cv::Mat panel;
  cv::hconcat(std::vector<cv::Mat>{img, d, n, l}, panel);
  return panel;
}

// ------------------------------------------------------------------------------------------------ summary
nlohmann::json SynthSummary::toJson() const {
  return {{"frames", frames},
          {"render_seconds", renderSeconds},
          {"total_seconds", totalSeconds},
          {"render_fps", renderSeconds > 0 ? frames / renderSeconds : 0.0},
          {"render_cpu_seconds", renderCpuSeconds},
          {"render_fps_per_cpu_second", renderCpuSeconds > 0 ? frames / renderCpuSeconds : 0.0},
          {"total_cpu_seconds", totalCpuSeconds},
          {"total_fps", totalSeconds > 0 ? frames / totalSeconds : 0.0},
          {"mean_dynamic_fraction", meanDynamicFraction},
          {"mean_sky_fraction", meanSkyFraction},
          {"mean_valid_depth_fraction", meanValidDepthFraction},
          {"mean_fast_corners", meanFastCorners},
          {"rawlog", rawlog.string()},
          {"groundtruth", groundTruth.string()},
          {"labels", labelsDir.string()},
          {"timings", timings.summary()}};
}

std::string SynthSummary::toText() const {
  char buf[1024];
  std::snprintf(buf, sizeof(buf),
                "frames: %zu\nrender: %.2f s wall (%.1f frames/s), %.2f s CPU (%.1f frames/s on one core)\n"
                "total: %.2f s wall (%.1f frames/s), %.2f s CPU (%.1f frames/s) incl. encoding and writing\n"
                "mean dynamic pixels: %.1f %%, sky: %.1f %%, valid depth: %.1f %%\nmean FAST corners "
                "(threshold 20): %.0f\nrawlog: %s\nground truth: %s\nlabels: %s\ninfo: %s\n",
                frames, renderSeconds, renderSeconds > 0 ? frames / renderSeconds : 0.0, renderCpuSeconds,
                renderCpuSeconds > 0 ? frames / renderCpuSeconds : 0.0, totalSeconds,
                totalSeconds > 0 ? frames / totalSeconds : 0.0, totalCpuSeconds,
                totalCpuSeconds > 0 ? frames / totalCpuSeconds : 0.0, 100 * meanDynamicFraction, 100 * meanSkyFraction,
                100 * meanValidDepthFraction, meanFastCorners, rawlog.string().c_str(), groundTruth.string().c_str(),
                labelsDir.string().c_str(), info.string().c_str());
  return buf;
}

// ------------------------------------------------------------------------------------------------ app
SynthApp::SynthApp(SynthOptions options, std::vector<std::filesystem::path> inputs)
    : options_(std::move(options)), inputs_(std::move(inputs)) {
  options_.check();
}

SynthSummary SynthApp::run() {
  const auto tStart = std::chrono::steady_clock::now();
  const std::clock_t cStart = std::clock();
  const SynthOptions& o = options_;
  const ScenarioInfo info = scenarioInfo(o.scenario);
  const int frames = o.frames > 0 ? o.frames : info.defaultFrames;
  const double duration = frames / info.fps;
  const int previewFrame = o.previewFrame >= 0 ? o.previewFrame : frames / 2;
  if (!o.preview.empty() && previewFrame >= frames)
    throw Error("[synth] preview_frame: frame " + std::to_string(previewFrame) + " is beyond the " +
                std::to_string(frames) + " frames generated");
  const Scenario scenario = makeScenario(o.scenario, o.seed, duration, o.pathVariant);
  const PinholeCamera cam = o.camera();
  RenderOptions ro;
  ro.textured = o.textured;
  ro.supersampling = o.supersampling;
  ro.antiAliasing = o.antiAliasingMode();
  ro.adaptiveContrast = o.aaContrast;
  ro.threads = o.threads;
  const Renderer renderer(cam, ro);
  const std::string name = o.effectiveName();

  SynthSummary sum;
  sum.rawlog = o.outDir / (name + ".rawlog");
  sum.groundTruth = o.outDir / (name + "_groundtruth.txt");
  sum.labelsDir = o.outDir / (name + "_Labels");
  sum.info = o.outDir / (name + "_synth.json");

  // Every output is prepared before rendering (an impossible path fails now) and all are committed at the end.
  OutputSet outputs(inputs_);
  datasets::RawlogWriter writer(sum.rawlog, "png", &outputs);
  AtomicOutput& labelsOut = outputs.add(sum.labelsDir, OutputKind::folder("LABEL_[0-9]{6,}\\.png"));
  AtomicOutput& groundTruthOut = outputs.add(sum.groundTruth);
  AtomicOutput* previewOut = o.preview.empty() ? nullptr : &outputs.add(o.preview);
  AtomicOutput& infoOut = outputs.add(sum.info);

  Trajectory gt;
  gt.reserve(static_cast<std::size_t>(frames));
  Progress progress("slam-synth " + name, static_cast<std::size_t>(frames), o.progress);
  const mrpt::img::TCamera tcam = cam.toTCamera();
  cv::Mat preview;
  double renderSeconds = 0;
  const cv::Vec3b oneHot[3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
  for (int i = 0; i < frames; ++i) {
    const double tScene = i / info.fps;
    // Stamps are whole microseconds and survive the rawlog's mrpt::Clock round trip exactly, so the ground
    // truth written with 6 decimals equals the CAMERA stamps.
    const double rawStamp = std::round((kFirstStamp + tScene) * 1e6) / 1e6;
    const double stamp = mrpt::Clock::toDouble(mrpt::Clock::fromDouble(rawStamp));
    const Eigen::Isometry3d T_world_cam = scenario.T_world_cam(tScene);

    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    RenderedView view = renderer.render(scenario.scene, T_world_cam, tScene);
    const double dt = secondsSince(t0);
    renderSeconds += dt;
    sum.renderCpuSeconds += double(std::clock() - c0) / CLOCKS_PER_SEC;
    sum.timings.add("render", 1000 * dt);

    auto tStage = std::chrono::steady_clock::now();
    auto stageDone = [&](const char* stage) {
      const auto now = std::chrono::steady_clock::now();
      sum.timings.add(stage, std::chrono::duration<double, std::milli>(now - tStage).count());
      tStage = now;
    };
    datasets::Frame f;
    f.timestamp = stamp;
    f.camera = tcam;
    f.image = applySensor(view.radiance, o.exposure ? Exposure::at(tScene, o.seed) : Exposure{}, o.noiseSigma,
                          (static_cast<std::uint64_t>(o.seed) << 32) ^ static_cast<std::uint64_t>(i + 1));
    f.depthUnits = info.depthUnit;
    f.depth.create(cam.height, cam.width, CV_16UC1);
    f.semantic.create(cam.height, cam.width, CV_8UC3);
    f.normals.create(cam.height, cam.width, CV_8UC3);
    std::size_t dynamicPx = 0, skyPx = 0, validPx = 0;
    const double invDepthUnit = 1.0 / info.depthUnit;
    for (int y = 0; y < cam.height; ++y) {
      const float* z = view.depth.ptr<float>(y);
      const cv::Vec3f* n = view.normals.ptr<cv::Vec3f>(y);
      const std::uint8_t* cls = view.trainId.ptr<std::uint8_t>(y);
      auto* dOut = f.depth.ptr<std::uint16_t>(y);
      auto* sOut = f.semantic.ptr<cv::Vec3b>(y);
      auto* nOut = f.normals.ptr<cv::Vec3b>(y);
      cv::Vec3f lastNormal(0, 0, 0);
      cv::Vec3b lastEncoded(0, 0, 0);
      for (int x = 0; x < cam.width; ++x) {
        const double units = z[x] > 0 ? std::floor(z[x] * invDepthUnit + 0.5) : 0.0;
        dOut[x] = (units >= 1 && units <= 65535) ? static_cast<std::uint16_t>(units) : 0;  // out of range: invalid
        validPx += dOut[x] != 0;
        const int group = semanticGroupOfTrainId(cls[x]);
        sOut[x] = oneHot[group];
        dynamicPx += group == 1;
        skyPx += cls[x] == static_cast<std::uint8_t>(TrainId::Sky);
        if (z[x] > 0) {
          // Surfaces are planar: runs of identical normals are encoded once.
          if (n[x] != lastNormal) {
            lastNormal = n[x];
            lastEncoded = datasets::encodeNormal(cv::Vec3d(n[x][0], n[x][1], n[x][2]));
          }
          nOut[x] = lastEncoded;
        } else {
          nOut[x] = cv::Vec3b(0, 0, 0);
        }
      }
    }
    stageDone("channels");
    writer.write(f);
    stageDone("rawlog_write");
    char labelName[64];
    std::snprintf(labelName, sizeof(labelName), "LABEL_%06d.png", i);
    const fs::path labelFile = labelsOut.tempPath() / labelName;
    if (!cv::imwrite(labelFile.string(), view.trainId))
      throw Error(sum.labelsDir.string() + ": cannot write " + labelName);
    gt.emplace_back(stamp, T_world_cam);
    stageDone("labels_write");

    const double npx = double(cam.width) * cam.height;
    sum.meanDynamicFraction += dynamicPx / npx;
    sum.meanSkyFraction += skyPx / npx;
    sum.meanValidDepthFraction += validPx / npx;
    std::vector<cv::KeyPoint> corners;
    cv::FAST(f.image, corners, 20, true);
    sum.meanFastCorners += static_cast<double>(corners.size());
    stageDone("fast_corners");
    if (i == previewFrame && !o.preview.empty()) preview = makePreviewPanel(f.image, view.depth, view.normals, view.trainId);
    progress.update(static_cast<std::size_t>(i + 1));
  }
  writer.commit();
  writeTumTrajectory(groundTruthOut.tempPath(), gt,
                     "ground truth of slam-synth scenario '" + o.scenario + "' seed " + std::to_string(o.seed) +
                         (o.pathVariant != 0 ? " path variant " + std::to_string(o.pathVariant) : std::string()) +
                         " (camera-to-world, T_world_cam)");
  sum.frames = static_cast<std::size_t>(frames);
  sum.meanDynamicFraction /= frames;
  sum.meanSkyFraction /= frames;
  sum.meanValidDepthFraction /= frames;
  sum.meanFastCorners /= frames;
  sum.renderSeconds = renderSeconds;
  if (previewOut) {
    std::vector<uchar> png;
    if (!cv::imencode(".png", preview, png, {cv::IMWRITE_PNG_COMPRESSION, 9}))
      throw Error(o.preview.string() + ": cannot encode preview");
    writeOutputFile(*previewOut, [&](std::ostream& os) { os.write(reinterpret_cast<const char*>(png.data()), png.size()); });
  }
  sum.totalSeconds = secondsSince(tStart);
  sum.totalCpuSeconds = double(std::clock() - cStart) / CLOCKS_PER_SEC;
  nlohmann::json j;
  j["options"] = o.toJson();
  j["scenario"] = {{"name", info.name}, {"description", info.description}, {"fps", info.fps},
                   {"depth_unit_m", info.depthUnit}, {"frames", frames}};
  j["camera"] = {{"width", cam.width}, {"height", cam.height}, {"fx", cam.fx}, {"fy", cam.fy}, {"cx", cam.cx},
                 {"cy", cam.cy}};
  j["labels"] = {{"format", "8-bit PNG of Cityscapes trainIds, 255 = unlabeled"},
                 {"pattern", name + "_Labels/LABEL_%06d.png (frame index)"}};
  j["summary"] = sum.toJson();
  writeOutputFile(infoOut, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
  outputs.commit();
  progress.finish(std::to_string(frames) + " frames");
  return sum;
}

}  // namespace pslam::synth
