#include "pslam/synth/NormalsDataset.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/synth/Scenarios.h"
#include "pslam/synth/SynthApp.h"

namespace fs = std::filesystem;

namespace pslam::synth {

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
constexpr const char* kSplitEntries = "[a-z-]+_s[0-9]+_[0-9]{4,}_(image|normal|mask)\\.png|manifest\\.csv";

/// One generator per (scenario, seed, view): a view's draws do not depend on which other views are rendered.
std::mt19937_64 viewRng(const std::string& scenario, std::uint32_t seed, int view) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a over the scenario name, then the numbers
  for (char c : scenario) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  std::seed_seq seq{static_cast<std::uint32_t>(h), static_cast<std::uint32_t>(h >> 32), seed,
                    static_cast<std::uint32_t>(view), 0x4E4F524DU};
  return std::mt19937_64(seq);
}

Eigen::Vector3d direction(double azimuthDeg, double elevationDeg) {
  const double az = azimuthDeg * kDegToRad, el = elevationDeg * kDegToRad;
  return {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
}

std::string stemOf(const std::string& scenario, std::uint32_t seed, int view) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%s_s%u_%04d", scenario.c_str(), seed, view);
  return buf;
}

}  // namespace

std::vector<std::string> splitScenarioList(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    tok.erase(0, tok.find_first_not_of(" \t"));
    tok.erase(tok.find_last_not_of(" \t") + 1);
    out.push_back(tok);
  }
  return out;
}

std::optional<std::string> scenarioListProblem(const std::string& list) {
  const auto names = splitScenarioList(list);
  if (names.empty()) return "needs at least one scenario";
  const auto& known = scenarioNames();
  for (const auto& n : names)
    if (std::find(known.begin(), known.end(), n) == known.end()) {
      std::string all;
      for (const auto& k : known) all += (all.empty() ? "" : ", ") + k;
      return "unknown scenario '" + n + "' (known: " + all + ")";
    }
  return std::nullopt;
}

void NormalsDatasetOptions::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  params::load(*this, cfg, section);
}

void NormalsDatasetOptions::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  params::save(*this, cfg, section);
}

void NormalsDatasetOptions::check() const {
  params::check(*this, kSection);
  if (focalMax < focalMin)
    throw params::ParamError(kSection, "focal_max", std::to_string(focalMax), "must be >= focal_min");
  if (lookDownMaxDeg < lookDownMinDeg)
    throw params::ParamError(kSection, "look_down_max_deg", std::to_string(lookDownMaxDeg), "must be >= look_down_min_deg");
  if (outDir.empty()) throw params::ParamError(kSection, "out_dir", "", "output folder is required");
}

nlohmann::json NormalsDatasetOptions::toJson() const {
  return {{"scenarios", scenarios}, {"first_train_seed", firstTrainSeed}, {"train_seeds", trainSeeds},
          {"first_test_seed", firstTestSeed}, {"test_seeds", testSeeds}, {"views", views}, {"width", width},
          {"height", height}, {"focal_min", focalMin}, {"focal_max", focalMax}, {"untextured_share", untexturedShare},
          {"max_tilt_deg", maxTiltDeg}, {"look_down_share", lookDownShare}, {"look_down_min_deg", lookDownMinDeg},
          {"look_down_max_deg", lookDownMaxDeg}, {"random_lighting", randomLighting}, {"max_exposure_gain", maxExposureGain},
          {"max_exposure_offset", maxExposureOffset}, {"max_noise", maxNoise}, {"blur_share", blurShare},
          {"max_blur_sigma", maxBlurSigma}, {"supersampling", supersampling}, {"threads", threads},
          {"out_dir", outDir.string()}};
}

nlohmann::json NormalsDatasetSummary::toJson() const {
  return {{"train_views", trainViews}, {"test_views", testViews}, {"seconds", seconds},
          {"mean_mask_share", meanMaskShare}};
}

NormalsDataset::NormalsDataset(NormalsDatasetOptions options) : options_(std::move(options)) {
  // The output folder is checked by run(); in-memory rendering needs none.
  NormalsDatasetOptions probe = options_;
  if (probe.outDir.empty()) probe.outDir = ".";
  probe.check();
}

