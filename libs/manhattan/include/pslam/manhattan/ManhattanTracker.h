#pragma once
// Mean-shift Manhattan-frame (MF) rotation tracking on the unit sphere (thesis §2.3.2.4, Algorithm 4,
// after Zhou et al.), with the first-frame initialization and the two-plane completion of §4.4.1.
//
// Convention: R_cam_mf has the three MF axes, expressed in the camera frame, as its COLUMNS; it maps MF
// coordinates to camera coordinates. Algorithm 4 writes the same axes as the ROWS of R = R_mf_cam.
// Normals and axes are sign-less directions (a plane and its opposite wall support the same axis).
#include <array>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <mrpt/config/CConfigFileBase.h>
#include <nlohmann/json.hpp>

#include "pslam/core/Params.h"
namespace pslam::manhattan {

struct ManhattanParams {
  double coneAngleDeg = 10.0;
  double kernelWidth = 2.0;
  int maxIterations = 50;
  double convergenceDeg = 0.01;
  /// Coarse stage before the rho_th stage: same iteration with a wider cone, so that an axis that moved more
  /// than rho_th since the previous estimate (or a sampled start) is still captured. 0 disables it.
  double coarseConeAngleDeg = 25.0;
  std::size_t maxNormals = 20000;
  // Validity of an estimate (callers reject a bad rotation, §4.4.2 "Pose Validation").
  std::size_t minAxisSupport = 200;
  double minAxisShare = 0.03;
  double maxAxisSpreadDeg = 6.0;
  int minObservedAxes = 2;
  double maxStepDeg = 45.0;
  // First-frame initialization: sampled rotations, mean shift from each, clustering.
  int initSamples = 100;
  double initClusterDeg = 3.0;
  unsigned seed = 42;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, coneAngleDeg, inOpen(0, 45), "rho_th of Table 4.1: normals within this angle of an axis support it");
    PSLAM_FIELD(v, kernelWidth, atLeast(0), "c of Table 4.1 in the Gaussian kernel exp(-c |p|^2) of eq. 2.67 (p in rad)");
    PSLAM_FIELD(v, maxIterations, atLeast(1), "mean-shift iterations per estimate");
    PSLAM_FIELD(v, convergenceDeg, greaterThan(0), "stop when the rotation changes less than this per iteration");
    PSLAM_FIELD(v, coarseConeAngleDeg,
                satisfies([this](double c) { return c == 0 || (c >= coneAngleDeg && c < 45); },
                          "must be 0 or in [coneAngleDeg, 45)"),
                "cone of the coarse stage (deg); 0 = none");
    PSLAM_FIELD(v, maxNormals, atLeast(10), "normals used per frame (seeded subsample of a larger set)");
    PSLAM_FIELD(v, minAxisSupport, anyValue, "normals an axis needs to count as observed");
    PSLAM_FIELD(v, minAxisShare, inRightOpen(0, 1), "... and this share of all normals");
    PSLAM_FIELD(v, maxAxisSpreadDeg, greaterThan(0), "RMS angle of the supporting normals to their axis");
    PSLAM_FIELD(v, minObservedAxes, inClosed(2, 3), "2 = the third axis may come from the cross product (§4.4.1)");
    PSLAM_FIELD(v, maxStepDeg, inLeftOpen(0, 45), "largest plausible MF rotation between consecutive frames");
    PSLAM_FIELD(v, initSamples, atLeast(1), "sampled start rotations of the first-frame initialization");
    PSLAM_FIELD(v, initClusterDeg, greaterThan(0), "converged rotations closer than this (modulo the cube symmetry) cluster");
    PSLAM_FIELD(v, seed, anyValue, "seed of the normal subsample and the start rotations");
  }
  PSLAM_PARAMS("ManhattanTracker")
};

struct AxisSupport {
  std::size_t count = 0;  ///< normals inside the rho_th cone
  double share = 0.0;     ///< count / all normals
  double spreadDeg = 0.0; ///< RMS angle of those normals to the axis
  bool observed = false;  ///< count and share above the thresholds, spread below
};

