#pragma once
// Alignment and pose metrics on associated trajectories (pose k of `gt` pairs with pose k of `est`).
// Definitions follow evo (MichaelGrupp/evo, evo/core/metrics.py, geometry.py, filters.py), which agrees with
// the TUM RGB-D benchmark scripts where both define a quantity:
//  - alignment: Umeyama (1991) least squares, p_gt ~ s R p_est + t (Eigen::umeyama); SE(3) fixes s = 1,
//    Sim(3) estimates s (monocular runs). Applied to the estimate: positions s R p + t, orientations R q.
//  - ATE (thesis eq. 2.102, as an RMSE): e_k = || p_gt,k - p_est,k || after alignment.
//  - RPE (thesis eq. 2.103 restricted to the pairs (i, j) chosen below): E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)
//    with Q ground truth, P the aligned estimate; translation error ||t(E)||, rotation error |angle(R(E))|
//    in degrees. Pairs are chosen on the ESTIMATE (evo's default):
//      delta in frames, consecutive: i = 0, d, 2d, ... and pairs of consecutive ids; all pairs: (i, i+d);
//      delta in metres, consecutive: the path length accumulated from the previous id (reset to 0 at each
//        id, starting at pose 0) reaches delta -> a new id, pairs of consecutive ids (pose 0 itself is not
//        an id, as in evo); all pairs: for each i, the j found by evo's bounded binary search with
//        |arc length(i..j) - delta| <= relTol * delta.
//  - RE (thesis eq. 4.8): mean over k of the angle between the camera z-axes of the aligned estimate and GT.
//  - statistics: rmse, mean, median (mean of the two middle values for an even count), std (ddof = 0,
//    numpy's default as evo), min, max, sse, count.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "pslam/core/Trajectory.h"

namespace pslam::eval {

struct ErrorStatistics {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0, sse = 0;
  std::size_t count = 0;
  nlohmann::json toJson() const;
};

/// Throws pslam::Error("<what>: ...") for an empty set or a non-finite value.
ErrorStatistics computeStatistics(const std::vector<double>& values, const std::string& what = "errors");

enum class AlignmentMode { None, SE3, Sim3 };
/// "none" | "se3" | "sim3"; throws pslam::Error naming the value otherwise.
AlignmentMode parseAlignmentMode(const std::string& name);
std::string toString(AlignmentMode mode);

/// p_gt ~ scale * rotation * p_est + translation.
struct Alignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;
  nlohmann::json toJson() const;
};

/// Umeyama alignment of the estimate onto the ground truth using pairs [0, firstN) (all when firstN == 0
/// or larger than the size). Throws pslam::Error if fewer than 3 pairs are used, if the sizes differ, or
/// if the used estimate positions are degenerate (all equal / collinear: rotation undetermined).
Alignment alignTrajectories(const Trajectory& gt, const Trajectory& est, AlignmentMode mode,
                            std::size_t firstN = 0);

/// One run of consecutive associated pairs aligned on its own (alignSegments).
struct SegmentAlignment {
  std::size_t first = 0, last = 0;  ///< pair indices, both included
  double startTime = 0, endTime = 0;  ///< ground-truth stamps of the first and the last pair
  double pathLength = 0;            ///< ground-truth path length over the segment, metres
  Alignment alignment;              ///< the segment's own; with Sim(3) its scale is the map's scale there
  ErrorStatistics ate;              ///< ATE after the segment's own alignment
  nlohmann::json toJson() const;
};

/// The associated pairs split into `segments` consecutive runs of equal size (the first n % segments of them one
/// pair longer), each aligned with `mode` and its ATE taken after that alignment. When one alignment of the whole
/// run leaves a large ATE, small segment ATEs with Sim(3) scales that differ from segment to segment say the error
/// is the scale drifting along the path (a monocular map's weakest direction), not local error. Throws pslam::Error
/// if `segments` is 0, a segment would hold fewer than 3 pairs, or a segment's alignment is undetermined (naming
/// the segment).
std::vector<SegmentAlignment> alignSegments(const Trajectory& gt, const Trajectory& est, AlignmentMode mode,
                                            std::size_t segments);

/// The smallest and largest alignment scale of the segments; spread() = largest / smallest - 1, the scale drift
/// along the path that one alignment of the whole run cannot absorb. Throws pslam::Error for no segments.
struct SegmentScaleRange {
  double smallest = 1.0, largest = 1.0;
  double spread() const { return largest / smallest - 1.0; }
};
SegmentScaleRange segmentScaleRange(const std::vector<SegmentAlignment>& segments);

/// Applies the alignment to every pose of `trajectory` (positions s R p + t, orientations R q).
Trajectory applyAlignment(const Trajectory& trajectory, const Alignment& alignment);

struct AteResult {
  ErrorStatistics stats;
  std::vector<double> errors;  ///< per pair, metres
};
/// ATE of an already aligned estimate. Throws pslam::Error if the sizes differ or are 0.
AteResult computeAte(const Trajectory& gt, const Trajectory& estAligned);

enum class DeltaUnit { Frames, Meters };
DeltaUnit parseDeltaUnit(const std::string& name);  ///< "frames"/"f" | "m"/"meters"
std::string toString(DeltaUnit unit);

struct RpeOptions {
  double delta = 1.0;
  DeltaUnit unit = DeltaUnit::Frames;
  bool allPairs = false;
  double relativeTolerance = 0.1;  ///< evo rel_delta_tol, used for metres with allPairs
};

/// Index pairs along `poses` following evo's filters (see the header comment). Throws pslam::Error if the
/// delta is not positive (or not an integer for frames) or if no pair results.
std::vector<std::pair<std::size_t, std::size_t>> selectRpePairs(const Trajectory& poses, const RpeOptions& o);

struct RpeResult {
  ErrorStatistics translation;  ///< metres
  ErrorStatistics rotation;     ///< degrees
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<double> translationErrors, rotationErrorsDeg;
};
/// RPE of an aligned estimate; pairs chosen on `estAligned`.
RpeResult computeRpe(const Trajectory& gt, const Trajectory& estAligned, const RpeOptions& options);

struct RotationErrorResult {
  ErrorStatistics stats;        ///< degrees; stats.mean is RE of eq. 4.8
  std::vector<double> errorsDeg;
};
/// Thesis eq. 4.8 on an aligned estimate: angle between the third columns of R_gt and R_est.
RotationErrorResult computeRotationError(const Trajectory& gt, const Trajectory& estAligned);

/// Rotation angle of a rotation matrix in radians, in [0, pi] (robust near 0 and pi).
double rotationAngle(const Eigen::Matrix3d& R);

}  // namespace pslam::eval
