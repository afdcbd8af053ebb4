#include "pslam/datasets/Readers.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <tuple>

#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "TextTable.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Camera.h"

namespace fs = std::filesystem;

namespace pslam::datasets {

using detail::parseInteger;
using detail::parseNumber;
using detail::readTextTable;
using detail::requireFields;
using detail::TextRow;
using detail::where;

namespace {

constexpr double kTumDepthUnits = 1.0 / 5000.0;  // TUM RGB-D and ICL-NUIM: 5000 units = 1 m

std::string formatDouble(double v, int precision = 10) {
  std::ostringstream ss;
  ss.precision(precision);
  ss << v;
  return ss.str();
}

/// The name of a folder even when given as "a/b/" or ".".
std::string folderName(const fs::path& root) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(root, ec);
  if (ec) p = root.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

void requireFolder(const fs::path& root) {
  std::error_code ec;
  if (!fs::exists(root, ec)) throw Error(root.string() + ": dataset folder not found");
  if (!fs::is_directory(root, ec)) throw Error(root.string() + ": not a folder");
}

cv::Size imageSizeOf(const fs::path& image) {
  const cv::Mat m = cv::imread(image.string(), cv::IMREAD_UNCHANGED);
  if (m.empty()) throw Error(image.string() + ": cannot read image (missing, empty or not an image)");
  return m.size();
}

/// The override camera, with its resolution taken from `firstImage` when only intrinsics were given.
std::optional<mrpt::img::TCamera> resolveOverride(const CameraOverride& o, const fs::path& firstImage) {
  if (o.camera) return o.camera;
  if (o.intrinsics.empty()) return std::nullopt;
  require(o.intrinsics.size() == 4, "intrinsics", "expected 4 values fx,fy,cx,cy");
  const cv::Size size = imageSizeOf(firstImage);
  return makePinholeCamera(static_cast<uint32_t>(size.width), static_cast<uint32_t>(size.height), o.intrinsics[0],
                           o.intrinsics[1], o.intrinsics[2], o.intrinsics[3], o.distortion);
}

std::string describeCamera(const mrpt::img::TCamera& c) {
  std::string s = std::to_string(c.ncols) + "x" + std::to_string(c.nrows) + " fx=" + formatDouble(c.fx()) +
                  " fy=" + formatDouble(c.fy()) + " cx=" + formatDouble(c.cx()) + " cy=" + formatDouble(c.cy());
  if (c.distortion != mrpt::img::DistortionModel::none) {
    s += " dist=[";
    for (int k = 0; k < 5; ++k) s += (k ? " " : "") + formatDouble(c.dist[k]);
    s += "]";
  }
  return s;
}

/// Every listed file must exist before anything is written (a late failure would waste a long run).
void requireFilesExist(const DatasetIndex& idx) {
  std::error_code ec;
  for (std::size_t i = 0; i < idx.frames.size(); ++i) {
    const auto& e = idx.frames[i];
    if (!fs::is_regular_file(e.image, ec))
      throw Error(e.image.string() + ": image file not found (frame " + std::to_string(i) + ")");
    if (!e.depth.empty() && !fs::is_regular_file(e.depth, ec))
      throw Error(e.depth.string() + ": depth file not found (frame " + std::to_string(i) + ")");
  }
}

/// A TUM trajectory file with stamps quantized like the camera stamps and checked for order.
Trajectory readGroundTruth(const fs::path& file) {
  Trajectory gt = readTumTrajectory(file);
  for (auto& p : gt) p.timestamp = quantizeStamp(p.timestamp);
  requireSortedStamps(gt, file.string());
  return gt;
}

struct StampedFile {
  double stamp;
  fs::path file;
  int line;
};

/// "timestamp filename" lists of TUM RGB-D (rgb.txt, depth.txt); stamps must increase.
std::vector<StampedFile> readTumList(const fs::path& root, const std::string& name) {
  const fs::path file = root / name;
  std::vector<StampedFile> out;
  for (const TextRow& row : readTextTable(file, false)) {
    requireFields(row, 2, file, "'timestamp filename'");
    const double t = quantizeStamp(parseNumber(row.fields[0], file, row.line, "timestamp"));
    if (!out.empty() && !(t > out.back().stamp))
      throw Error(where(file, row.line) + ": timestamp " + row.fields[0] + " is not after the previous one");
    out.push_back({t, root / row.fields[1], row.line});
  }
  return out;
}

/// TUM's associate.py rule: every (rgb, depth) pair closer than maxDiff is a candidate; candidates are
/// taken in order of increasing time difference, each rgb and each depth stamp used at most once.
std::vector<std::ptrdiff_t> associateDepth(const std::vector<StampedFile>& rgb, const std::vector<StampedFile>& depth,
                                           double maxDiff) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
  for (std::size_t a = 0; a < rgb.size(); ++a) {
    const auto lo = std::lower_bound(depth.begin(), depth.end(), rgb[a].stamp - maxDiff,
                                     [](const StampedFile& d, double v) { return d.stamp < v; });
    for (auto it = lo; it != depth.end() && it->stamp < rgb[a].stamp + maxDiff; ++it) {
      const double diff = std::abs(rgb[a].stamp - it->stamp);
      if (diff < maxDiff) candidates.emplace_back(diff, a, static_cast<std::size_t>(it - depth.begin()));
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<std::ptrdiff_t> match(rgb.size(), -1);
  std::vector<bool> depthUsed(depth.size(), false);
  for (const auto& [diff, a, b] : candidates) {
    if (match[a] >= 0 || depthUsed[b]) continue;
    match[a] = static_cast<std::ptrdiff_t>(b);
    depthUsed[b] = true;
  }
  return match;
}

Eigen::Isometry3d isometryFromRowMajor3x4(const double* v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.matrix()(r, c) = v[4 * r + c];
    T.matrix()(r, 3) = v[4 * r + 3];
  }
  return T;
}

/// Rotation part re-orthonormalized (KITTI / EuRoC matrices carry 6-7 significant digits).
Eigen::Isometry3d orthonormalized(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return out;
}

void fillGroundTruth(DatasetIndex& idx, const Trajectory& gt, double maxGap) {
  for (auto& e : idx.frames) e.T_world_cam = interpolatePose(gt, e.timestamp, maxGap);
  idx.groundTruthSamples = gt.size();
  std::size_t missing = 0;
  for (const auto& e : idx.frames) missing += e.T_world_cam ? 0 : 1;
  if (missing > 0)
    idx.assumptions.push_back(std::to_string(missing) +
                              " frame(s) outside the ground-truth time span (or in a hole) get no ground-truth pose");
}

}  // namespace

// ------------------------------------------------------------------------------------------------ formats
std::string formatName(DatasetFormat f) {
  switch (f) {
    case DatasetFormat::Tum: return "tum";
    case DatasetFormat::IclNuim: return "icl";
    case DatasetFormat::Kitti: return "kitti";
    case DatasetFormat::Euroc: return "euroc";
    case DatasetFormat::ImageFolder: return "folder";
  }
  return "?";
}

DatasetFormat parseFormatName(const std::string& name) {
  for (auto f : {DatasetFormat::Tum, DatasetFormat::IclNuim, DatasetFormat::Kitti, DatasetFormat::Euroc,
                 DatasetFormat::ImageFolder})
    if (formatName(f) == name) return f;
  throw Error("unknown dataset format '" + name + "' (use auto, tum, icl, kitti, euroc or folder)");
}

namespace {
std::vector<fs::path> filesWithSuffix(const fs::path& dir, const std::string& suffix) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    if (e.is_regular_file() && n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0)
      out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}
}  // namespace

