#pragma once
// Trajectory readers for the formats evaluated by slam-eval: TUM (`t tx ty tz qx qy qz qw`), KITTI odometry
// (12 numbers per line: the row-major 3x4 [R|t] of T_world_cam, no timestamps; optional times file with one
// time per line) and EuRoC/ASL csv (`timestamp_ns, px, py, pz, qw, qx, qy, qz, ...`). All give camera- (or
// body-) to-world poses as pslam::Trajectory. Stamps must be in time order: a stamp before the previous one is
// an error naming the file and line (of the times file for KITTI). A stamp equal to the previous one is kept, as
// evo keeps it (published ground truth has some, e.g. TUM fr2/desk); slam-eval reports them
// (pslam::duplicateStampNote).
#include <filesystem>
#include <string>

#include "pslam/core/Trajectory.h"

namespace pslam::eval {

enum class TrajectoryFormat { Auto, Tum, Kitti, Euroc };

/// "auto" | "tum" | "kitti" | "euroc" -> format; throws pslam::Error naming the value otherwise.
TrajectoryFormat parseTrajectoryFormat(const std::string& name);
std::string toString(TrajectoryFormat format);

/// Guesses the format from the first data line: 12 numbers -> KITTI, comma-separated with an integer
/// nanosecond first field -> EuRoC, 8 numbers -> TUM. Throws pslam::Error naming the file if it cannot be
/// opened, holds no data line, or matches none of them.
TrajectoryFormat detectTrajectoryFormat(const std::filesystem::path& path);

/// Reads a KITTI pose file. Timestamps come from `timesPath` (one per line, as many as poses) when given,
/// else are the 0-based line index (index-based association). The rotation block is re-orthonormalized
/// (the files hold 6-7 significant digits). Throws pslam::Error with file:line on a malformed line or a
/// non-finite value, and on a times file whose length differs.
Trajectory readKittiTrajectory(const std::filesystem::path& path, const std::filesystem::path& timesPath = {});

/// Reads an EuRoC/ASL csv (header lines start with '#'); timestamps in ns are converted to seconds; the
/// quaternion is stored w x y z; extra columns (velocities, biases) are ignored.
Trajectory readEurocTrajectory(const std::filesystem::path& path);

/// Reads any of the above; `format` Auto detects it. `kittiTimesPath` is used for KITTI only.
Trajectory readTrajectory(const std::filesystem::path& path, TrajectoryFormat format = TrajectoryFormat::Auto,
                          const std::filesystem::path& kittiTimesPath = {});

}  // namespace pslam::eval
