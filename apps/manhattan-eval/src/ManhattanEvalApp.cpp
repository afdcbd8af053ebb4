#include "pslam/manhattan/ManhattanEvalApp.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/Progress.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/Plot.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/priors/NormalSource.h"

namespace fs = std::filesystem;

namespace pslam::manhattan {

namespace {

double median(std::vector<double> v) { return percentile(std::move(v), 50.0); }

}  // namespace

ManhattanEvalConfig ManhattanEvalConfig::loadFromFile(const fs::path& path) {
  ManhattanEvalConfig c;
  if (path.empty()) return c;
  params::loadSectionsFromFile(c, path.string());
  c.normals.resolvePaths(path);
  return c;
}

ManhattanEvalResult runManhattanEval(const ManhattanEvalOptions& o) {
  params::checkOption("--normal-stride", o.normalStride, params::atLeast(1));
  params::checkOption("--accuracy-pixels", o.accuracyPixels, params::oneOf({"all", "reference-planar"}));
  params::checkOption("--max-gt-dt", o.maxGroundTruthDt, params::atLeast(0));
  require(!o.rawlog.empty(), "manhattan-eval", "an input rawlog is required");
  require(fs::is_regular_file(o.rawlog), o.rawlog.string(), "rawlog not found");
  const ManhattanEvalConfig ini = ManhattanEvalConfig::loadFromFile(o.config);
  const ManhattanParams& params = ini.tracker;
  const auto sourceFrom = [](const std::string& kind, const ManhattanEvalConfig& c, const fs::path& path) {
    if (kind == "network" && c.normals.network.model.empty() && !path.empty())
      throw Error(path.string() + ": [" + priors::kNetworkNormalsSection +
                  "] model: missing (the network normal source needs it)");
    return priors::makeNormalSource(kind, c.normals);
  };
  auto normalSource = sourceFrom(o.normals, ini, o.config);
  std::unique_ptr<priors::NormalSource> referenceSource;
  if (!o.referenceNormals.empty()) {
    const fs::path refPath = o.referenceConfig.empty() ? o.config : o.referenceConfig;
    referenceSource = sourceFrom(o.referenceNormals, ManhattanEvalConfig::loadFromFile(refPath), refPath);
  }

  fs::path gtPath = o.groundTruth;
  if (gtPath.empty()) gtPath = o.rawlog.parent_path() / (o.rawlog.stem().string() + "_groundtruth.txt");
  require(fs::is_regular_file(gtPath), gtPath.string(), "ground-truth file not found");
  // The outputs, prepared before the run: none may be an input or replace a folder; all are written or none.
  std::vector<fs::path> inputs = datasets::RawlogWriter::inputFilesOf(o.rawlog);
  for (const fs::path& p : {gtPath, o.config, o.referenceConfig}) inputs.push_back(p);
  OutputSet outputs(inputs);
  AtomicOutput* jsonOut = o.outputJson.empty() ? nullptr : &outputs.add(o.outputJson);
  AtomicOutput* plotOut = o.outputPlot.empty() ? nullptr : &outputs.add(o.outputPlot);
  AtomicOutput* textOut = o.outputText.empty() ? nullptr : &outputs.add(o.outputText);
  Trajectory gt = readTumTrajectory(gtPath);
  std::sort(gt.begin(), gt.end(), [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });

  datasets::RawlogReader frames(o.rawlog);
  Progress progress("manhattan-eval", datasets::RawlogReader::countFrames(o.rawlog), o.progress);
  ManhattanTracker tracker(params);
  StageTimings timings;
  priors::NormalErrorAccumulator accuracy;
  nlohmann::json perFrame = nlohmann::json::array();
  std::vector<double> errors, errorFrames, gtAngles;
  std::size_t nFrames = 0, nValid = 0, nWithGt = 0;
  struct Evaluated {
    std::size_t record;  // position in perFrame
    std::size_t frameIndex;
    Eigen::Matrix3d R_cam_mf, R_w_cam;
  };
  std::vector<Evaluated> evaluated;  // frames with a valid estimate and ground truth
  datasets::Frame frame;
  while (frames.next(frame)) {
    ++nFrames;
    priors::NormalMap nm;
    // A source's errors name the frame; the file is ours to add.
    const auto normalsOf = [&](priors::NormalSource& source) {
      try {
        return source.compute(frame);
      } catch (const Error& e) {
        throw Error(o.rawlog.string() + ": " + e.what());
      }
    };
    {
      ScopedStage s(timings, "normals_" + normalSource->kind());
      nm = normalsOf(*normalSource);
    }
    if (referenceSource) {
      const priors::NormalMap ref = normalsOf(*referenceSource);
      if (o.accuracyPixels == "reference-planar") {
        // Only where the reference finds a plane (depth: AHC-style segments; rawlog: every stored normal).
        cv::Mat planarRef(ref.normals.size(), CV_32FC3, cv::Scalar::all(0));
        ref.normals.copyTo(planarRef, ref.planarMask);
        accuracy.addMaps(nm.normals, planarRef);
      } else {
        accuracy.addMaps(nm.normals, ref.normals);
      }
    }
    // The tracker uses the planar pixels only (thesis §4.2).
    cv::Mat planarNormals(nm.normals.size(), CV_32FC3, cv::Scalar::all(0));
    nm.normals.copyTo(planarNormals, nm.planarMask);
    const auto normals = priors::collectNormals(planarNormals, o.normalStride);
    ManhattanEstimate est;
    {
      ScopedStage s(timings, "tracker");
      est = tracker.process(normals);
    }
    nlohmann::json rec = {{"index", frame.index}, {"timestamp", frame.timestamp}, {"normals", normals.size()}};
    rec["estimate"] = est.toJson();
    const Eigen::Quaterniond q_cam_mf(est.R_cam_mf);
    rec["q_cam_mf_xyzw"] = {q_cam_mf.x(), q_cam_mf.y(), q_cam_mf.z(), q_cam_mf.w()};
    const StampedPose* pose = nearestPose(gt, frame.timestamp, o.maxGroundTruthDt);
    if (pose) ++nWithGt;
    if (est.valid) ++nValid;
    if (est.valid && pose)
      evaluated.push_back({perFrame.size(), frame.index, est.R_cam_mf, pose->orientation.toRotationMatrix()});
    perFrame.push_back(rec);
    progress.update(nFrames, est.valid ? "ok" : est.reason);
  }
  progress.finish(std::to_string(nValid) + "/" + std::to_string(nFrames) + " frames accepted");
  require(nFrames > 0, o.rawlog.string(), "no frames");

  // Errors relative to the reference frame k (default: the first evaluated one):
  // R_ck_ci = R_ck_mf R_ci_mf^T (tracker) against R_w_ck^T R_w_ci (ground truth).
  const auto ref = std::find_if(evaluated.begin(), evaluated.end(),
                                [&](const Evaluated& e) { return e.frameIndex >= o.referenceFrame; });
  std::size_t referenceIndex = 0;
  if (ref != evaluated.end()) {
    referenceIndex = ref->frameIndex;
    for (const auto& e : evaluated) {
      const Eigen::Matrix3d estRel = ref->R_cam_mf * e.R_cam_mf.transpose();
      const Eigen::Matrix3d gtRel = ref->R_w_cam.transpose() * e.R_w_cam;
      const double err = rotationAngleDeg(estRel, gtRel);
      const double gtAngle = rotationAngleDeg(Eigen::Matrix3d::Identity(), gtRel);
      errors.push_back(err);
      errorFrames.push_back(static_cast<double>(e.frameIndex));
      gtAngles.push_back(gtAngle);
      perFrame[e.record]["rotation_error_deg"] = err;
      perFrame[e.record]["gt_rotation_from_reference_deg"] = gtAngle;
    }
  }
  // Between consecutive evaluated frames (a rotational RPE): independent of the reference frame's estimate.
  std::vector<double> stepErrors;
  for (std::size_t i = 1; i < evaluated.size(); ++i) {
    const auto &a = evaluated[i - 1], &b = evaluated[i];
    stepErrors.push_back(rotationAngleDeg(a.R_cam_mf * b.R_cam_mf.transpose(), a.R_w_cam.transpose() * b.R_w_cam));
  }

  nlohmann::json summary;
  summary["frames"] = nFrames;
  summary["frames_with_ground_truth"] = nWithGt;
  summary["accepted_frames"] = nValid;
  summary["success_share"] = static_cast<double>(nValid) / nFrames;
  summary["evaluated_frames"] = errors.size();
  summary["reference_frame"] = referenceIndex;
  const bool haveSteps = !stepErrors.empty();
  summary["step_error_median_deg"] = haveSteps ? median(stepErrors) : std::nan("");
  summary["step_error_max_deg"] = haveSteps ? *std::max_element(stepErrors.begin(), stepErrors.end()) : std::nan("");
  const bool haveErr = !errors.empty();
  summary["rotation_error_median_deg"] = haveErr ? median(errors) : std::nan("");
  summary["rotation_error_max_deg"] = haveErr ? *std::max_element(errors.begin(), errors.end()) : std::nan("");
  summary["rotation_error_mean_deg"] =
      haveErr ? std::accumulate(errors.begin(), errors.end(), 0.0) / errors.size() : std::nan("");
  summary["timings_ms"] = timings.summary();
  if (referenceSource) summary["normal_accuracy"] = accuracy.summary().toJson();

  nlohmann::json config;
  mrpt::config::CConfigFileMemory effective;
  params.saveToConfigFile(effective, kTrackerSection);
  config["tracker_ini"] = effective.getContent();
  config["input"] = o.rawlog.string();
  config["ground_truth"] = gtPath.string();
  config["normals"] = o.normals;
  config["reference_normals"] = o.referenceNormals;
  config["reference_config"] = (o.referenceConfig.empty() ? o.config : o.referenceConfig).string();
  config["normal_stride"] = o.normalStride;
  config["accuracy_pixels"] = o.accuracyPixels;

  ManhattanEvalResult r;
  r.report = {{"config", config}, {"summary", summary}, {"frames", perFrame}};
  std::ostringstream t;
  t << std::fixed << std::setprecision(2);
  t << "manhattan-eval: " << config["input"].get<std::string>() << " (normals: " << o.normals << ")\n";
  t << "  frames                     " << nFrames << " (" << nWithGt << " with ground truth)\n";
  t << "  accepted by the tracker    " << nValid << " (" << 100.0 * nValid / nFrames << " %)\n";
  if (haveErr) {
    t << "  rotation error vs GT [deg] median " << summary["rotation_error_median_deg"].get<double>() << "  max "
      << summary["rotation_error_max_deg"].get<double>() << "  mean " << summary["rotation_error_mean_deg"].get<double>()
      << "  (" << errors.size() << " frames, relative to frame " << referenceIndex << ")\n";
  }
  if (haveSteps) {
    t << "  step error [deg]           median " << summary["step_error_median_deg"].get<double>() << "  max "
      << summary["step_error_max_deg"].get<double>() << "  (between consecutive evaluated frames)\n";
  }
  for (const auto& [stage, s] : summary["timings_ms"].items())
    t << "  time " << std::left << std::setw(22) << stage << std::right << " median " << s["median_ms"].get<double>()
      << " ms  mean " << s["mean_ms"].get<double>() << " ms\n";
  if (referenceSource) {
    const auto a = accuracy.summary();
    t << "  normals " << o.normals << " vs " << o.referenceNormals << ": mean " << a.meanDeg << "  median "
      << a.medianDeg << "  rmse " << a.rmseDeg << " deg; <11.25 " << a.under11_25 << "  <22.5 " << a.under22_5
      << "  <30 " << a.under30 << "  (" << a.count << " px)\n";
  }
  r.text = t.str();
  if (jsonOut) writeOutputFile(*jsonOut, [&](std::ostream& os) { os << r.report.dump(2) << "\n"; });
  if (plotOut) {
    eval::Plot plot("Manhattan-frame rotation error vs ground truth (" + o.normals + " normals)", "frame",
                    "degrees");
    plot.addLine(errorFrames, errors, "rotation error (relative to frame " + std::to_string(referenceIndex) + ")", eval::colors::red());
    std::vector<double> scaled(gtAngles.size());
    for (std::size_t i = 0; i < gtAngles.size(); ++i) scaled[i] = gtAngles[i] / 10.0;
    plot.addLine(errorFrames, scaled, "GT rotation from that frame / 10", eval::colors::grey(), 1);
    double top = 1.0;
    for (double e : errors) top = std::max(top, e);
    for (double g : scaled) top = std::max(top, g);
    plot.setYRange(0.0, 1.1 * top);
    plot.save(plotOut->tempPath());
  }
  if (textOut) writeOutputFile(*textOut, [&](std::ostream& os) { os << r.text; });
  outputs.commit();
  return r;
}

}  // namespace pslam::manhattan