DatasetFormat detectFormat(const fs::path& root) {
  requireFolder(root);
  std::error_code ec;
  // ICL-NUIM's TUM-compatible release names its poses <name>.gt.freiburg (frame ids, not times), beside an
  // associations.txt or, without depth, an rgb.txt: that file decides between ICL-NUIM and TUM RGB-D.
  const bool iclPoses = !filesWithSuffix(root, ".gt.freiburg").empty();
  if (iclPoses && (fs::is_regular_file(root / "associations.txt", ec) || fs::is_regular_file(root / "rgb.txt", ec)))
    return DatasetFormat::IclNuim;
  if (fs::is_regular_file(root / "rgb.txt", ec)) return DatasetFormat::Tum;
  if (fs::is_directory(root / "image_0", ec) || fs::is_directory(root / "image_2", ec)) return DatasetFormat::Kitti;
  if (fs::is_regular_file(root / "mav0" / "cam0" / "data.csv", ec) || fs::is_regular_file(root / "cam0" / "data.csv", ec))
    return DatasetFormat::Euroc;
  if (!detail::listImages(root).empty()) return DatasetFormat::ImageFolder;
  throw Error(root.string() +
              ": unknown dataset format (no rgb.txt, associations.txt + *.gt.freiburg, image_0/, image_2/, "
              "cam0/data.csv or image files); pass --format");
}

