#include "pslam/datasets/Dataset2RawlogApp.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Camera.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/datasets/Readers.h"

namespace fs = std::filesystem;

namespace pslam::datasets {

namespace {

ColorMode parseColor(const std::string& s) {
  if (s == "keep") return ColorMode::Keep;
  if (s == "grey" || s == "gray") return ColorMode::Grey;
  if (s == "colour" || s == "color") return ColorMode::Colour;
  throw Error("color: '" + s + "' is not keep, grey or colour");
}

}  // namespace

std::vector<double> parseNumberList(const std::string& text, const std::string& what) {
  std::string t = text;
  for (char& c : t)
    if (c == ',' || c == '[' || c == ']') c = ' ';
  std::istringstream ss(t);
  std::vector<double> out;
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) throw Error(what + ": '" + tok + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

// ------------------------------------------------------------------------------------------------ options
void Dataset2RawlogOptions::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& s) {
  // The rules only: input and out_dir may still come from the command line.
  params::load(*this, cfg, s);
}

void Dataset2RawlogOptions::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& s) const {
  params::save(*this, cfg, s);
}

void Dataset2RawlogOptions::check() const {
  params::check(*this, kSection);
  if (input.empty()) throw params::ParamError(kSection, "input", "", "no dataset folder given");
  if (outDir.empty()) throw params::ParamError(kSection, "out_dir", "", "no output folder given");
}

std::optional<std::string> Dataset2RawlogOptions::intrinsicsProblem(const std::vector<double>& k) const {
  if (k.empty()) return std::nullopt;
  if (k.size() != 4) return "expected 4 values fx,fy,cx,cy";
  if (!std::all_of(k.begin(), k.end(), [](double x) { return std::isfinite(x); })) return "values must be finite";
  if (!cameraIni.empty()) return "give either camera_ini or intrinsics, not both";
  return std::nullopt;
}

std::optional<std::string> Dataset2RawlogOptions::distortionProblem(const std::vector<double>& d) const {
  if (d.empty()) return std::nullopt;
  if (intrinsics.empty()) return "only valid together with intrinsics";
  if (d.size() > 5) return "at most 5 values k1,k2,p1,p2,k3";
  if (!std::all_of(d.begin(), d.end(), [](double x) { return std::isfinite(x); })) return "values must be finite";
  return std::nullopt;
}

// ------------------------------------------------------------------------------------------------ summary
std::string Dataset2RawlogSummary::line() const {
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%zu frames (%zu with depth), %zu GT poses -> %s in %.2f s (%.1f frames/s)",
                frames, depthFrames, groundTruthPoses, rawlogPath.string().c_str(), seconds, framesPerSecond());
  return buf;
}

// ------------------------------------------------------------------------------------------------ app
Dataset2RawlogApp::Dataset2RawlogApp(Dataset2RawlogOptions options) : opt_(std::move(options)) { opt_.check(); }

std::string Dataset2RawlogApp::defaultName(const DatasetIndex& index) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(index.root, ec);
  if (ec) p = index.root.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  if (index.format == "kitti") return "kitti_" + p.filename().string();
  if (p.filename() == "mav0") p = p.parent_path();
  return p.filename().string();
}

