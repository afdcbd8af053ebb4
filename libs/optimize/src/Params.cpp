#include "pslam/optimize/Params.h"

#include <cmath>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"

namespace pslam::optimize {

namespace {
void requireKey(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw Error("optimizer parameter '" + key + "': " + what);
}
bool positiveFinite(double v) { return std::isfinite(v) && v > 0.0; }
}  // namespace

void PoseOptimizationParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& s) {
  rounds = cfg.read_int(s, "rounds", rounds);
  iterationsPerRound = cfg.read_int(s, "iterationsPerRound", iterationsPerRound);
  robustRounds = cfg.read_int(s, "robustRounds", robustRounds);
  huberDelta = cfg.read_double(s, "huberDelta", huberDelta);
  chi2Threshold = cfg.read_double(s, "chi2Threshold", chi2Threshold);
  minCorrespondences = cfg.read_int(s, "minCorrespondences", minCorrespondences);
  minInliersToContinue = cfg.read_int(s, "minInliersToContinue", minInliersToContinue);
  check();
}

void PoseOptimizationParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& s) const {
  cfg.write(s, "rounds", rounds);
  cfg.write(s, "iterationsPerRound", iterationsPerRound);
  cfg.write(s, "robustRounds", robustRounds);
  cfg.write(s, "huberDelta", huberDelta);
  cfg.write(s, "chi2Threshold", chi2Threshold);
  cfg.write(s, "minCorrespondences", minCorrespondences);
  cfg.write(s, "minInliersToContinue", minInliersToContinue);
}

void PoseOptimizationParams::check() const {
  requireKey(rounds >= 1, "rounds", "must be >= 1");
  requireKey(iterationsPerRound >= 1, "iterationsPerRound", "must be >= 1");
  requireKey(robustRounds >= 0, "robustRounds", "must be >= 0");
  requireKey(positiveFinite(huberDelta), "huberDelta", "must be finite and > 0");
  requireKey(positiveFinite(chi2Threshold), "chi2Threshold", "must be finite and > 0");
  requireKey(minCorrespondences >= 3, "minCorrespondences", "must be >= 3 (a pose has 6 DoF, 2 per point)");
  requireKey(minInliersToContinue >= 0, "minInliersToContinue", "must be >= 0");
}

void BundleAdjustmentParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& s) {
  maxLocalKeyFrames = cfg.read_int(s, "maxLocalKeyFrames", maxLocalKeyFrames);
  firstPassIterations = cfg.read_int(s, "firstPassIterations", firstPassIterations);
  secondPassIterations = cfg.read_int(s, "secondPassIterations", secondPassIterations);
  globalIterations = cfg.read_int(s, "globalIterations", globalIterations);
  huberDelta = cfg.read_double(s, "huberDelta", huberDelta);
  chi2Threshold = cfg.read_double(s, "chi2Threshold", chi2Threshold);
  numThreads = cfg.read_int(s, "numThreads", numThreads);
  functionTolerance = cfg.read_double(s, "functionTolerance", functionTolerance);
  linearSolver = cfg.read_string(s, "linearSolver", linearSolver);
  check();
}

void BundleAdjustmentParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& s) const {
  cfg.write(s, "maxLocalKeyFrames", maxLocalKeyFrames);
  cfg.write(s, "firstPassIterations", firstPassIterations);
  cfg.write(s, "secondPassIterations", secondPassIterations);
  cfg.write(s, "globalIterations", globalIterations);
  cfg.write(s, "huberDelta", huberDelta);
  cfg.write(s, "chi2Threshold", chi2Threshold);
  cfg.write(s, "numThreads", numThreads);
  cfg.write(s, "functionTolerance", functionTolerance);
  cfg.write(s, "linearSolver", linearSolver);
}

void BundleAdjustmentParams::check() const {
  requireKey(maxLocalKeyFrames >= 1, "maxLocalKeyFrames", "must be >= 1");
  requireKey(firstPassIterations >= 1, "firstPassIterations", "must be >= 1");
  requireKey(secondPassIterations >= 0, "secondPassIterations", "must be >= 0");
  requireKey(globalIterations >= 1, "globalIterations", "must be >= 1");
  requireKey(positiveFinite(huberDelta), "huberDelta", "must be finite and > 0");
  requireKey(positiveFinite(chi2Threshold), "chi2Threshold", "must be finite and > 0");
  requireKey(numThreads >= 1, "numThreads", "must be >= 1");
  requireKey(positiveFinite(functionTolerance), "functionTolerance", "must be finite and > 0");
  requireKey(linearSolver == "sparse_schur" || linearSolver == "dense_schur", "linearSolver",
             "must be sparse_schur or dense_schur, got '" + linearSolver + "'");
}

}  // namespace pslam::optimize
