#include "pslam/datasets/Dataset2RawlogApp.h"

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

std::string joinNumbers(const std::vector<double>& v) {
  std::ostringstream ss;
  ss.precision(10);
  for (std::size_t k = 0; k < v.size(); ++k) ss << (k ? "," : "") << v[k];
  return ss.str();
}

std::size_t readSize(const mrpt::config::CConfigFileBase& cfg, const std::string& section, const std::string& key,
                     std::size_t def) {
  if (!cfg.keyExists(section, key)) return def;
  const std::string text = cfg.read_string(section, key, "");
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < 0)
    throw Error("[" + section + "] " + key + ": '" + text + "' is not a non-negative integer");
  return static_cast<std::size_t>(v);
}

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
  input = cfg.read_string(s, "input", input.string());
  outDir = cfg.read_string(s, "out_dir", outDir.string());
  name = cfg.read_string(s, "name", name);
  format = cfg.read_string(s, "format", format);
  first = readSize(cfg, s, "first", first);
  last = readSize(cfg, s, "last", last);
  count = readSize(cfg, s, "count", count);
  stride = readSize(cfg, s, "stride", stride);
  color = cfg.read_string(s, "color", color);
  imageFormat = cfg.read_string(s, "image_format", imageFormat);
  cameraIni = cfg.read_string(s, "camera_ini", cameraIni.string());
  cameraSection = cfg.read_string(s, "camera_section", cameraSection);
  if (cfg.keyExists(s, "intrinsics")) intrinsics = parseNumberList(cfg.read_string(s, "intrinsics", ""), "[" + s + "] intrinsics");
  if (cfg.keyExists(s, "distortion")) distortion = parseNumberList(cfg.read_string(s, "distortion", ""), "[" + s + "] distortion");
  tumCamera = cfg.read_string(s, "tum_camera", tumCamera);
  rate = cfg.read_double(s, "rate", rate);
  firstStamp = cfg.read_double(s, "first_stamp", firstStamp);
  maxDepthDiff = cfg.read_double(s, "max_depth_diff", maxDepthDiff);
  gtMaxGap = cfg.read_double(s, "gt_max_gap", gtMaxGap);
  noDepth = cfg.read_bool(s, "no_depth", noDepth);
  kittiCamera = cfg.read_int(s, "kitti_camera", kittiCamera);
  eurocCamera = cfg.read_string(s, "euroc_camera", eurocCamera);
  posesFile = cfg.read_string(s, "poses", posesFile.string());
  timesFile = cfg.read_string(s, "times", timesFile.string());
  iclRawPoses = cfg.read_bool(s, "icl_raw_poses", iclRawPoses);
  progress = cfg.read_bool(s, "progress", progress);
}

void Dataset2RawlogOptions::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& s) const {
  cfg.write(s, "input", input.string());
  cfg.write(s, "out_dir", outDir.string());
  cfg.write(s, "name", name);
  cfg.write(s, "format", format);
  cfg.write(s, "first", static_cast<uint64_t>(first));
  if (last != std::numeric_limits<std::size_t>::max()) cfg.write(s, "last", static_cast<uint64_t>(last));
  cfg.write(s, "count", static_cast<uint64_t>(count));
  cfg.write(s, "stride", static_cast<uint64_t>(stride));
  cfg.write(s, "color", color);
  cfg.write(s, "image_format", imageFormat);
  cfg.write(s, "camera_ini", cameraIni.string());
  cfg.write(s, "camera_section", cameraSection);
  cfg.write(s, "intrinsics", joinNumbers(intrinsics));
  cfg.write(s, "distortion", joinNumbers(distortion));
  cfg.write(s, "tum_camera", tumCamera);
  cfg.write(s, "rate", rate);
  cfg.write(s, "first_stamp", firstStamp);
  cfg.write(s, "max_depth_diff", maxDepthDiff);
  cfg.write(s, "gt_max_gap", gtMaxGap);
  cfg.write(s, "no_depth", noDepth);
  cfg.write(s, "kitti_camera", kittiCamera);
  cfg.write(s, "euroc_camera", eurocCamera);
  cfg.write(s, "poses", posesFile.string());
  cfg.write(s, "times", timesFile.string());
  cfg.write(s, "icl_raw_poses", iclRawPoses);
  cfg.write(s, "progress", progress);
}

void Dataset2RawlogOptions::check() const {
  require(!input.empty(), "input", "no dataset folder given");
  require(!outDir.empty(), "out_dir", "no output folder given");
  if (format != "auto") parseFormatName(format);
  require(stride >= 1, "stride", "must be at least 1");
  require(last >= first, "last", "must not be before first");
  parseColor(color);
  require(imageFormat == "png" || imageFormat == "bmp" || imageFormat == "tiff" || imageFormat == "ppm" ||
              imageFormat == "pgm",
          "image_format", "'" + imageFormat + "' is not a lossless format (png, bmp, tiff, ppm, pgm)");
  require(intrinsics.empty() || intrinsics.size() == 4, "intrinsics", "expected 4 values fx,fy,cx,cy");
  require(distortion.empty() || !intrinsics.empty(), "distortion", "only valid together with intrinsics");
  require(distortion.size() <= 5, "distortion", "at most 5 values k1,k2,p1,p2,k3");
  require(intrinsics.empty() || cameraIni.empty(), "intrinsics", "give either camera_ini or intrinsics, not both");
  require(tumCamera.empty() || tumCamera == "fr1" || tumCamera == "fr2" || tumCamera == "fr3", "tum_camera",
          "'" + tumCamera + "' is not fr1, fr2 or fr3");
  require(std::isfinite(rate) && rate >= 0, "rate", "must be a non-negative frame rate in Hz");
  require(std::isfinite(firstStamp), "first_stamp", "must be finite");
  require(std::isfinite(maxDepthDiff) && maxDepthDiff > 0, "max_depth_diff", "must be positive (seconds)");
  require(std::isfinite(gtMaxGap) && gtMaxGap >= 0, "gt_max_gap", "must be >= 0 (seconds, 0 = no limit)");
  require(kittiCamera == -1 || kittiCamera == 0 || kittiCamera == 2, "kitti_camera", "must be 0, 2 or -1 (auto)");
  require(name.find('/') == std::string::npos, "name", "must be a base name, not a path");
  require(eurocCamera == "cam0" || eurocCamera == "cam1", "euroc_camera", "must be cam0 or cam1");
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
