#pragma once
// A dataset on disk described as a list of frames (image file, optional depth file, timestamp, optional
// ground-truth pose) plus the camera. Every reader (TUM RGB-D, ICL-NUIM, KITTI, EuRoC, image folder) builds
// one; images are decoded only when a frame is loaded, one at a time.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <mrpt/img/TCamera.h>
#include <mrpt/poses/CPose3D.h>

#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"

namespace pslam::datasets {

struct FrameEntry {
  double timestamp = 0.0;        ///< seconds, already quantized with quantizeStamp()
  std::filesystem::path image;   ///< CAMERA image file
  std::filesystem::path depth;   ///< u16 depth image registered to `image`, empty if none
  std::optional<Eigen::Isometry3d> T_world_cam;  ///< ground truth at `timestamp`, if known
};

struct DatasetIndex {
  std::string format;                    ///< "tum", "icl", "kitti", "euroc", "folder"
  std::filesystem::path root;            ///< the dataset folder
  mrpt::img::TCamera camera;             ///< intrinsics + distortion of the CAMERA images
  mrpt::poses::CPose3D sensorPoseOnBody; ///< CAMERA pose on the body (identity if unknown)
  double depthUnits = 0.0;               ///< metres per depth unit when frames have depth
  std::vector<FrameEntry> frames;
  std::size_t groundTruthSamples = 0;    ///< poses in the source ground-truth file (0 = none)
  std::vector<std::string> assumptions;  ///< what was assumed or defaulted, for the summary
};

/// Timestamps travel through MRPT as 100 ns ticks and through TUM files with 6 decimals. A stamp is
/// therefore rounded to whole microseconds and then round-tripped through mrpt::Clock::fromDouble /
/// toDouble, so the value a RawlogReader returns, the value written into the ground-truth file and the
/// value parsed back from it are the same double.
double quantizeStamp(double seconds);

/// Ground truth at time t from a trajectory sorted by time: linear interpolation of the position and
/// slerp of the orientation between the two bracketing samples (a sample stamp equal to t is returned
/// as is). Returns nullopt outside [first, last] sample stamps or, when maxGap > 0, when the bracketing
/// samples are more than maxGap seconds apart (a hole in the ground truth).
std::optional<Eigen::Isometry3d> interpolatePose(const Trajectory& samples, double t, double maxGap = 0.0);

/// Throws pslam::Error naming `source` unless the stamps are strictly increasing.
void requireSortedStamps(const Trajectory& samples, const std::string& source);

/// Keeps frames first, first+stride, ... up to `last` (inclusive; SIZE_MAX = to the end). Throws
/// pslam::Error when the dataset is empty or the range selects no frame.
void selectFrames(DatasetIndex& index, std::size_t first, std::size_t last, std::size_t stride);

enum class ColorMode { Keep, Grey, Colour };

/// Decodes frame `i`: the image (grey or BGR as asked), the depth (u16, must match the image size), the
/// camera and timestamp. Throws pslam::Error naming the file on an unreadable/empty image, a depth that is
/// not 16-bit single channel, or a size that differs from the intrinsics.
Frame loadFrame(const DatasetIndex& index, std::size_t i, ColorMode mode);

/// The frames' ground truth as a TUM trajectory (frames without ground truth are left out).
Trajectory groundTruthTrajectory(const DatasetIndex& index);

}  // namespace pslam::datasets