// ------------------------------------------------------------------------------------------------ TUM RGB-D
DatasetIndex indexTumRgbd(const fs::path& root, const TumOptions& opt) {
  requireFolder(root);
  require(opt.maxDepthDiff > 0 && std::isfinite(opt.maxDepthDiff), "max_depth_diff", "must be positive");
  DatasetIndex idx;
  idx.format = "tum";
  idx.root = root;
  idx.depthUnits = kTumDepthUnits;

  const auto rgb = readTumList(root, "rgb.txt");
  if (rgb.empty()) throw Error((root / "rgb.txt").string() + ": empty dataset (no image listed)");

  if (auto cam = resolveOverride(opt.override, rgb.front().file)) {
    idx.camera = *cam;
    idx.assumptions.push_back("camera from " + opt.override.source + ": " + describeCamera(idx.camera));
  } else {
    std::string name = opt.cameraName;
    std::string why = "given";
    if (name.empty()) {
      const auto guessed = tumCameraFromFolderName(folderName(root));
      if (!guessed)
        throw Error(root.string() +
                    ": cannot tell the TUM camera (fr1/fr2/fr3) from the folder name; pass --tum-camera or "
                    "--camera-ini");
      name = *guessed;
      why = "from the folder name";
    }
    idx.camera = tumCamera(name);
    idx.assumptions.push_back("camera: TUM " + name + " published calibration (" + why + ")");
  }

  std::vector<std::ptrdiff_t> depthOf(rgb.size(), -1);
  std::vector<StampedFile> depth;
  std::error_code ec;
  if (opt.useDepth) {
    if (fs::is_regular_file(root / "depth.txt", ec)) {
      depth = readTumList(root, "depth.txt");
      depthOf = associateDepth(rgb, depth, opt.maxDepthDiff);
      const auto unmatched = std::count(depthOf.begin(), depthOf.end(), -1);
      if (unmatched > 0)
        idx.assumptions.push_back(std::to_string(unmatched) + " RGB frame(s) without a depth image within " +
                                  formatDouble(opt.maxDepthDiff) + " s are kept without DEPTH");
    } else {
      idx.assumptions.push_back("no depth.txt: frames have no DEPTH");
    }
  }
  for (std::size_t a = 0; a < rgb.size(); ++a) {
    FrameEntry e;
    e.timestamp = rgb[a].stamp;
    e.image = rgb[a].file;
    if (depthOf[a] >= 0) e.depth = depth[static_cast<std::size_t>(depthOf[a])].file;
    idx.frames.push_back(std::move(e));
  }

  const fs::path gtFile = root / "groundtruth.txt";
  if (fs::is_regular_file(gtFile, ec)) {
    fillGroundTruth(idx, readGroundTruth(gtFile), opt.gtMaxGap);
  } else {
    idx.assumptions.push_back("no groundtruth.txt: no ground truth");
  }
  requireFilesExist(idx);
  return idx;
}

