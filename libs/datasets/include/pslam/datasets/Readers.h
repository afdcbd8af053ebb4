#pragma once
// Dataset readers: each turns one dataset layout on disk into a DatasetIndex (frames, camera, ground truth
// at the CAMERA stamps). Formats and conventions are documented in doc/datasets.md.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/img/TCamera.h>

#include "pslam/datasets/DatasetIndex.h"

namespace pslam::datasets {

enum class DatasetFormat { Tum, IclNuim, Kitti, Euroc, ImageFolder };

/// "tum", "icl", "kitti", "euroc", "folder".
std::string formatName(DatasetFormat f);
/// Inverse of formatName; throws pslam::Error "unknown dataset format '<name>'".
DatasetFormat parseFormatName(const std::string& name);

/// Looks at the files in `root`: rgb.txt -> TUM; associations.txt + *.gt.freiburg -> ICL-NUIM;
/// image_0/ or image_2/ -> KITTI; mav0/cam0/data.csv or cam0/data.csv -> EuRoC; image files -> folder.
/// Throws pslam::Error naming the folder when it is missing or matches none of these.
DatasetFormat detectFormat(const std::filesystem::path& root);

/// Options common to every reader: an explicit camera overrides what the dataset provides. Either a
/// complete TCamera (e.g. from an ini file) or bare intrinsics whose resolution is taken from the first image.
struct CameraOverride {
  std::optional<mrpt::img::TCamera> camera;  ///< complete camera
  std::vector<double> intrinsics;            ///< fx fy cx cy (used when `camera` is empty)
  std::vector<double> distortion;            ///< k1 k2 p1 p2 [k3] for `intrinsics`
  std::string source;                        ///< where it came from, for the summary
  bool given() const { return camera.has_value() || !intrinsics.empty(); }
};

struct TumOptions {
  CameraOverride override;
  std::string cameraName;        ///< "fr1" | "fr2" | "fr3"; empty = from the folder name
  double maxDepthDiff = 0.02;    ///< seconds, as TUM's associate.py --max_difference
  bool useDepth = true;
  double gtMaxGap = 0.0;         ///< > 0: no ground truth across holes longer than this (seconds)
};
/// TUM RGB-D: rgb.txt, depth.txt (optional), groundtruth.txt (optional). Depth units 1/5000 m.
DatasetIndex indexTumRgbd(const std::filesystem::path& root, const TumOptions& opt);

struct IclOptions {
  CameraOverride override;
  double rate = 30.0;             ///< Hz; ICL-NUIM frames carry ids, not times
  bool reflectPoses = true;       ///< convert the y-up renderer poses to the top-down images (S T S)
  bool useDepth = true;
  std::filesystem::path posesFile;  ///< empty = the single *.gt.freiburg in the folder, else groundtruth.txt
};
/// ICL-NUIM, TUM-compatible release: associations.txt ("id depth/id.png id rgb/id.png") or, without depth, rgb.txt
/// ("id rgb/id.png"), and <name>.gt.freiburg or groundtruth.txt (TUM lines whose first column is the frame id).
/// Depth units 1/5000 m.
DatasetIndex indexIclNuim(const std::filesystem::path& root, const IclOptions& opt);

struct KittiOptions {
  CameraOverride override;
  int cameraIndex = -1;               ///< 0 (image_0, grey) or 2 (image_2, colour); -1 = image_0 if present
  double rate = 0.0;                  ///< Hz, used only when times.txt is missing
  std::string rateSource;             ///< where the rate came from, for the summary
  std::filesystem::path timesFile;    ///< empty = <root>/times.txt
  std::filesystem::path posesFile;    ///< empty = <root>/../../poses/<seq>.txt
};
/// KITTI odometry sequence folder (sequences/NN): image_0|image_2, calib.txt, times.txt, poses/NN.txt
/// (3x4 row-major T_world_cam0). Missing calib.txt needs an explicit camera, missing times.txt a rate.
DatasetIndex indexKitti(const std::filesystem::path& root, const KittiOptions& opt);

struct EurocOptions {
  CameraOverride override;
  std::string cameraName = "cam0";
  double gtMaxGap = 0.0;
};
/// EuRoC MAV (ASL format): <mav0>/cam0/{data.csv,sensor.yaml,data/}, state_groundtruth_estimate0/data.csv
/// (BODY poses, T_world_cam = T_world_body * T_BS). `root` may be the sequence folder or its mav0/.
DatasetIndex indexEuroc(const std::filesystem::path& root, const EurocOptions& opt);

struct FolderOptions {
  CameraOverride override;           ///< required: a folder carries no intrinsics
  double rate = 0.0;                 ///< Hz, required
  double firstStamp = 0.0;           ///< seconds of the first image
  std::filesystem::path posesFile;   ///< optional TUM file, one pose per image in order
};
/// A plain folder of images (natural name order), timestamps firstStamp + i / rate.
DatasetIndex indexImageFolder(const std::filesystem::path& root, const FolderOptions& opt);

}  // namespace pslam::datasets
