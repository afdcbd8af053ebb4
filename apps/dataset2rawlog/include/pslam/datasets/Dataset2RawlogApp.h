#pragma once
// dataset2rawlog as a testable class: reads a dataset (TUM RGB-D, ICL-NUIM, KITTI odometry, EuRoC MAV, image
// folder), writes `<out>/<name>.rawlog` + `<name>_Images/` (the rawlog contract, DESIGN.md §3) and
// `<out>/<name>_groundtruth.txt` (TUM, camera-to-world, stamps equal to the CAMERA stamps). Nothing appears
// under the final names unless the whole conversion succeeds.
#include <cstddef>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>

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

  /// Keys: the member names in snake_case (input, out_dir, name, format, first, last, count, stride, color,
  /// image_format, camera_ini, camera_section, intrinsics, distortion, tum_camera, rate, first_stamp,
  /// max_depth_diff, gt_max_gap, no_depth, kitti_camera, euroc_camera, poses, times, icl_raw_poses, progress).
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  /// Throws pslam::Error naming the offending key.
  void check() const;
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