// ------------------------------------------------------------------------------------------------ ICL-NUIM
DatasetIndex indexIclNuim(const fs::path& root, const IclOptions& opt) {
  requireFolder(root);
  require(opt.rate > 0 && std::isfinite(opt.rate), "rate", "must be positive");
  DatasetIndex idx;
  idx.format = "icl";
  idx.root = root;
  idx.depthUnits = kTumDepthUnits;

  // The frame list: associations.txt ("id depth/id.png id rgb/id.png", or rgb first as associate.py writes it), or,
  // for a folder without depth, rgb.txt ("id rgb/id.png").
  const bool withAssociations = fs::exists(root / "associations.txt");
  const fs::path assocFile = root / (withAssociations || !fs::exists(root / "rgb.txt") ? "associations.txt" : "rgb.txt");
  struct Row {
    long long id;
    fs::path rgb, depth;
  };
  std::vector<Row> rows;
  for (const TextRow& row : readTextTable(assocFile, false)) {
    std::string idField, rgbField, depthField;
    if (withAssociations) {
      requireFields(row, 4, assocFile, "'id depth/<id>.png id rgb/<id>.png'");
      const bool depthFirst = row.fields[1].find("depth") != std::string::npos;
      rgbField = depthFirst ? row.fields[3] : row.fields[1];
      depthField = depthFirst ? row.fields[1] : row.fields[3];
      idField = depthFirst ? row.fields[2] : row.fields[0];
    } else {
      requireFields(row, 2, assocFile, "'id rgb/<id>.png'");
      idField = row.fields[0];
      rgbField = row.fields[1];
    }
    const double idValue = parseNumber(idField, assocFile, row.line, "frame id");
    if (idValue < 0 || idValue != std::floor(idValue))
      throw Error(where(assocFile, row.line) + ": frame id '" + idField + "' is not a non-negative integer");
    const long long id = static_cast<long long>(idValue);
    if (!rows.empty() && id <= rows.back().id)
      throw Error(where(assocFile, row.line) + ": frame id " + idField + " is not after the previous one");
    rows.push_back({id, root / rgbField, depthField.empty() ? fs::path() : root / depthField});
  }
  if (rows.empty()) throw Error(assocFile.string() + ": empty dataset (no frame listed)");

  if (auto cam = resolveOverride(opt.override, rows.front().rgb)) {
    idx.camera = *cam;
    idx.assumptions.push_back("camera from " + opt.override.source + ": " + describeCamera(idx.camera));
  } else {
    idx.camera = iclNuimCamera();
    idx.assumptions.push_back("camera: ICL-NUIM 481.20 480.00 319.50 239.50 (fy positive for the TUM-compatible PNGs)");
  }
  idx.assumptions.push_back("timestamps = frame id / " + formatDouble(opt.rate) + " Hz (ICL-NUIM has frame ids only)");

  for (const Row& r : rows) {
    FrameEntry e;
    e.timestamp = quantizeStamp(static_cast<double>(r.id) / opt.rate);
    e.image = r.rgb;
    if (opt.useDepth) e.depth = r.depth;
    idx.frames.push_back(std::move(e));
  }
  if (!withAssociations) idx.assumptions.push_back("frames from " + assocFile.filename().string() + ": no depth images");

  // The poses: --poses, else the release's single <name>.gt.freiburg, else a groundtruth.txt of frame ids (a TUM
  // file whose first column is the id, as some copies of the release name it).
  fs::path gtFile = opt.posesFile;
  if (gtFile.empty()) {
    const auto candidates = filesWithSuffix(root, ".gt.freiburg");
    if (candidates.size() > 1)
      throw Error(root.string() + ": several *.gt.freiburg files; pass --poses to choose one");
    if (!candidates.empty())
      gtFile = candidates.front();
    else if (fs::is_regular_file(root / "groundtruth.txt"))
      gtFile = root / "groundtruth.txt";
  }
  if (gtFile.empty()) {
    idx.assumptions.push_back("no *.gt.freiburg or groundtruth.txt: no ground truth");
  } else {
    // The first column of <name>.gt.freiburg is the frame id of associations.txt; match ids exactly.
    const Trajectory gt = readTumTrajectory(gtFile);
    std::map<long long, Eigen::Isometry3d> byId;
    for (const auto& p : gt) {
      const double id = std::round(p.timestamp);
      if (std::abs(p.timestamp - id) > 1e-6)
        throw Error(gtFile.string() + ": first column " + formatDouble(p.timestamp, 12) +
                    " is not a frame id (expected an integer)");
      byId[static_cast<long long>(id)] = p.T_world_cam();
    }
    // The poses live in the renderer's y-up world while the PNGs are stored top-down (the dataset page's
    // fy = -480 belongs to the POV-Ray native format). Reflecting the poses about the XZ plane,
    // T' = S T S with S = diag(1,-1,1), gives a proper right-handed camera (x right, y down, z forward).
    Eigen::Isometry3d S = Eigen::Isometry3d::Identity();
    S.linear() = Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal();
    std::size_t missing = 0;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const auto it = byId.find(rows[i].id);
      if (it == byId.end()) {
        ++missing;
        continue;
      }
      idx.frames[i].T_world_cam = opt.reflectPoses ? orthonormalized(S * it->second * S) : it->second;
    }
    idx.groundTruthSamples = gt.size();
    if (missing > 0)
      idx.assumptions.push_back(std::to_string(missing) + " frame id(s) without a pose in " +
                                gtFile.filename().string() + " get no ground truth");
    idx.assumptions.push_back("poses from " + gtFile.filename().string() + ", matched by frame id");
    idx.assumptions.push_back(opt.reflectPoses ? "ICL-NUIM pose convention: poses reflected about the XZ plane (S T S, "
                                                 "S = diag(1,-1,1)) for the top-down images; --icl-raw-poses keeps them"
                                               : "poses kept as published (y-up renderer frame, --icl-raw-poses)");
  }
  if (!opt.useDepth) idx.assumptions.push_back("depth not converted (--no-depth)");
  requireFilesExist(idx);
  return idx;
}

