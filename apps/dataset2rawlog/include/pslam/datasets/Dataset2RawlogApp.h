#pragma once
// dataset2rawlog as a testable class: reads a dataset (TUM RGB-D, ICL-NUIM, KITTI odometry, EuRoC MAV, image
// folder), writes `<out>/<name>.rawlog` + `<name>_Images/` (the rawlog contract, doc/architecture.md, "Data contracts") and
// `<out>/<name>_groundtruth.txt` (TUM, camera-to-world, stamps equal to the CAMERA stamps). Nothing appears
// under the final names unless the whole conversion succeeds.
#include <cstddef>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Params.h"
#include "pslam/core/StageTimer.h"
#include "pslam/datasets/DatasetIndex.h"

namespace pslam::datasets {

struct Dataset2RawlogOptions {
  std::filesystem::path input;       ///< dataset folder
  std::filesystem::path outDir;      ///< output folder
  std::string name;                  ///< output base name; empty = derived from the input folder
  std::string format = "auto";       ///< auto | tum | icl | kitti | euroc | folder
  std::size_t first = 0;             ///< first frame (0-based, in the dataset's order)
  std::size_t last = std::numeric_limits<std::size_t>::max();  ///< last frame, inclusive
  std::size_t count = 0;             ///< at most this many frames (after stride); 0 = all
  std::size_t stride = 1;
  std::string color = "keep";        ///< keep | grey | colour
  std::string imageFormat = "png";   ///< lossless: png | bmp | tiff | ppm | pgm
  // Camera
  std::filesystem::path cameraIni;   ///< TCamera ini file (config/cameras/*.ini)
  std::string cameraSection = "CAMERA";
  std::vector<double> intrinsics;    ///< fx fy cx cy (resolution from the first image)
  std::vector<double> distortion;    ///< k1 k2 p1 p2 [k3] with `intrinsics`
  std::string tumCamera;             ///< fr1 | fr2 | fr3 (empty = from the folder name)
  // Timing and channels
  double rate = 0.0;                 ///< Hz: KITTI without times.txt, ICL-NUIM (default 30), image folder
  double firstStamp = 0.0;           ///< seconds of the first frame (image folder)
  double maxDepthDiff = 0.02;        ///< TUM RGB/depth association window (s), as associate.py
  double gtMaxGap = 0.0;             ///< > 0: no ground truth interpolated across longer holes (s)
  bool noDepth = false;
  // Format specifics
  int kittiCamera = -1;              ///< 0 | 2 | -1 (= image_0 if present)
  std::string eurocCamera = "cam0";  ///< EuRoC camera folder under mav0/
  std::filesystem::path posesFile;   ///< KITTI/ICL/folder ground truth file (overrides the default place)
  std::filesystem::path timesFile;   ///< KITTI times file (overrides <seq>/times.txt)
  bool iclRawPoses = false;          ///< keep ICL-NUIM poses in the renderer's y-up frame
  bool progress = true;

