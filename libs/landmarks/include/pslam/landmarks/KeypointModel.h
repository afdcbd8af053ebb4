#pragma once
// The probabilistic keypoint model of the thesis (§3.3, App. A.1): per map point an inverse-depth Gaussian
// N(Z|mu, sigma^2), a Beta(phi|a_obs, b_obs) of the geometric inlier model, and a semantic Beta prior
// Beta(phi|a_sem, b_sem) whose counts follow from the accumulated class evidence (eq. 3.10, 3.20-3.21).
// With matching accuracy alpha = 1 and no semantic prior it is the Vogiatzis/SVO model of §2.3.3.2.
//
// Conventions (see doc/semantic_model.md):
//  * The Beta used in the true posterior of App. A.1.2.1 is the combined one, a = a_obs + a_sem,
//    b = b_obs + b_sem (the counts of eq. 3.22). After moment matching (A.1.2.2) the semantic counts, which
//    are re-derived from q(c|S) at every step, are subtracted again: a'_obs = a' - a_sem, b'_obs = b' - b_sem.
//  * A class with B_k = infinity (Table 3.1: invalid / sky) vetoes the point: when its posterior mass reaches
//    `vetoProbability` the point is invalid (phi = 0, never active); below that its mass adds no counts.
//    No infinity is ever stored or computed.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "pslam/core/Params.h"

namespace pslam::landmarks {

/// Classes of the SEMANTIC channel (Table 3.1): 0 static, 1 (potentially) dynamic, 2 invalid.
inline constexpr int kNumSemanticClasses = 3;
using ClassVector = std::array<double, kNumSemanticClasses>;

/// Parameters of the keypoint model. Defaults: Table 3.1 (A_k, B_k), Table 3.2 (psi_min), SVO for the
/// initial counts a = b = 10 (§3.5.5.1 initializes a = b; the value is not given in the thesis).
struct KeypointModelParams {
  double initialCount = 10.0;
  double psiMin = 0.6;
  ClassVector priorA{5.0, 0.0, 0.0};
  ClassVector priorB{0.0, 5.0, std::numeric_limits<double>::infinity()};
  double vetoProbability = 0.5;
  double inverseDepthMin = 0.0;
  double inverseDepthMax = 10.0;
  double probabilityFloor = 1.0 / 510.0;
  double minCount = 1e-3;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, initialCount, greaterThan(0), "a_obs = b_obs at creation (§3.5.5.1)");
    PSLAM_FIELD(v, psiMin, inOpen(0, 1), "activation threshold on the inlier ratio (Table 3.2)");
    // A_k = inf would need an "always inlier" rule symmetric to the veto; Table 3.1 has none, so refuse it.
    v.field("A_static", priorA[0], atLeast(0), "A_k of class static (Table 3.1)");
    v.field("B_static", priorB[0], atLeast(0).orInfinite(), "B_k of class static (Table 3.1)");
    v.field("A_dynamic", priorA[1], atLeast(0), "A_k of class dynamic (Table 3.1)");
    v.field("B_dynamic", priorB[1], atLeast(0).orInfinite(), "B_k of class dynamic (Table 3.1)");
    v.field("A_invalid", priorA[2], atLeast(0), "A_k of class invalid (Table 3.1)");
    v.field("B_invalid", priorB[2], atLeast(0).orInfinite(), "B_k of class invalid (Table 3.1; inf = veto)");
    PSLAM_FIELD(v, vetoProbability, inLeftOpen(0, 1), "q(c_k|S) of the B = inf classes from which a point is invalid");
    PSLAM_FIELD(v, inverseDepthMin, atLeast(0), "Z_min of the uniform outlier density U (inverse depth, 1/m)");
    PSLAM_FIELD(v, inverseDepthMax,
                satisfies([this](double z) { return std::isfinite(z) && z > inverseDepthMin; },
                          "must be finite and > inverseDepthMin"),
                "Z_max of U (depth >= 0.1 scene units)");
    PSLAM_FIELD(v, probabilityFloor,
                satisfies([](double p) { return p > 0 && p < 1.0 / kNumSemanticClasses; }, "must be in (0, 1/3)"),
                "CNN probabilities are clamped here before -log (half an 8-bit step)");
    PSLAM_FIELD(v, minCount, satisfies([this](double c) { return c > 0 && c < initialCount; }, "must be in (0, initialCount)"),
                "lower bound of a_obs, b_obs after an update (keeps the Beta proper)");
  }
  PSLAM_PARAMS("PointModel")
  /// Uniform outlier density U(d|Z_min, Z_max) (eq. 2.85).
  double uniformDensity() const { return 1.0 / (inverseDepthMax - inverseDepthMin); }
};

