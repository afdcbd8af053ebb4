#pragma once
// Camera intrinsics for the dataset readers: MRPT TCamera ini blocks (config/cameras/*.ini), the TUM RGB-D
// published calibrations, KITTI calib.txt projection matrices and explicit values from the command line.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <mrpt/img/TCamera.h>

namespace pslam::datasets {

/// Pinhole camera; `distortion` = [k1 k2 p1 p2 (k3)] (OpenCV/ROS plumb_bob order, as MRPT's `dist`);
/// empty or all-zero means no distortion.
mrpt::img::TCamera makePinholeCamera(uint32_t width, uint32_t height, double fx, double fy, double cx, double cy,
                                     const std::vector<double>& distortion = {});

/// Loads a TCamera block (keys resolution, fx, fy, cx, cy, dist, distortion_model) from an ini file.
/// Throws pslam::Error naming the file and section when the file is missing or a key is missing/invalid.
mrpt::img::TCamera loadCameraIni(const std::filesystem::path& iniFile, const std::string& section = "CAMERA");

/// Optional nominal frame rate (`frame_rate_hz`) stored beside the TCamera keys; nullopt if absent.
std::optional<double> loadFrameRateFromIni(const std::filesystem::path& iniFile, const std::string& section = "CAMERA");

/// The TUM RGB-D published calibration of the colour camera ("fr1", "fr2", "fr3"; also "freiburg1"...),
/// 640x480: fr1 517.3 516.5 318.6 255.3 d=[0.2624 -0.9531 -0.0054 0.0026 1.1633]; fr2 520.9 521.0 325.1
/// 249.7 d=[0.2312 -0.7849 -0.0033 -0.0001 0.9172]; fr3 535.4 539.2 320.1 247.6 without distortion (fr3
/// images are already undistorted). Throws pslam::Error for another name.
mrpt::img::TCamera tumCamera(const std::string& name);

/// "fr1"/"fr2"/"fr3" from a TUM sequence folder name (rgbd_dataset_freiburg2_desk -> "fr2"), or nullopt.
std::optional<std::string> tumCameraFromFolderName(const std::string& folderName);

/// ICL-NUIM (TUM-compatible release) camera: 481.20 480.00 319.50 239.50, 640x480, no distortion. The
/// dataset page lists fy = -480 for its POV-Ray native format; the TUM-compatible PNGs are stored top-down,
/// so fy is positive here (see doc/datasets.md for the matching pose conversion).
mrpt::img::TCamera iclNuimCamera();

}  // namespace pslam::datasets