struct ManhattanEstimate {
  Eigen::Matrix3d R_cam_mf = Eigen::Matrix3d::Identity();
  std::array<AxisSupport, 3> axes{};
  int observedAxes = 0;
  int completedAxis = -1;   ///< axis filled in by the cross product of the other two, or -1
  int iterations = 0;
  bool converged = false;
  bool valid = false;       ///< enough observed axes, converged, and (when tracking) a plausible step
  bool reinitialized = false;  ///< tracking failed and the frame was re-initialized from samples
  std::string reason;       ///< why the estimate is invalid (empty when valid)
  nlohmann::json toJson() const;
};

// ---- The S^2 maps of eqs. 2.66 and 2.68 (tangent plane at +z), sign-less as in Zhou et al.
/// Logarithm map: unit vector v -> tangent vector p (|p| = angle to the z axis, v and -v map alike).
Eigen::Vector2d logMapS2(const Eigen::Vector3d& v);
/// Exponential map back onto the sphere, as eq. 2.68: normalize([tan|m|/|m| m; 1]).
Eigen::Vector3d expMapS2(const Eigen::Vector2d& m);

/// Angle of R_a^T R_b in degrees.
double rotationAngleDeg(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b);
/// The 24 proper rotations that permute and flip the axes of a cube (the MF's symmetry group).
const std::vector<Eigen::Matrix3d>& cubeSymmetries();
/// R_cam_mf re-labelled (axes permuted / flipped, kept right-handed) to be closest to `reference`;
/// `angleDeg` receives the remaining angle.
Eigen::Matrix3d alignToReference(const Eigen::Matrix3d& R_cam_mf, const Eigen::Matrix3d& reference,
                                 double* angleDeg = nullptr);

/// One full mean-shift estimate from `R_start` (Algorithm 4 iterated to convergence, coarse then fine
/// cone), with support statistics. Stateless; used by the tracker for tracking and initialization.
ManhattanEstimate refineManhattanFrame(const std::vector<Eigen::Vector3d>& normals,
                                       const Eigen::Matrix3d& R_start, const ManhattanParams& params);

/// Algorithm 4, one iteration with cone `coneAngleDeg`. Returns the orthogonalized new rotation; `support`
/// receives the per-axis counts inside the cone. Axes with fewer than `minSupport` (>= 1) normals keep their
/// previous direction; with exactly one such axis it is the cross product of the other two (§4.4.1).
Eigen::Matrix3d meanShiftIteration(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R_cam_mf,
                                   double coneAngleDeg, double kernelWidth, std::size_t minSupport,
                                   std::array<std::size_t, 3>* support);

class ManhattanTracker {
 public:
  explicit ManhattanTracker(ManhattanParams params = {});
  const ManhattanParams& params() const { return params_; }

  /// First frame (or after reset): samples rotations (seeded), runs the mean shift from each and returns
  /// the dominant cluster (the one with the largest total support). Sets the tracker state when valid.
  ManhattanEstimate initialize(const std::vector<Eigen::Vector3d>& normals);
  /// Later frames: mean shift from the previous estimate; if that is invalid, re-initializes and keeps the
  /// axis labels of the previous frame (cube symmetry closest to it, within maxStepDeg). The state only
  /// advances on valid estimates.
  ManhattanEstimate track(const std::vector<Eigen::Vector3d>& normals);
  /// initialize() until the first valid estimate, then track().
  ManhattanEstimate process(const std::vector<Eigen::Vector3d>& normals);

  bool initialized() const { return initialized_; }
  const Eigen::Matrix3d& R_cam_mf() const { return R_cam_mf_; }

 private:
  std::vector<Eigen::Vector3d> subsample(const std::vector<Eigen::Vector3d>& normals);
  ManhattanEstimate sampleAndCluster(const std::vector<Eigen::Vector3d>& normals);

  ManhattanParams params_;
  std::mt19937 rng_;
  bool initialized_ = false;
  Eigen::Matrix3d R_cam_mf_ = Eigen::Matrix3d::Identity();
};

}  // namespace pslam::manhattan