  /// Keys: the member names in snake_case (pslam/core/Params.h: strict, unknown keys are errors). The
  /// command-line options of dataset2rawlog set the same fields and are checked by the same rules.
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, input, anyValue, "dataset folder (required)");
    PSLAM_KEY(v, "out_dir", outDir, anyValue, "output folder (required)");
    PSLAM_FIELD(v, name, satisfies([](const std::string& n) { return n.find('/') == std::string::npos; },
                                   "must be a base name, not a path"),
                "output base name (empty = from the input folder)");
    PSLAM_FIELD(v, format, oneOf({"auto", "tum", "icl", "kitti", "euroc", "folder"}), "dataset format");
    PSLAM_FIELD(v, first, anyValue, "first frame (0-based)");
    PSLAM_FIELD(v, last, satisfies([this](std::size_t l) { return l >= first; }, "must not be before first"),
                "last frame, inclusive");
    PSLAM_FIELD(v, count, anyValue, "at most this many frames after stride (0 = all)");
    PSLAM_FIELD(v, stride, atLeast(1), "keep every n-th frame");
    PSLAM_FIELD(v, color, oneOf({"keep", "grey", "gray", "colour", "color"}), "CAMERA image colour");
    PSLAM_KEY(v, "image_format", imageFormat, oneOf({"png", "bmp", "tiff", "ppm", "pgm"}), "lossless image format");
    PSLAM_KEY(v, "camera_ini", cameraIni, anyValue, "MRPT TCamera ini (config/cameras/*.ini)");
    PSLAM_KEY(v, "camera_section", cameraSection, nonEmpty, "section of camera_ini");
    PSLAM_FIELD(v, intrinsics, custom([this](const std::vector<double>& k) { return intrinsicsProblem(k); },
                                      "4 finite values fx, fy, cx, cy; not with camera_ini"),
                "fx fy cx cy (resolution from the first image)");
    PSLAM_FIELD(v, distortion, custom([this](const std::vector<double>& d) { return distortionProblem(d); },
                                      "at most 5 finite values k1, k2, p1, p2, k3; only with intrinsics"),
                "k1 k2 p1 p2 [k3] (plumb_bob) with intrinsics");
    PSLAM_KEY(v, "tum_camera", tumCamera, oneOf({"", "fr1", "fr2", "fr3"}), "TUM calibration (empty = from the folder)");
    PSLAM_FIELD(v, rate, atLeast(0), "[Hz] KITTI without times.txt, ICL-NUIM, image folder");
    PSLAM_KEY(v, "first_stamp", firstStamp, finite(), "[s] stamp of the first image (image folder)");
    PSLAM_KEY(v, "max_depth_diff", maxDepthDiff, greaterThan(0), "[s] TUM RGB/depth association window");
    PSLAM_KEY(v, "gt_max_gap", gtMaxGap, atLeast(0), "[s] no ground truth interpolated across longer holes (0 = no limit)");
    PSLAM_KEY(v, "no_depth", noDepth, anyValue, "do not write DEPTH observations");
    PSLAM_KEY(v, "kitti_camera", kittiCamera,
              satisfies([](int c) { return c == -1 || c == 0 || c == 2; }, "must be 0, 2 or -1 (auto)"), "KITTI camera");
    PSLAM_KEY(v, "euroc_camera", eurocCamera, oneOf({"cam0", "cam1"}), "EuRoC camera folder");
    PSLAM_KEY(v, "poses", posesFile, anyValue, "ground-truth file (KITTI poses, ICL *.gt.freiburg, TUM for a folder)");
    PSLAM_KEY(v, "times", timesFile, anyValue, "KITTI times file");
    PSLAM_KEY(v, "icl_raw_poses", iclRawPoses, anyValue, "keep ICL-NUIM poses in the renderer's y-up frame");
    PSLAM_FIELD(v, progress, anyValue, "progress on the terminal");
  }
  /// loadFromConfigFile / saveToConfigFile (section default dataset2rawlog); check() throws params::ParamError
  /// naming the offending key (input and out_dir must be set).
  PSLAM_PARAMS("dataset2rawlog")

 private:
  std::optional<std::string> intrinsicsProblem(const std::vector<double>& k) const;
  std::optional<std::string> distortionProblem(const std::vector<double>& d) const;
};

struct Dataset2RawlogSummary {
  std::string format;
  std::filesystem::path rawlogPath;
  std::filesystem::path groundTruthPath;  ///< empty when the dataset has no ground truth
  std::size_t frames = 0;
  std::size_t depthFrames = 0;
  std::size_t groundTruthPoses = 0;
  double seconds = 0.0;                   ///< wall time of the conversion
  std::vector<std::string> assumptions;
  StageTimings timings;                   ///< per frame: "read" (decode the dataset files), "write" (rawlog + images)

  double framesPerSecond() const { return seconds > 0 ? frames / seconds : 0.0; }
  /// One line: "<n> frames (<d> with depth), <g> GT poses -> <rawlog> in <s> s (<fps> frames/s)".
  std::string line() const;
};

class Dataset2RawlogApp {
 public:
  explicit Dataset2RawlogApp(Dataset2RawlogOptions options);
  /// Builds the dataset index (format detection, camera, timestamps, ground truth, frame range).
  DatasetIndex buildIndex() const;
  /// Converts; throws pslam::Error with the file/line/frame at fault, leaving no output behind.
  Dataset2RawlogSummary run();

  /// The base name used when options.name is empty: kitti_<seq> for KITTI, the sequence folder otherwise.
  static std::string defaultName(const DatasetIndex& index);

 private:
  Dataset2RawlogOptions opt_;
};

/// "a,b,c" or "a b c" -> numbers; throws pslam::Error naming `what` on a bad value.
std::vector<double> parseNumberList(const std::string& text, const std::string& what);

}  // namespace pslam::datasets
