#pragma once
// Parameters of the optimization back end; defaults are Table 3.2 and ORB-SLAM's Optimizer.cc.
#include <string>

namespace mrpt::config {
class CConfigFileBase;
}

namespace pslam::optimize {

/// Motion-only optimization (ORB-SLAM Optimizer::PoseOptimization).
struct PoseOptimizationParams {
  int rounds = 4;                ///< outlier-classification rounds
  int iterationsPerRound = 10;   ///< Levenberg-Marquardt iterations per round
  int robustRounds = 2;          ///< the first rounds use the Huber loss, the later ones plain least squares
  double huberDelta = 2.448;     ///< delta_R, whitened pixels (Table 3.2) = sqrt(chi2Threshold)
  double chi2Threshold = 5.991;  ///< chi_R: 95% of chi-square with 2 DoF (Table 3.2)
  int minCorrespondences = 3;    ///< fewer correspondences: no optimization, 0 inliers returned
  int minInliersToContinue = 10; ///< stop the rounds early when fewer inliers remain (ORB-SLAM)

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  /// Throws pslam::Error naming the offending key.
  void check() const;
};

/// Local and global bundle adjustment (ORB-SLAM Optimizer::LocalBundleAdjustment / GlobalBundleAdjustemnt).
struct BundleAdjustmentParams {
  int maxLocalKeyFrames = 20;      ///< N_lBA (Table 3.2): keyframes optimized in local BA
  int firstPassIterations = 5;     ///< with the Huber loss on every observation
  int secondPassIterations = 10;   ///< without the loss and without the outliers of the first pass; 0 = skip
  int globalIterations = 20;       ///< global BA of the initial map
  double huberDelta = 2.448;       ///< delta_R (Table 3.2)
  double chi2Threshold = 5.991;    ///< chi_R (Table 3.2)
  int numThreads = 1;              ///< Ceres threads; 1 keeps runs bit-for-bit repeatable
  double functionTolerance = 1e-6; ///< Ceres relative cost-change convergence test
  /// "sparse_schur" (SuiteSparse Cholesky of the reduced camera system) or "dense_schur" (dense Cholesky,
  /// often faster for the ~30 poses of a local window; see bench_optimize).
  std::string linearSolver = "sparse_schur";

  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  void check() const;
};

}  // namespace pslam::optimize
