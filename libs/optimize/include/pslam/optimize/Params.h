#pragma once
// Parameters of the optimization back end; defaults are Table 3.2 and ORB-SLAM's Optimizer.cc.
#include <string>

#include "pslam/core/Params.h"

namespace pslam::optimize {

/// Motion-only optimization (ORB-SLAM Optimizer::PoseOptimization), [PoseOptimization].
struct PoseOptimizationParams {
  int rounds = 4;
  int iterationsPerRound = 10;
  int robustRounds = 2;
  double huberDelta = 2.448;
  double chi2Threshold = 5.991;
  int minCorrespondences = 3;
  int minInliersToContinue = 10;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, rounds, atLeast(1), "outlier-classification rounds");
    PSLAM_FIELD(v, iterationsPerRound, atLeast(1), "Levenberg-Marquardt iterations per round");
    PSLAM_FIELD(v, robustRounds, atLeast(0), "the first rounds use the Huber loss, the later ones plain least squares");
    PSLAM_FIELD(v, huberDelta, greaterThan(0), "delta_R, whitened pixels (Table 3.2) = sqrt(chi2Threshold)");
    PSLAM_FIELD(v, chi2Threshold, greaterThan(0), "chi_R: 95% of chi-square with 2 DoF (Table 3.2)");
    PSLAM_FIELD(v, minCorrespondences, atLeast(3),
                "fewer correspondences: no optimization, 0 inliers returned (a pose has 6 DoF, 2 per point)");
    PSLAM_FIELD(v, minInliersToContinue, atLeast(0), "stop the rounds early when fewer inliers remain (ORB-SLAM)");
  }
  PSLAM_PARAMS("PoseOptimization")
};

/// Local and global bundle adjustment (ORB-SLAM Optimizer::LocalBundleAdjustment / GlobalBundleAdjustemnt),
/// [BundleAdjustment].
struct BundleAdjustmentParams {
  int maxLocalKeyFrames = 20;
  int firstPassIterations = 5;
  int secondPassIterations = 10;
  int globalIterations = 20;
  double huberDelta = 2.448;
  double chi2Threshold = 5.991;
  int numThreads = 1;
  double functionTolerance = 1e-6;
  /// "sparse_schur" (SuiteSparse Cholesky of the reduced camera system) or "dense_schur" (dense Cholesky,
  /// often faster for the ~30 poses of a local window; see bench_optimize).
  std::string linearSolver = "sparse_schur";

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, maxLocalKeyFrames, atLeast(1), "N_lBA (Table 3.2): keyframes optimized in local BA");
    PSLAM_FIELD(v, firstPassIterations, atLeast(1), "with the Huber loss on every observation");
    PSLAM_FIELD(v, secondPassIterations, atLeast(0), "without the loss and the first pass' outliers; 0 = skip");
    PSLAM_FIELD(v, globalIterations, atLeast(1), "global BA of the initial map");
    PSLAM_FIELD(v, huberDelta, greaterThan(0), "delta_R (Table 3.2)");
    PSLAM_FIELD(v, chi2Threshold, greaterThan(0), "chi_R (Table 3.2)");
    PSLAM_FIELD(v, numThreads, atLeast(1), "Ceres threads; 1 keeps runs bit-for-bit repeatable");
    PSLAM_FIELD(v, functionTolerance, greaterThan(0), "Ceres relative cost-change convergence test");
    PSLAM_FIELD(v, linearSolver, oneOf({"sparse_schur", "dense_schur"}), "Ceres linear solver");
  }
  PSLAM_PARAMS("BundleAdjustment")
};

}  // namespace pslam::optimize