// ------------------------------------------------------------------------------------------------ KITTI
DatasetIndex indexKitti(const fs::path& root, const KittiOptions& opt) {
  requireFolder(root);
  DatasetIndex idx;
  idx.format = "kitti";
  idx.root = root;
  std::error_code ec;

  int camIndex = opt.cameraIndex;
  if (camIndex < 0) camIndex = fs::is_directory(root / "image_0", ec) ? 0 : 2;
  require(camIndex == 0 || camIndex == 2, "kitti_camera", "must be 0 (image_0, grey) or 2 (image_2, colour)");
  const fs::path imageDir = root / ("image_" + std::to_string(camIndex));
  const auto images = detail::listImages(imageDir);
  if (images.empty()) throw Error(imageDir.string() + ": empty dataset (no images)");
  // KITTI names frames 000000.png, 000001.png, ...: frame i is line i of times.txt and of the poses file.
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::string stem = images[i].stem().string();
    char* end = nullptr;
    const long long n = std::strtoll(stem.c_str(), &end, 10);
    if (stem.empty() || *end != '\0' || n != static_cast<long long>(i))
      throw Error(images[i].string() + ": expected frame number " + std::to_string(i) +
                  " (KITTI images must be numbered contiguously from 000000)");
  }

  // Intrinsics: calib.txt (P<k> = K [I | t_k], rectified), else the override.
  const fs::path calibFile = root / "calib.txt";
  Eigen::Vector3d t_camk_cam0 = Eigen::Vector3d::Zero();
  bool haveCalib = false;
  mrpt::img::TCamera calibCamera;
  if (fs::is_regular_file(calibFile, ec)) {
    const std::string key = "P" + std::to_string(camIndex) + ":";
    for (const TextRow& row : readTextTable(calibFile, false)) {
      if (row.fields.empty() || row.fields[0] != key) continue;
      requireFields(row, 13, calibFile, "'" + key + " followed by 12 numbers'");
      double P[12];
      for (int k = 0; k < 12; ++k) P[k] = parseNumber(row.fields[k + 1], calibFile, row.line, "calibration value");
      const cv::Size size = imageSizeOf(images.front());
      calibCamera = makePinholeCamera(static_cast<uint32_t>(size.width), static_cast<uint32_t>(size.height), P[0],
                                      P[5], P[2], P[6]);
      Eigen::Matrix3d K;
      K << P[0], P[1], P[2], P[4], P[5], P[6], P[8], P[9], P[10];
      t_camk_cam0 = K.inverse() * Eigen::Vector3d(P[3], P[7], P[11]);
      haveCalib = true;
    }
    if (!haveCalib) throw Error(calibFile.string() + ": no line '" + key + "'");
  }
  if (auto cam = resolveOverride(opt.override, images.front())) {
    idx.camera = *cam;
    idx.assumptions.push_back(std::string(haveCalib ? "calib.txt overridden" : "calib.txt missing") +
                              ": camera from " + opt.override.source + ": " + describeCamera(idx.camera));
  } else if (haveCalib) {
    idx.camera = calibCamera;
  } else {
    throw Error(calibFile.string() +
                ": not found; pass the intrinsics with --camera-ini (e.g. config/cameras/kitti_00-02.ini) or "
                "--intrinsics fx,fy,cx,cy");
  }
  // The poses are those of cam0; camera k sits at T_cam0_camk = [I | -t_k] on the rig (rectified images).
  Eigen::Isometry3d T_cam0_camk = Eigen::Isometry3d::Identity();
  T_cam0_camk.translation() = -t_camk_cam0;
  if (camIndex != 0 && !haveCalib)
    idx.assumptions.push_back("image_2 without calib.txt: camera assumed at the cam0 pose (the ~6 cm offset is unknown)");
  {
    mrpt::math::CMatrixDouble44 M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = T_cam0_camk.matrix()(r, c);
    idx.sensorPoseOnBody = mrpt::poses::CPose3D(M);
  }

  // Timestamps.
  const fs::path timesFile = opt.timesFile.empty() ? root / "times.txt" : opt.timesFile;
  std::vector<double> stamps;
  if (fs::is_regular_file(timesFile, ec)) {
    for (const TextRow& row : readTextTable(timesFile, false)) {
      requireFields(row, 1, timesFile, "one timestamp per line");
      if (row.fields.size() != 1)
        throw Error(where(timesFile, row.line) + ": malformed line: expected one timestamp");
      stamps.push_back(quantizeStamp(parseNumber(row.fields[0], timesFile, row.line, "timestamp")));
      if (stamps.size() > 1 && !(stamps.back() > stamps[stamps.size() - 2]))
        throw Error(where(timesFile, row.line) + ": timestamp is not after the previous one");
    }
    if (stamps.size() < images.size())
      throw Error(timesFile.string() + ": mismatched counts: " + std::to_string(stamps.size()) + " timestamps for " +
                  std::to_string(images.size()) + " images in " + imageDir.string());
    if (stamps.size() > images.size())
      idx.assumptions.push_back(timesFile.filename().string() + " has " + std::to_string(stamps.size()) +
                                " stamps for " + std::to_string(images.size()) + " images: using the first " +
                                std::to_string(images.size()));
  } else if (!opt.timesFile.empty()) {
    throw Error(timesFile.string() + ": times file not found");
  } else {
    if (!(opt.rate > 0 && std::isfinite(opt.rate)))
      throw Error(timesFile.string() + ": not found; pass a nominal frame rate with --rate (KITTI records at about "
                                       "10 Hz) or put frame_rate_hz in the camera ini file");
    for (std::size_t i = 0; i < images.size(); ++i) stamps.push_back(quantizeStamp(static_cast<double>(i) / opt.rate));
    idx.assumptions.push_back("times.txt missing: timestamps = i / " + formatDouble(opt.rate) + " Hz (rate from " +
                              (opt.rateSource.empty() ? std::string("--rate") : opt.rateSource) + ")");
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    FrameEntry e;
    e.timestamp = stamps[i];
    e.image = images[i];
    idx.frames.push_back(std::move(e));
  }

  // Ground truth: poses/<seq>.txt, 12 numbers per line, row-major 3x4 T_world_cam0.
  const std::string seq = folderName(root);
  const fs::path posesFile = opt.posesFile.empty() ? root / ".." / ".." / "poses" / (seq + ".txt") : opt.posesFile;
  if (fs::is_regular_file(posesFile, ec)) {
    std::vector<Eigen::Isometry3d> poses;
    for (const TextRow& row : readTextTable(posesFile, false)) {
      if (row.fields.size() != 12)
        throw Error(where(posesFile, row.line) + ": malformed line: expected 12 numbers (3x4 row-major pose), found " +
                    std::to_string(row.fields.size()));
      double v[12];
      for (int k = 0; k < 12; ++k) v[k] = parseNumber(row.fields[k], posesFile, row.line, "pose value");
      poses.push_back(orthonormalized(isometryFromRowMajor3x4(v)));
    }
    if (poses.size() < images.size())
      throw Error(posesFile.string() + ": mismatched counts: " + std::to_string(poses.size()) + " poses for " +
                  std::to_string(images.size()) + " images in " + imageDir.string());
    if (poses.size() > images.size())
      idx.assumptions.push_back(posesFile.filename().string() + " has " + std::to_string(poses.size()) +
                                " poses for " + std::to_string(images.size()) + " images: using the first " +
                                std::to_string(images.size()));
    for (std::size_t i = 0; i < images.size(); ++i) idx.frames[i].T_world_cam = poses[i] * T_cam0_camk;
    idx.groundTruthSamples = poses.size();
  } else if (!opt.posesFile.empty()) {
    throw Error(posesFile.string() + ": poses file not found");
  } else {
    idx.assumptions.push_back("no ground truth (" + posesFile.lexically_normal().string() + " not found)");
  }
  requireFilesExist(idx);
  return idx;
}

