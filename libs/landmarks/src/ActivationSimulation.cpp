#include "pslam/landmarks/ActivationSimulation.h"

namespace pslam::landmarks {

std::vector<ActivationStep> simulateActivation(const KeypointModel& model, const ActivationScenario& sc,
                                               std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sc.measurementStd);
  std::uniform_real_distribution<double> anywhere(model.params().inverseDepthMin, model.params().inverseDepthMax);
  std::vector<ActivationStep> steps;
  auto record = [&](int i, const KeypointState& s) {
    ActivationStep st;
    st.observation = i;
    st.inlierRatio = model.inlierRatio(s);
    model.combinedCounts(s, st.a, st.b);
    st.mu = s.mu;
    st.sigma2 = s.sigma2;
    st.active = model.isActive(s);
    steps.push_back(st);
  };
  // The point is created by a triangulation whose pixel carries the first semantic prediction.
  KeypointState s = model.initialize(sc.trueInverseDepth + noise(rng), sc.initialStd * sc.initialStd);
  model.addSemanticObservation(s, sc.cnn, sc.alpha);
  record(0, s);
  for (int i = 1; i <= sc.observations; ++i) {
    model.addSemanticObservation(s, sc.cnn, sc.alpha);
    const double d = sc.consistent ? sc.trueInverseDepth + noise(rng) : anywhere(rng);
    model.updateDepth(s, d, sc.measurementStd * sc.measurementStd, sc.alpha);
    record(i, s);
  }
  return steps;
}

int firstActiveObservation(const std::vector<ActivationStep>& steps) {
  for (const auto& s : steps)
    if (s.active) return s.observation;
  return -1;
}

}  // namespace pslam::landmarks