std::vector<NormalsSample> NormalsDataset::renderSequence(const std::string& scenarioName, std::uint32_t seed,
                                                          int firstView, int count) const {
  const NormalsDatasetOptions& o = options_;
  const ScenarioInfo info = scenarioInfo(scenarioName);
  const double duration = info.defaultFrames / info.fps;
  Scenario scenario = makeScenario(scenarioName, seed, duration);
  const Lighting presetLighting = scenario.scene.lighting;
  // Per sequence: textured or white surfaces (view -1 of the sequence's generator).
  std::mt19937_64 seqRng = viewRng(scenarioName, seed, -1);
  const bool textured = std::uniform_real_distribution<double>(0, 1)(seqRng) >= o.untexturedShare;

  std::vector<NormalsSample> out;
  out.reserve(static_cast<std::size_t>(std::max(count, 0)));
  for (int view = firstView; view < firstView + count; ++view) {
    std::mt19937_64 rng = viewRng(scenarioName, seed, view);
    auto U = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    ViewDraws d;
    d.textured = textured;
    // Every draw is taken whether or not it is used, so options change values, never the sequence of draws.
    d.time = U(0, duration);
    d.rollDeg = U(-1, 1) * o.maxTiltDeg;
    d.pitchDeg = U(-1, 1) * o.maxTiltDeg;
    d.yawDeg = U(-1, 1) * o.maxTiltDeg;
    d.focalFactor = U(o.focalMin, o.focalMax);
    const double keyAz = U(0, 360), keyEl = U(20, 80), fillAz = keyAz + 180 + U(-60, 60), fillEl = U(-60, 10);
    const double ambient = U(0.15, 0.45), key = U(0.35, 0.8), fill = U(0.1, 0.45);
    const double gainDraw = U(-1, 1), offsetDraw = U(-1, 1), noiseDraw = U(0, 1), blurDraw = U(0, 1),
                 sigmaDraw = U(0.3, o.maxBlurSigma);
    const auto noiseSeed = static_cast<std::uint64_t>(rng());
    const double lookDownDraw = U(0, 1), lookDownAngle = U(o.lookDownMinDeg, o.lookDownMaxDeg);
    // A rotation about the camera x axis by -a turns the optical axis towards +y, i.e. down.
    if (lookDownDraw < o.lookDownShare) d.pitchDeg -= lookDownAngle;
    Lighting light = presetLighting;
    if (o.randomLighting) {
      d.keyAzimuthDeg = keyAz;
      d.keyElevationDeg = keyEl;
      d.fillAzimuthDeg = std::fmod(fillAz, 360.0);
      d.fillElevationDeg = fillEl;
      d.ambient = ambient;
      d.key = key;
      d.fill = fill;
      light.keyDirection = direction(d.keyAzimuthDeg, d.keyElevationDeg);
      light.fillDirection = direction(d.fillAzimuthDeg, d.fillElevationDeg);
      light.ambient = ambient;
      light.key = key;
      light.fill = fill;
    } else {
      d.ambient = light.ambient;
      d.key = light.key;
      d.fill = light.fill;
    }
    d.gain = 1.0 + o.maxExposureGain * gainDraw;
    d.offset = o.maxExposureOffset * offsetDraw;
    d.noise = o.maxNoise * noiseDraw;
    d.blurSigma = blurDraw < o.blurShare ? sigmaDraw : 0.0;
    scenario.scene.lighting = light;

    NormalsSample s;
    s.scenario = scenarioName;
    s.seed = seed;
    s.view = view;
    s.draws = d;
    s.camera.width = o.width;
    s.camera.height = o.height;
    s.camera.fx = s.camera.fy = info.focalAt640 * o.width / 640.0 * d.focalFactor;
    s.camera.cx = 0.5 * (o.width - 1);
    s.camera.cy = 0.5 * (o.height - 1);
    RenderOptions ro;
    ro.textured = textured;
    ro.supersampling = o.supersampling;
    ro.threads = o.threads;
    const Renderer renderer(s.camera, ro);
    // The extra rotation turns the camera about its own centre, so it never enters furniture or walls.
    const Eigen::Matrix3d R_extra = (Eigen::AngleAxisd(d.yawDeg * kDegToRad, Eigen::Vector3d::UnitY()) *
                                     Eigen::AngleAxisd(d.pitchDeg * kDegToRad, Eigen::Vector3d::UnitX()) *
                                     Eigen::AngleAxisd(d.rollDeg * kDegToRad, Eigen::Vector3d::UnitZ()))
                                        .toRotationMatrix();
    Eigen::Isometry3d T_world_cam = scenario.T_world_cam(d.time);
    T_world_cam.linear() = T_world_cam.linear() * R_extra;
    RenderedView rv = renderer.render(scenario.scene, T_world_cam, d.time);
    if (d.blurSigma > 0) cv::GaussianBlur(rv.radiance, rv.radiance, cv::Size(0, 0), d.blurSigma);
    Exposure e;
    e.gain = d.gain;
    e.offset = d.offset;
    s.image = applySensor(rv.radiance, e, d.noise, noiseSeed);
    s.normals = rv.normals;
    // Every surface of the synthetic scenes is planar: the mask is every pixel with a ground-truth normal.
    s.mask = rv.depth > 0;
    out.push_back(std::move(s));
  }
  return out;
}

