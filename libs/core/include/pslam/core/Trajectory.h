#pragma once
// Stamped camera poses and the TUM trajectory format (`timestamp tx ty tz qx qy qz qw`, camera-to-world),
// the format of ground truth beside every rawlog and of every trajectory a run writes.
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include <mrpt/poses/CPose3D.h>

namespace pslam {

/// One pose of a trajectory: T_world_cam maps camera coordinates to world coordinates.
struct StampedPose {
  double timestamp = 0.0;  ///< seconds
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();

  StampedPose() = default;
  StampedPose(double t, const Eigen::Isometry3d& T_world_cam);
  Eigen::Isometry3d T_world_cam() const;
  mrpt::poses::CPose3D toCPose3D() const;
  static StampedPose fromCPose3D(double t, const mrpt::poses::CPose3D& T_world_cam);
};

using Trajectory = std::vector<StampedPose>;

/// The same rigid transform as an MRPT pose and back, element for element (no re-orthonormalization, so a round
/// trip Eigen -> CPose3D -> Eigen gives the same bits).
mrpt::poses::CPose3D toCPose3D(const Eigen::Isometry3d& T);
Eigen::Isometry3d toIsometry(const mrpt::poses::CPose3D& T);

/// Whether a reader requires the stamps to be in time order.
enum class StampOrder { Any, NonDecreasing };

/// Reads a TUM trajectory. Skips blank lines and '#' comments. Throws pslam::Error naming file and line on
/// a malformed line, a NaN/Inf value, a zero quaternion, or a file that cannot be opened; with
/// StampOrder::NonDecreasing also on a stamp before the previous one. Quaternions are normalized. An empty
/// file gives an empty trajectory.
Trajectory readTumTrajectory(const std::filesystem::path& path, StampOrder order = StampOrder::Any);

/// The message of a stamp that goes back in time: "<file>:<line>: timestamp <t> is before the previous one
/// (line <l>)".
std::string stampOrderError(const std::filesystem::path& path, int line, double stamp, int previousLine);

/// "" if every stamp is after the previous one, else a one-line note naming `path`, the number of stamps equal to
/// the previous one and the first of them. Published ground truth has some (TUM fr2/desk); readers keep them.
std::string duplicateStampNote(const Trajectory& trajectory, const std::filesystem::path& path);

/// Writes a TUM trajectory atomically (temporary file + rename), timestamps with 6 decimals, poses with 9
/// significant digits.
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                        const std::string& headerComment = "");

/// Formats one TUM line (no newline).
std::string formatTumLine(const StampedPose& pose);

/// The pose of `sortedByStamp` (ascending timestamps) nearest in time to `t`, or null when none is within `maxDt`
/// seconds (ground truth for a frame; of two equally near, the later).
const StampedPose* nearestPose(const Trajectory& sortedByStamp, double t, double maxDt);

}  // namespace pslam