DatasetIndex Dataset2RawlogApp::buildIndex() const {
  const DatasetFormat format = opt_.format == "auto" ? detectFormat(opt_.input) : parseFormatName(opt_.format);

  CameraOverride cam;
  std::optional<double> iniRate;
  if (!opt_.cameraIni.empty()) {
    cam.camera = loadCameraIni(opt_.cameraIni, opt_.cameraSection);
    cam.source = opt_.cameraIni.string() + " [" + opt_.cameraSection + "]";
    iniRate = loadFrameRateFromIni(opt_.cameraIni, opt_.cameraSection);
  } else if (!opt_.intrinsics.empty()) {
    cam.intrinsics = opt_.intrinsics;
    cam.distortion = opt_.distortion;
    cam.source = "--intrinsics";
  }
  // Frame rate: the command line, else the camera ini's frame_rate_hz.
  double rate = opt_.rate;
  std::string rateSource = "--rate";
  if (rate <= 0 && iniRate) {
    rate = *iniRate;
    rateSource = opt_.cameraIni.string() + " frame_rate_hz";
  }

  DatasetIndex index;
  switch (format) {
    case DatasetFormat::Tum: {
      TumOptions o;
      o.override = cam;
      o.cameraName = opt_.tumCamera;
      o.maxDepthDiff = opt_.maxDepthDiff;
      o.useDepth = !opt_.noDepth;
      o.gtMaxGap = opt_.gtMaxGap;
      index = indexTumRgbd(opt_.input, o);
      break;
    }
    case DatasetFormat::IclNuim: {
      IclOptions o;
      o.override = cam;
      if (rate > 0) o.rate = rate;
      o.reflectPoses = !opt_.iclRawPoses;
      o.useDepth = !opt_.noDepth;
      o.posesFile = opt_.posesFile;
      index = indexIclNuim(opt_.input, o);
      break;
    }
    case DatasetFormat::Kitti: {
      KittiOptions o;
      o.override = cam;
      o.cameraIndex = opt_.kittiCamera;
      o.rate = rate;
      o.rateSource = rateSource;
      o.timesFile = opt_.timesFile;
      o.posesFile = opt_.posesFile;
      index = indexKitti(opt_.input, o);
      break;
    }
    case DatasetFormat::Euroc: {
      EurocOptions o;
      o.override = cam;
      o.cameraName = opt_.eurocCamera;
      o.gtMaxGap = opt_.gtMaxGap;
      index = indexEuroc(opt_.input, o);
      break;
    }
    case DatasetFormat::ImageFolder: {
      FolderOptions o;
      o.override = cam;
      o.rate = rate;
      o.firstStamp = opt_.firstStamp;
      o.posesFile = opt_.posesFile;
      index = indexImageFolder(opt_.input, o);
      break;
    }
  }
  std::size_t last = opt_.last;
  if (opt_.count > 0) {
    const std::size_t byCount = opt_.first + (opt_.count - 1) * opt_.stride;
    last = std::min(last, byCount);
  }
  selectFrames(index, opt_.first, last, opt_.stride);
  return index;
}

Dataset2RawlogSummary Dataset2RawlogApp::run() {
  const auto start = std::chrono::steady_clock::now();
  const DatasetIndex index = buildIndex();
  const ColorMode color = parseColor(opt_.color);
  const std::string name = opt_.name.empty() ? defaultName(index) : opt_.name;
  require(!name.empty(), "name", "cannot derive an output name from " + opt_.input.string() + "; pass --name");

  Dataset2RawlogSummary summary;
  summary.format = index.format;
  summary.rawlogPath = opt_.outDir / (name + ".rawlog");
  summary.assumptions = index.assumptions;
  const fs::path gtPath = opt_.outDir / (name + "_groundtruth.txt");

  // The outputs are prepared first (none may be an input or replace a folder), produced under temporary names
  // and moved into place together only after every frame converted.
  const Trajectory gt = groundTruthTrajectory(index);
  OutputSet outputs({opt_.input, opt_.cameraIni, opt_.posesFile, opt_.timesFile});
  RawlogWriter writer(summary.rawlogPath, opt_.imageFormat, &outputs);
  AtomicOutput* gtOut = gt.empty() ? nullptr : &outputs.add(gtPath);
  Progress progress("dataset2rawlog " + name, index.frames.size(), opt_.progress);
  for (std::size_t i = 0; i < index.frames.size(); ++i) {
    Frame frame;
    {
      ScopedStage stage(summary.timings, "read");
      frame = loadFrame(index, i, color);
    }
    {
      ScopedStage stage(summary.timings, "write");
      writer.write(frame);
    }
    summary.depthFrames += frame.hasDepth() ? 1 : 0;
    progress.update(i + 1);
  }
  summary.frames = writer.framesWritten();

  summary.groundTruthPoses = gt.size();
  if (gtOut)
    writeTumTrajectory(gtOut->tempPath(), gt,
                       "ground truth of " + name + ".rawlog (" + index.format + " " + index.root.string() +
                           "), stamps = CAMERA stamps");
  writer.commit();
  outputs.commit();
  if (gtOut) {
    summary.groundTruthPath = gtPath;
  } else {
    // A ground-truth file of an earlier run under this name would not belong to this rawlog. Only that kind of
    // file is removed: a regular file that is none of the inputs.
    std::error_code ec;
    bool isInput = false;
    for (const fs::path& in : {opt_.input, opt_.cameraIni, opt_.posesFile, opt_.timesFile})
      isInput = isInput || (!in.empty() && fs::equivalent(in, gtPath, ec));
    if (!isInput && fs::is_regular_file(fs::symlink_status(gtPath, ec)) && fs::remove(gtPath, ec))
      summary.assumptions.push_back("removed stale " + gtPath.string());
    summary.assumptions.push_back("no ground truth written");
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.finish();
  return summary;
}

}  // namespace pslam::datasets
