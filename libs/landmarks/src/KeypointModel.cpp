#include "pslam/landmarks/KeypointModel.h"

#include <algorithm>
#include <cmath>

#include "pslam/core/Error.h"

namespace pslam::landmarks {
namespace {

double logNormalPdf(double x, double mean, double variance) {
  const double r = x - mean;
  return -0.5 * (std::log(2.0 * M_PI * variance) + r * r / variance);
}

void requireFinite(double v, const std::string& what) {
  if (!std::isfinite(v)) throw Error("KeypointModel: " + what + " is not finite");
}

void requireAccuracy(double alpha) {
  if (!(alpha >= 0.0 && alpha <= 1.0))
    throw Error("KeypointModel: matching accuracy alpha must be in [0, 1], got " + std::to_string(alpha));
}

}  // namespace

PSLAM_DEFINE_PARAMS(KeypointModelParams)

KeypointModel::KeypointModel(const KeypointModelParams& params) : params_(params) { params_.check(); }

KeypointState KeypointModel::initialize(double inverseDepth, double variance) const {
  requireFinite(inverseDepth, "initial inverse depth");
  if (!(std::isfinite(variance) && variance > 0))
    throw Error("KeypointModel: initial inverse-depth variance must be finite and > 0");
  KeypointState s;
  s.mu = inverseDepth;
  s.sigma2 = variance;
  s.aObs = s.bObs = params_.initialCount;  // a = b: inlier ratio 0.5 before any evidence (§3.5.5.1)
  return s;
}

void KeypointModel::addSemanticObservation(KeypointState& state, const ClassVector& classProbabilities,
                                           double alpha) const {
  requireAccuracy(alpha);
  for (int k = 0; k < kNumSemanticClasses; ++k) {
    const double p = classProbabilities[k];
    if (!(p >= 0.0 && p <= 1.0))
      throw Error("KeypointModel: class probability " + std::to_string(k) + " must be in [0, 1]");
  }
  // eq. 3.10 in log form: q(c_k|S) ∝ prod_i CNN(c_k|I_i)^alpha_i. The floor keeps a single hard 0 of a
  // one-hot label from making a class impossible forever.
  for (int k = 0; k < kNumSemanticClasses; ++k)
    state.semanticNll[k] += -alpha * std::log(std::max(classProbabilities[k], params_.probabilityFloor));
  ++state.semanticUpdates;
}

void KeypointModel::addSemanticObservation(KeypointState& state, const std::optional<ClassVector>& classProbabilities,
                                           double alpha) const {
  if (classProbabilities) addSemanticObservation(state, *classProbabilities, alpha);
}

ClassVector KeypointModel::classPosterior(const KeypointState& state) const {
  if (state.semanticUpdates == 0) return {1.0, 0.0, 0.0};  // no evidence: static (see the header)
  // Softmax of -NLL, shifted by the minimum so the largest term is exp(0) = 1 (no underflow to 0/0).
  const double minNll = *std::min_element(state.semanticNll.begin(), state.semanticNll.end());
  ClassVector q{};
  double sum = 0.0;
  for (int k = 0; k < kNumSemanticClasses; ++k) sum += (q[k] = std::exp(-(state.semanticNll[k] - minNll)));
  for (double& v : q) v /= sum;
  return q;
}

SemanticPrior KeypointModel::semanticPrior(const KeypointState& state) const {
  const ClassVector q = classPosterior(state);
  SemanticPrior prior;
  double vetoMass = 0.0;
  for (int k = 0; k < kNumSemanticClasses; ++k) {
    prior.a += params_.priorA[k] * q[k];  // eq. 3.20
    if (std::isinf(params_.priorB[k]))
      vetoMass += q[k];  // B_k = inf: Beta(phi|A_k, inf) is a point mass at phi = 0
    else
      prior.b += params_.priorB[k] * q[k];  // eq. 3.21
  }
  prior.invalid = vetoMass >= params_.vetoProbability;
  if (prior.invalid) prior.a = prior.b = 0.0;  // the update then runs on the geometric counts alone
  return prior;
}

void KeypointModel::combinedCounts(const KeypointState& state, double& a, double& b) const {
  const SemanticPrior prior = semanticPrior(state);
  a = state.aObs + prior.a;
  b = state.bObs + prior.b;
}

double KeypointModel::inlierRatio(const KeypointState& state) const {
  const SemanticPrior prior = semanticPrior(state);
  if (prior.invalid) return 0.0;
  const double a = state.aObs + prior.a, b = state.bObs + prior.b;
  return a / (a + b);  // eq. 3.22
}

bool KeypointModel::isActive(const KeypointState& state) const { return inlierRatio(state) >= params_.psiMin; }

namespace {

struct Branches {
  UpdateWeights w;
  double m = 0.0, s2 = 0.0;  // simple Gaussian update (eq. 2.73-2.74)
  double a = 0.0, b = 0.0;   // combined Beta counts before the update
};

Branches computeBranches(const KeypointModelParams& p, const KeypointModel& model, const KeypointState& state,
                         double d, double tau2, double alpha) {
  requireFinite(d, "measured inverse depth");
  if (!(std::isfinite(tau2) && tau2 > 0)) throw Error("KeypointModel: measurement variance tau2 must be > 0");
  requireAccuracy(alpha);
  Branches br;
  model.combinedCounts(state, br.a, br.b);
  // eq. 3.12-3.14 in log space, normalized by their maximum so that a far outlier (N underflows) still gives
  // finite weights. U is the constant density of eq. 2.85 (as SVO, also for d outside [Z_min, Z_max]).
  const double logU = std::log(p.uniformDensity());
  const double logInlierRatio = std::log(br.a / (br.a + br.b));
  const double logOutlierRatio = std::log(br.b / (br.a + br.b));
  const double negInf = -std::numeric_limits<double>::infinity();
  const double l1 = alpha > 0 ? std::log(alpha) + logInlierRatio + logNormalPdf(d, state.mu, state.sigma2 + tau2)
                              : negInf;
  const double l2 = alpha > 0 ? std::log(alpha) + logOutlierRatio + logU : negInf;
  const double l3 = alpha < 1 ? std::log1p(-alpha) + logU : negInf;
  const double lmax = std::max({l1, l2, l3});
  const double c1 = std::exp(l1 - lmax), c2 = std::exp(l2 - lmax), c3 = std::exp(l3 - lmax);
  const double sum = c1 + c2 + c3;
  br.w = {c1 / sum, c2 / sum, c3 / sum};
  // Simple Gaussian posterior (eq. 2.73-2.74), written as s^2 = (1/sigma^2 + 1/tau^2)^-1 of App. A.1.2.1.
  br.s2 = state.sigma2 * tau2 / (state.sigma2 + tau2);
  br.m = br.s2 * (state.mu / state.sigma2 + d / tau2);
  return br;
}

}  // namespace

PosteriorMoments KeypointModel::posteriorMoments(const KeypointState& state, double d, double tau2,
                                                 double alpha) const {
  const Branches br = computeBranches(params_, *this, state, d, tau2, alpha);
  const double a = br.a, b = br.b, n = a + b;
  const double keep = br.w.outlier + br.w.mismatch;
  PosteriorMoments m;
  m.meanZ = br.w.inlier * br.m + keep * state.mu;  // eq. 3.11
  m.secondZ = br.w.inlier * (br.s2 + br.m * br.m) + keep * (state.sigma2 + state.mu * state.mu);
  m.meanPhi = br.w.inlier * (a + 1) / (n + 1) + br.w.outlier * a / (n + 1) + br.w.mismatch * a / n;  // eq. 3.16
  m.secondPhi = br.w.inlier * (a + 1) * (a + 2) / ((n + 1) * (n + 2)) +
                br.w.outlier * a * (a + 1) / ((n + 1) * (n + 2)) +
                br.w.mismatch * a * (a + 1) / (n * (n + 1));  // eq. 3.17
  return m;
}

UpdateWeights KeypointModel::updateDepth(KeypointState& state, double d, double tau2, double alpha) const {
  const Branches br = computeBranches(params_, *this, state, d, tau2, alpha);
  const SemanticPrior prior = semanticPrior(state);
  const double a = br.a, b = br.b;
  const double wIn = br.w.inlier, wKeep = br.w.outlier + br.w.mismatch;

  // Gaussian moments (eq. 3.11, 3.15). The variance is written as the law of total variance
  // sum_k w_k var_k + sum_k w_k (mean_k - mean)^2, which equals E[Z^2] - E[Z]^2 but cannot go negative.
  const double mu = wIn * br.m + wKeep * state.mu;
  const double dm = br.m - state.mu;
  const double sigma2 = wIn * br.s2 + wKeep * state.sigma2 + wIn * wKeep * dm * dm;

  // Beta moments (eq. 3.16-3.17), again as a law of total variance over the three Beta components.
  struct Component {
    double w, a, b;
  };
  const Component comps[3] = {{br.w.inlier, a + 1, b}, {br.w.outlier, a, b + 1}, {br.w.mismatch, a, b}};
  double f = 0.0;
  for (const auto& c : comps) f += c.w * c.a / (c.a + c.b);
  double var = 0.0;
  for (const auto& c : comps) {
    const double cn = c.a + c.b, cm = c.a / cn;
    var += c.w * (cm * (1 - cm) / (cn + 1) + (cm - f) * (cm - f));
  }
  // eq. 3.18-3.19 (A.1.2.3): a' = f (f - e)/(e - f^2), b' = (f - e)(1 - f)/(e - f^2), with e - f^2 = var and
  // f - e = f (1 - f) - var.
  double aNew, bNew;
  const double fMinusE = f * (1 - f) - var;
  if (var > 0 && fMinusE > 0 && std::isfinite(var)) {
    aNew = f * fMinusE / var;
    bNew = fMinusE * (1 - f) / var;
  } else {
    // Only reachable through rounding with huge counts: fall back to the expected count increments.
    aNew = a + br.w.inlier;
    bNew = b + br.w.outlier;
  }
  // The semantic counts are recomputed from q(c|S) at every step (eq. 3.20-3.21), so the geometric part keeps
  // the rest of the matched counts.
  state.mu = mu;
  state.sigma2 = std::max(sigma2, std::numeric_limits<double>::min());
  state.aObs = std::max(aNew - prior.a, params_.minCount);
  state.bObs = std::max(bNew - prior.b, params_.minCount);
  ++state.depthUpdates;
  return br.w;
}

UpdateWeights KeypointModel::observe(KeypointState& state, double d, double tau2, double alpha,
                                    const std::optional<ClassVector>& classProbabilities) const {
  KeypointState next = state;
  addSemanticObservation(next, classProbabilities, alpha);
  const UpdateWeights w = updateDepth(next, d, tau2, alpha);
  state = next;
  return w;
}

bool isValidState(const KeypointState& s) {
  bool ok = std::isfinite(s.mu) && std::isfinite(s.sigma2) && s.sigma2 > 0 && std::isfinite(s.aObs) &&
            s.aObs > 0 && std::isfinite(s.bObs) && s.bObs > 0;
  for (double v : s.semanticNll) ok = ok && std::isfinite(v) && v >= 0;
  return ok;
}

}  // namespace pslam::landmarks