// ------------------------------------------------------------------------------------------------ EuRoC
namespace {

std::vector<double> yamlNumbers(const cv::FileNode& node, const fs::path& file, const std::string& key) {
  std::vector<double> out;
  if (node.empty() || !node.isSeq()) throw Error(file.string() + ": key '" + key + "' missing or not a list");
  for (const auto& item : node) {
    if (!item.isReal() && !item.isInt()) throw Error(file.string() + ": key '" + key + "' holds a non-number");
    const double v = static_cast<double>(item);
    if (!std::isfinite(v)) throw Error(file.string() + ": key '" + key + "' holds NaN or Inf");
    out.push_back(v);
  }
  return out;
}

}  // namespace

DatasetIndex indexEuroc(const fs::path& root, const EurocOptions& opt) {
  requireFolder(root);
  std::error_code ec;
  const fs::path mav = fs::is_directory(root / "mav0", ec) ? root / "mav0" : root;
  const fs::path camDir = mav / opt.cameraName;
  DatasetIndex idx;
  idx.format = "euroc";
  idx.root = root;

  // Images: data.csv "#timestamp [ns],filename", files in data/.
  const fs::path csv = camDir / "data.csv";
  for (const TextRow& row : readTextTable(csv, true)) {
    requireFields(row, 2, csv, "'timestamp_ns,filename'");
    const long long ns = parseInteger(row.fields[0], csv, row.line, "timestamp [ns]");
    FrameEntry e;
    // Whole microseconds via integers (a double of the ns count would lose the last digits first).
    e.timestamp = quantizeStamp(static_cast<double>((ns + 500) / 1000) / 1e6);
    if (!idx.frames.empty() && !(e.timestamp > idx.frames.back().timestamp))
      throw Error(where(csv, row.line) + ": timestamp is not after the previous one");
    e.image = camDir / "data" / row.fields[1];
    idx.frames.push_back(std::move(e));
  }
  if (idx.frames.empty()) throw Error(csv.string() + ": empty dataset (no image listed)");
  idx.assumptions.push_back("EuRoC ns timestamps rounded to whole microseconds");

  // sensor.yaml: intrinsics [fu fv cu cv], resolution [w h], radial-tangential distortion, T_BS (4x4).
  const fs::path yaml = camDir / "sensor.yaml";
  if (!fs::is_regular_file(yaml, ec)) throw Error(yaml.string() + ": file not found");
  cv::FileStorage fsYaml;
  try {
    fsYaml.open(yaml.string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw Error(yaml.string() + ": cannot parse YAML (" + e.msg + ")");
  }
  if (!fsYaml.isOpened()) throw Error(yaml.string() + ": cannot parse YAML");
  const auto tbs = yamlNumbers(fsYaml["T_BS"]["data"], yaml, "T_BS.data");
  if (tbs.size() != 16) throw Error(yaml.string() + ": T_BS.data must hold 16 numbers");
  Eigen::Isometry3d T_body_cam = orthonormalized(isometryFromRowMajor3x4(tbs.data()));
  {
    mrpt::math::CMatrixDouble44 M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = T_body_cam.matrix()(r, c);
    idx.sensorPoseOnBody = mrpt::poses::CPose3D(M);
  }
  if (auto cam = resolveOverride(opt.override, idx.frames.front().image)) {
    idx.camera = *cam;
    idx.assumptions.push_back("camera from " + opt.override.source + ": " + describeCamera(idx.camera));
  } else {
    const auto intr = yamlNumbers(fsYaml["intrinsics"], yaml, "intrinsics");
    const auto res = yamlNumbers(fsYaml["resolution"], yaml, "resolution");
    if (intr.size() != 4) throw Error(yaml.string() + ": intrinsics must hold 4 numbers (fu fv cu cv)");
    if (res.size() != 2 || res[0] < 1 || res[1] < 1) throw Error(yaml.string() + ": resolution must be [width height]");
    std::string model;
    fsYaml["distortion_model"] >> model;
    std::vector<double> dist;
    if (model == "radial-tangential" || model == "radtan" || model == "plumb_bob") {
      dist = yamlNumbers(fsYaml["distortion_coefficients"], yaml, "distortion_coefficients");
      if (dist.size() < 4 || dist.size() > 5)
        throw Error(yaml.string() + ": distortion_coefficients must hold 4 or 5 numbers (k1 k2 p1 p2 [k3])");
    } else if (!model.empty() && model != "none") {
      throw Error(yaml.string() + ": distortion_model '" + model + "' is not supported (radial-tangential only)");
    }
    idx.camera = makePinholeCamera(static_cast<uint32_t>(res[0]), static_cast<uint32_t>(res[1]), intr[0], intr[1],
                                   intr[2], intr[3], dist);
  }

  // Ground truth: BODY poses "ts_ns, p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...", interpolated at the camera
  // stamps, then moved to the camera: T_world_cam = T_world_body * T_BS.
  const fs::path gtCsv = mav / "state_groundtruth_estimate0" / "data.csv";
  if (fs::is_regular_file(gtCsv, ec)) {
    Trajectory body;
    for (const TextRow& row : readTextTable(gtCsv, true)) {
      requireFields(row, 8, gtCsv, "'timestamp_ns, p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...'");
      const long long ns = parseInteger(row.fields[0], gtCsv, row.line, "timestamp [ns]");
      double v[7];
      for (int k = 0; k < 7; ++k) v[k] = parseNumber(row.fields[k + 1], gtCsv, row.line, "pose value");
      Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
      if (q.norm() < 1e-6) throw Error(where(gtCsv, row.line) + ": zero quaternion");
      StampedPose p;
      p.timestamp = quantizeStamp(static_cast<double>((ns + 500) / 1000) / 1e6);
      p.position = Eigen::Vector3d(v[0], v[1], v[2]);
      p.orientation = q.normalized();
      body.push_back(p);
    }
    requireSortedStamps(body, gtCsv.string());
    fillGroundTruth(idx, body, opt.gtMaxGap);
    for (auto& e : idx.frames)
      if (e.T_world_cam) e.T_world_cam = *e.T_world_cam * T_body_cam;
  } else {
    idx.assumptions.push_back("no state_groundtruth_estimate0/data.csv: no ground truth");
  }
  requireFilesExist(idx);
  return idx;
}

// ------------------------------------------------------------------------------------------------ folder
DatasetIndex indexImageFolder(const fs::path& root, const FolderOptions& opt) {
  requireFolder(root);
  DatasetIndex idx;
  idx.format = "folder";
  idx.root = root;
  const auto images = detail::listImages(root);
  if (images.empty()) throw Error(root.string() + ": empty dataset (no image files)");
  require(opt.rate > 0 && std::isfinite(opt.rate), root.string(),
          "a plain image folder needs a frame rate: pass --rate");
  require(std::isfinite(opt.firstStamp), "first_stamp", "must be finite");
  auto cam = resolveOverride(opt.override, images.front());
  if (!cam)
    throw Error(root.string() + ": a plain image folder carries no intrinsics: pass --camera-ini or --intrinsics");
  idx.camera = *cam;
  idx.assumptions.push_back("camera from " + opt.override.source + ": " + describeCamera(idx.camera));
  idx.assumptions.push_back("timestamps = " + formatDouble(opt.firstStamp, 16) + " + i / " + formatDouble(opt.rate) +
                            " Hz, images in natural name order");
  for (std::size_t i = 0; i < images.size(); ++i) {
    FrameEntry e;
    e.timestamp = quantizeStamp(opt.firstStamp + static_cast<double>(i) / opt.rate);
    e.image = images[i];
    idx.frames.push_back(std::move(e));
  }
  if (!opt.posesFile.empty()) {
    const Trajectory poses = readTumTrajectory(opt.posesFile);
    if (poses.size() != images.size())
      throw Error(opt.posesFile.string() + ": mismatched counts: " + std::to_string(poses.size()) + " poses for " +
                  std::to_string(images.size()) + " images in " + root.string());
    for (std::size_t i = 0; i < images.size(); ++i) idx.frames[i].T_world_cam = poses[i].T_world_cam();
    idx.groundTruthSamples = poses.size();
    idx.assumptions.push_back("pose i of " + opt.posesFile.filename().string() +
                              " belongs to image i (its stamps are replaced by the frame stamps)");
  }
  requireFilesExist(idx);
  return idx;
}

}  // namespace pslam::datasets
