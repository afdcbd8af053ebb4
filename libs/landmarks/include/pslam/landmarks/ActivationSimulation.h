#pragma once
// Synthetic observation sequences of one map point through the keypoint model: the experiment behind
// Figure 3.4 (inlier-ratio evolution of a point with a static or dynamic semantic prior under consistent or
// inconsistent depth measurements). Used by its test and by the semantic-model-plot tool.
#include <random>
#include <vector>

#include "pslam/landmarks/KeypointModel.h"

namespace pslam::landmarks {

struct ActivationScenario {
  ClassVector cnn{0.9, 0.05, 0.05};  ///< CNN(c_k|I_i) at the point in every frame
  bool consistent = true;            ///< depth measurements around trueInverseDepth, else uniform over [Z_min, Z_max]
  double trueInverseDepth = 0.5;
  double measurementStd = 0.02;      ///< tau of every measurement (inverse depth)
  double initialStd = 0.1;
  double alpha = 0.9;                ///< matching accuracy of every observation
  int observations = 30;
};

struct ActivationStep {
  int observation = 0;       ///< 0 = after initialization, before any measurement
  double inlierRatio = 0.0;  ///< eq. 3.22
  double a = 0.0, b = 0.0;   ///< combined Beta counts (a_obs + a_sem, b_obs + b_sem)
  double mu = 0.0, sigma2 = 0.0;
  bool active = false;
};

/// Runs the scenario; the random numbers come from `rng` (seeded by the caller).
std::vector<ActivationStep> simulateActivation(const KeypointModel& model, const ActivationScenario& scenario,
                                               std::mt19937& rng);
/// First observation index at which the point is active, or -1.
int firstActiveObservation(const std::vector<ActivationStep>& steps);

}  // namespace pslam::landmarks