/// Per-point state: plain doubles so it can be copied into every map point and serialized as is.
struct KeypointState {
  double mu = 0.0;       ///< mean inverse depth along the z axis of the reference keyframe (eq. 3.1)
  double sigma2 = 1.0;   ///< variance of the inverse depth
  double aObs = 1.0;     ///< geometric inlier counts (eq. 3.18)
  double bObs = 1.0;     ///< geometric outlier counts (eq. 3.19)
  ClassVector semanticNll{0.0, 0.0, 0.0};  ///< sum_i alpha_i * (-ln CNN(c_k|I_i)) (eq. 3.10 in log form)
  std::uint32_t depthUpdates = 0;
  std::uint32_t semanticUpdates = 0;
};

/// The semantic Beta prior of eq. 3.20-3.21 (finite counts) and whether a B = inf class vetoes the point.
struct SemanticPrior {
  double a = 0.0;
  double b = 0.0;
  bool invalid = false;
};

/// Normalized weights of the three branches of the true posterior (eq. 3.12-3.14): inlier, depth outlier,
/// wrong match. They sum to one.
struct UpdateWeights {
  double inlier = 0.0;
  double outlier = 0.0;
  double mismatch = 0.0;
};

/// Moments of the true posterior r(Z, phi) after one measurement (App. A.1.2.2).
struct PosteriorMoments {
  double meanZ = 0.0, secondZ = 0.0, meanPhi = 0.0, secondPhi = 0.0;
};

class KeypointModel {
 public:
  KeypointModel() = default;
  /// Calls params.check().
  explicit KeypointModel(const KeypointModelParams& params);
  const KeypointModelParams& params() const { return params_; }

  /// New point: inverse depth `inverseDepth` with variance `variance`, a_obs = b_obs = initialCount, no class
  /// evidence (the static class, see classPosterior()). Throws pslam::Error on non-finite values or a
  /// non-positive variance.
  KeypointState initialize(double inverseDepth, double variance) const;

  /// Accumulates one semantic observation: classProbabilities = CNN(c_k|I_i) (need not be normalized; they
  /// are clamped at probabilityFloor), weighted by the matching accuracy alpha in [0, 1] (eq. 3.10).
  void addSemanticObservation(KeypointState& state, const ClassVector& classProbabilities, double alpha) const;
  /// The same for evidence that may be absent (no SEMANTIC channel, or [PointModel] semantic = false): nothing then.
  void addSemanticObservation(KeypointState& state, const std::optional<ClassVector>& classProbabilities,
                              double alpha) const;

  /// One depth measurement d (inverse depth) with variance tau2 and matching accuracy alpha in [0, 1]:
  /// eq. 3.11-3.19 with the current semantic prior. Returns the branch weights. Throws pslam::Error on NaN,
  /// tau2 <= 0 or alpha outside [0, 1]; the state is unchanged then.
  UpdateWeights updateDepth(KeypointState& state, double d, double tau2, double alpha) const;

  /// One observation in a new frame (§3.4.2): the semantic evidence first (it sets the prior of this update),
  /// then the depth. All-or-nothing: on a pslam::Error the state is unchanged.
  /// Without class evidence (std::nullopt) it is the depth update alone.
  UpdateWeights observe(KeypointState& state, double d, double tau2, double alpha,
                        const std::optional<ClassVector>& classProbabilities) const;
  UpdateWeights observe(KeypointState& state, double d, double tau2, double alpha,
                        const ClassVector& classProbabilities) const {
    return observe(state, d, tau2, alpha, std::optional<ClassVector>(classProbabilities));
  }

  /// The moments the update matches (exposed for tests and diagnostics).
  PosteriorMoments posteriorMoments(const KeypointState& state, double d, double tau2, double alpha) const;

  /// q(c_k|S) of eq. 3.10 (normalized). Before any class evidence: the static class, exactly. A run without
  /// semantics assumes every point static; its prior (A = 5, B = 0, Table 3.1) then gives a new point
  /// phi = (n + 5) / (2 n + 5), 0.6 = psi_min for n = initialCount = 10: active from birth, as eq. 3.22 says.
  /// (Assumed evidence passed through the probability floor would leave the other classes 0.4 % and the point
  /// just below psi_min, inactive until its first depth update.)
  ClassVector classPosterior(const KeypointState& state) const;
  /// a_sem, b_sem of eq. 3.20-3.21 with the B = inf veto described above.
  SemanticPrior semanticPrior(const KeypointState& state) const;
  /// Counts a = a_obs + a_sem and b = b_obs + b_sem of the combined Beta used in the update.
  void combinedCounts(const KeypointState& state, double& a, double& b) const;
  /// phi of eq. 3.22 (0 for an invalid point).
  double inlierRatio(const KeypointState& state) const;
  /// phi >= psi_min (Table 3.2).
  bool isActive(const KeypointState& state) const;

 private:
  KeypointModelParams params_;
};

/// True when every double of the state is finite, sigma2 > 0 and a_obs, b_obs > 0.
bool isValidState(const KeypointState& state);

}  // namespace pslam::landmarks