NormalsDatasetSummary NormalsDataset::run() const {
  const NormalsDatasetOptions& o = options_;
  o.check();
  const auto t0 = std::chrono::steady_clock::now();
  const auto scenarios = splitScenarioList(o.scenarios);
  OutputSet outputs;
  struct Split {
    const char* name;
    std::uint32_t firstSeed;
    int seeds;
    AtomicOutput* folder;
    std::ostringstream manifest;
    std::size_t views = 0;
  };
  Split splits[2] = {{"train", o.firstTrainSeed, o.trainSeeds, nullptr, {}, 0},
                     {"test", o.firstTestSeed, o.testSeeds, nullptr, {}, 0}};
  for (Split& s : splits) {
    s.folder = &outputs.add(o.outDir / s.name, OutputKind::folder(kSplitEntries));
    s.manifest << "stem,scenario,seed,view,width,height,fx,fy,cx,cy,textured,time,roll_deg,pitch_deg,yaw_deg,"
                  "key_azimuth_deg,key_elevation_deg,fill_azimuth_deg,fill_elevation_deg,ambient,key,fill,gain,"
                  "offset,noise,blur_sigma,mask_share\n";
  }
  AtomicOutput& info = outputs.add(o.outDir / "dataset.json");
  const std::size_t total = scenarios.size() *
                            static_cast<std::size_t>(o.trainSeeds + o.testSeeds) * static_cast<std::size_t>(o.views);
  Progress progress("normals-dataset", total, o.progress);
  NormalsDatasetSummary sum;
  std::size_t done = 0;
  double maskShareSum = 0;
  for (Split& split : splits)
    for (int k = 0; k < split.seeds; ++k)
      for (const std::string& scenario : scenarios) {
        const std::uint32_t seed = split.firstSeed + static_cast<std::uint32_t>(k);
        for (const NormalsSample& s : renderSequence(scenario, seed, 0, o.views)) {
          const std::string stem = stemOf(s.scenario, s.seed, s.view);
          const fs::path dir = split.folder->tempPath();
          const auto write = [&](const std::string& suffix, const cv::Mat& m) {
            const fs::path p = dir / (stem + suffix);
            if (!cv::imwrite(p.string(), m))
              throw Error((o.outDir / split.name / (stem + suffix)).string() + ": cannot write");
          };
          write("_image.png", s.image);
          write("_normal.png", priors::encodeNormalMap(s.normals, s.mask));
          write("_mask.png", s.mask);
          const double maskShare = cv::countNonZero(s.mask) / double(s.mask.total());
          maskShareSum += maskShare;
          const ViewDraws& d = s.draws;
          char line[1024];
          std::snprintf(line, sizeof(line),
                        "%s,%s,%u,%d,%d,%d,%.6f,%.6f,%.3f,%.3f,%d,%.6f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.4f,%.4f,"
                        "%.4f,%.4f,%.3f,%.3f,%.3f,%.4f\n",
                        stem.c_str(), s.scenario.c_str(), s.seed, s.view, s.camera.width, s.camera.height, s.camera.fx,
                        s.camera.fy, s.camera.cx, s.camera.cy, d.textured ? 1 : 0, d.time, d.rollDeg, d.pitchDeg,
                        d.yawDeg, d.keyAzimuthDeg, d.keyElevationDeg, d.fillAzimuthDeg, d.fillElevationDeg, d.ambient,
                        d.key, d.fill, d.gain, d.offset, d.noise, d.blurSigma, maskShare);
          split.manifest << line;
          ++split.views;
          progress.update(++done, stem);
        }
      }
  for (Split& s : splits) {
    // The folder itself is the atomic output: its manifest is written into the temporary like the images.
    std::ofstream os(s.folder->tempPath() / "manifest.csv");
    os << s.manifest.str();
    if (!os.flush()) throw Error((o.outDir / s.name / "manifest.csv").string() + ": cannot write");
  }
  sum.trainViews = splits[0].views;
  sum.testViews = splits[1].views;
  sum.meanMaskShare = done ? maskShareSum / double(done) : 0.0;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j;
  j["options"] = o.toJson();
  j["summary"] = sum.toJson();
  j["files"] = {{"image", "8-bit grey PNG"},
                {"normal", "8-bit 3-channel PNG, the NORMALS channel encoding: OpenCV channels 0,1,2 = camera x,y,z "
                           "(x right, y down, z forward) as round((n+1)/2*255); (0,0,0) = no normal"},
                {"mask", "8-bit PNG, 255 = planar pixel with a ground-truth normal"}};
  writeOutputFile(info, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
  outputs.commit();
  progress.finish(std::to_string(sum.trainViews) + " train + " + std::to_string(sum.testViews) + " held-out views");
  return sum;
}

}  // namespace pslam::synth
