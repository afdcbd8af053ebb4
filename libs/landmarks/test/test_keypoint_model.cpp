// The keypoint model against brute force: every update is compared with the moments of the true posterior of
// App. A.1.2.1 integrated numerically on a grid over (inverse depth Z, inlier ratio phi).
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/landmarks/ActivationSimulation.h"
#include "pslam/landmarks/KeypointModel.h"

using namespace pslam::landmarks;

namespace {

double normalPdf(double x, double mean, double var) {
  return std::exp(-0.5 * (x - mean) * (x - mean) / var) / std::sqrt(2 * M_PI * var);
}
double betaPdf(double phi, double a, double b) {
  return std::exp((a - 1) * std::log(phi) + (b - 1) * std::log1p(-phi) + std::lgamma(a + b) - std::lgamma(a) -
                  std::lgamma(b));
}

struct GridMoments {
  double meanZ = 0, varZ = 0, meanPhi = 0, secondPhi = 0;
};

// r(Z, phi) ∝ [alpha (phi N(d|Z,tau2) + (1-phi) U) + (1-alpha) U] N(Z|mu, sigma2) Beta(phi|a, b), midpoint rule.
GridMoments bruteForcePosterior(double mu, double sigma2, double a, double b, double d, double tau2, double alpha,
                                double uniform) {
  const int nz = 1600, nphi = 1600;
  const double sd = std::sqrt(sigma2);
  const double zLo = std::min(mu, d) - 12 * sd, zHi = std::max(mu, d) + 12 * sd;
  const double dz = (zHi - zLo) / nz, dphi = 1.0 / nphi;
  std::vector<double> likeZ(nz), priorZ(nz), z(nz);
  for (int i = 0; i < nz; ++i) {
    z[i] = zLo + (i + 0.5) * dz;
    priorZ[i] = normalPdf(z[i], mu, sigma2);
    likeZ[i] = normalPdf(d, z[i], tau2);
  }
  double mass = 0, sz = 0, szz = 0, sp = 0, spp = 0;
  for (int j = 0; j < nphi; ++j) {
    const double phi = (j + 0.5) * dphi;
    const double bp = betaPdf(phi, a, b);
    for (int i = 0; i < nz; ++i) {
      const double lik = alpha * (phi * likeZ[i] + (1 - phi) * uniform) + (1 - alpha) * uniform;
      const double w = lik * priorZ[i] * bp;
      mass += w;
      sz += w * z[i];
      szz += w * z[i] * z[i];
      sp += w * phi;
      spp += w * phi * phi;
    }
  }
  GridMoments m;
  m.meanZ = sz / mass;
  m.varZ = szz / mass - m.meanZ * m.meanZ;
  m.meanPhi = sp / mass;
  m.secondPhi = spp / mass;
  return m;
}

struct Case {
  const char* name;
  ClassVector semantic;  // one observation with alpha = 1; negative = none
  double d, tau2, alpha;
};

}  // namespace

TEST(KeypointModel, UpdateMatchesBruteForcePosteriorMoments) {
  const KeypointModel model{KeypointModelParams{}};
  const double mu0 = 0.5, sigma20 = 0.04 * 0.04;
  const std::vector<Case> cases = {
      {"no prior, inlier, alpha 1", {-1, 0, 0}, 0.52, 0.03 * 0.03, 1.0},
      {"no prior, inlier, alpha 0.7", {-1, 0, 0}, 0.47, 0.02 * 0.02, 0.7},
      {"static prior, inlier", {0.9, 0.05, 0.05}, 0.53, 0.03 * 0.03, 0.9},
      {"static prior, outlier", {0.9, 0.05, 0.05}, 2.5, 0.03 * 0.03, 0.9},
      {"dynamic prior, inlier", {0.05, 0.9, 0.05}, 0.49, 0.02 * 0.02, 0.95},
      {"dynamic prior, outlier", {0.05, 0.9, 0.05}, 0.1, 0.02 * 0.02, 0.95},
      {"dynamic prior, weak match", {0.1, 0.8, 0.1}, 0.55, 0.05 * 0.05, 0.3},
      {"invalid prior (veto)", {0.05, 0.05, 0.9}, 0.51, 0.03 * 0.03, 0.8},
      {"mixed prior, 2 sigma", {0.4, 0.4, 0.2}, 0.58, 0.02 * 0.02, 0.6},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    KeypointState s = model.initialize(mu0, sigma20);
    if (c.semantic[0] >= 0) model.addSemanticObservation(s, c.semantic, 1.0);
    double a, b;
    model.combinedCounts(s, a, b);
    const GridMoments g = bruteForcePosterior(s.mu, s.sigma2, a, b, c.d, c.tau2, c.alpha,
                                              model.params().uniformDensity());
    const SemanticPrior prior = model.semanticPrior(s);
    const PosteriorMoments pm = model.posteriorMoments(s, c.d, c.tau2, c.alpha);
    model.updateDepth(s, c.d, c.tau2, c.alpha);
    EXPECT_NEAR(s.mu, g.meanZ, 1e-6);
    EXPECT_NEAR(s.sigma2, g.varZ, 1e-3 * g.varZ);
    EXPECT_NEAR(pm.meanPhi, g.meanPhi, 1e-5);
    EXPECT_NEAR(pm.secondPhi, g.secondPhi, 1e-5);
    // The matched Beta reproduces the first two moments of phi (eq. 3.18-3.19).
    const double a1 = s.aObs + prior.a, b1 = s.bObs + prior.b, n1 = a1 + b1;
    EXPECT_NEAR(a1 / n1, g.meanPhi, 1e-5);
    EXPECT_NEAR(a1 * (a1 + 1) / (n1 * (n1 + 1)), g.secondPhi, 1e-5);
    if (!prior.invalid) {
      EXPECT_NEAR(model.inlierRatio(s), g.meanPhi, 1e-5);
    }
  }
}

TEST(KeypointModel, ZeroMatchingAccuracyLeavesStateUnchanged) {
  const KeypointModel model{KeypointModelParams{}};
  KeypointState s = model.initialize(0.3, 0.01);
  model.addSemanticObservation(s, {0.2, 0.7, 0.1}, 0.9);
  for (double alpha : {0.0, 1e-12}) {
    KeypointState t = s;
    const UpdateWeights w = model.updateDepth(t, 0.31, 1e-4, alpha);
    EXPECT_NEAR(w.mismatch, 1.0, 1e-9);
    EXPECT_NEAR(t.mu, s.mu, 1e-12);
    EXPECT_NEAR(t.sigma2, s.sigma2, 1e-12);
    EXPECT_NEAR(t.aObs, s.aObs, 1e-9);
    EXPECT_NEAR(t.bObs, s.bObs, 1e-9);
  }
  // A semantic observation with alpha = 0 carries no evidence (eq. 3.10).
  KeypointState t = s;
  model.addSemanticObservation(t, {0.0, 0.0, 1.0}, 0.0);
  EXPECT_EQ(model.classPosterior(t), model.classPosterior(s));
}

// Vogiatzis / SVO update written directly from eq. 2.73-2.74, 2.81-2.90 (independent of the library code).
TEST(KeypointModel, AlphaOneWithoutSemanticPriorIsTheVogiatzisModel) {
  KeypointModelParams p;
  p.priorA = {0, 0, 0};
  p.priorB = {0, 0, 0};
  const KeypointModel model(p);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::uniform_real_distribution<double> outlier(0.0, p.inverseDepthMax);
  std::bernoulli_distribution isOutlier(0.3);
  KeypointState s = model.initialize(0.8, 0.2 * 0.2);
  double mu = s.mu, sigma2 = s.sigma2, a = s.aObs, b = s.bObs;
  for (int i = 0; i < 40; ++i) {
    const double d = isOutlier(rng) ? outlier(rng) : 0.5 + noise(rng);
    const double tau2 = 0.03 * 0.03;
    // Reference implementation.
    const double muHat = (tau2 * mu + sigma2 * d) / (sigma2 + tau2);       // eq. 2.73
    const double sigma2Hat = sigma2 * tau2 / (sigma2 + tau2);              // eq. 2.74
    double c1 = a / (a + b) * normalPdf(d, mu, sigma2 + tau2);             // eq. 2.82
    double c2 = b / (a + b) * p.uniformDensity();                          // eq. 2.83
    const double norm = c1 + c2;
    c1 /= norm;
    c2 /= norm;
    const double muNew = c1 * muHat + c2 * mu;                              // eq. 2.81
    const double sigma2New = c1 * (sigma2Hat + muHat * muHat) + c2 * (sigma2 + mu * mu) - muNew * muNew;  // 2.86
    const double f = c1 * (a + 1) / (a + b + 1) + c2 * a / (a + b + 1);                                    // 2.87
    const double e = c1 * (a + 1) * (a + 2) / ((a + b + 1) * (a + b + 2)) +
                     c2 * a * (a + 1) / ((a + b + 1) * (a + b + 2));                                       // 2.88
    const double aNew = (e - f) / (f - e / f);                                                              // 2.89
    const double bNew = aNew / f - aNew;                                                                    // 2.90
    mu = muNew;
    sigma2 = sigma2New;
    a = aNew;
    b = bNew;
    model.updateDepth(s, d, tau2, 1.0);
    ASSERT_NEAR(s.mu, mu, 1e-9 * (1 + std::abs(mu))) << "step " << i;
    ASSERT_NEAR(s.sigma2, sigma2, 1e-7 * sigma2) << "step " << i;
    ASSERT_NEAR(s.aObs, a, 1e-7 * a) << "step " << i;
    ASSERT_NEAR(s.bObs, b, 1e-7 * b) << "step " << i;
  }
  EXPECT_NEAR(s.mu, 0.5, 0.03);  // converged onto the inliers
}

TEST(KeypointModel, ClassPosteriorIsTheWeightedProductOfEq310) {
  const KeypointModel model{KeypointModelParams{}};
  KeypointState s = model.initialize(1.0, 1.0);
  const std::vector<std::pair<ClassVector, double>> obs = {
      {{0.7, 0.2, 0.1}, 0.9}, {{0.5, 0.4, 0.1}, 0.3}, {{0.6, 0.3, 0.1}, 1.0}, {{0.1, 0.8, 0.1}, 0.5}};
  ClassVector product{1, 1, 1};
  for (const auto& [p, alpha] : obs) {
    model.addSemanticObservation(s, p, alpha);
    for (int k = 0; k < 3; ++k) product[k] *= std::pow(p[k], alpha);
  }
  const double sum = product[0] + product[1] + product[2];
  const ClassVector q = model.classPosterior(s);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(q[k], product[k] / sum, 1e-12);
  const SemanticPrior prior = model.semanticPrior(s);
  EXPECT_NEAR(prior.a, 5 * q[0], 1e-12);  // eq. 3.20 with Table 3.1
  EXPECT_NEAR(prior.b, 5 * q[1], 1e-12);  // eq. 3.21; the invalid mass (B = inf) is below the veto
  EXPECT_FALSE(prior.invalid);
}

TEST(KeypointModel, InitializationAndPriorsOfTable31) {
  const KeypointModel model{KeypointModelParams{}};
  KeypointState s = model.initialize(0.5, 0.01);
  EXPECT_EQ(s.aObs, s.bObs);  // a = b (§3.5.5.1)
  // No class evidence yet (a run without semantics never gives any): the static class exactly, a_sem = 5,
  // b_sem = 0, so phi = (10 + 5) / (20 + 5) = psi_min = 0.6 and the point is active from birth (eq. 3.22).
  EXPECT_EQ(model.classPosterior(s), (ClassVector{1, 0, 0}));
  EXPECT_EQ(model.inlierRatio(s), model.params().psiMin);
  EXPECT_TRUE(model.isActive(s));
  KeypointState st = s, dy = s, inv = s;
  model.addSemanticObservation(st, {1, 0, 0}, 1.0);
  model.addSemanticObservation(dy, {0, 1, 0}, 1.0);
  model.addSemanticObservation(inv, {0, 0, 1}, 1.0);
  // A one-hot static label goes through the probability floor (1/510): the other classes keep 0.4 % and the
  // point sits just below psi_min until its first depth update.
  EXPECT_GT(model.inlierRatio(st), 0.599);
  EXPECT_LT(model.inlierRatio(st), model.params().psiMin);
  // Absent evidence adds nothing.
  KeypointState none = s;
  model.addSemanticObservation(none, std::optional<ClassVector>{}, 1.0);
  EXPECT_EQ(none.semanticUpdates, 0u);
  EXPECT_EQ(none.semanticNll, s.semanticNll);
  EXPECT_NEAR(model.semanticPrior(st).a, 5.0, 0.05);
  EXPECT_NEAR(model.semanticPrior(dy).b, 5.0, 0.05);
  EXPECT_GT(model.inlierRatio(st), 0.5);
  EXPECT_LT(model.inlierRatio(dy), 0.5);
  EXPECT_TRUE(model.semanticPrior(inv).invalid);
  EXPECT_EQ(model.inlierRatio(inv), 0.0);
  EXPECT_FALSE(model.isActive(inv));
  // An invalid point still tracks its depth with finite numbers.
  for (int i = 0; i < 20; ++i) model.updateDepth(inv, 0.5, 1e-4, 1.0);
  EXPECT_TRUE(isValidState(inv));
  EXPECT_FALSE(model.isActive(inv));
}

TEST(KeypointModel, RejectsBadMeasurementsWithoutChangingTheState) {
  const KeypointModel model{KeypointModelParams{}};
  KeypointState s = model.initialize(0.5, 0.01);
  const KeypointState before = s;
  EXPECT_THROW(model.updateDepth(s, std::nan(""), 1e-4, 1.0), pslam::Error);
  EXPECT_THROW(model.updateDepth(s, 0.5, 0.0, 1.0), pslam::Error);
  EXPECT_THROW(model.updateDepth(s, 0.5, 1e-4, 1.5), pslam::Error);
  EXPECT_THROW(model.addSemanticObservation(s, {0.5, std::nan(""), 0.1}, 1.0), pslam::Error);
  EXPECT_THROW(model.initialize(0.5, -1), pslam::Error);
  EXPECT_THROW(model.observe(s, 0.5, -1.0, 0.9, {0.8, 0.1, 0.1}), pslam::Error);  // semantic part not kept
  EXPECT_EQ(s.mu, before.mu);
  EXPECT_EQ(s.aObs, before.aObs);
  EXPECT_EQ(s.semanticUpdates, 0u);
  // observe() = semantic observation, then depth update.
  KeypointState x = s, y = s;
  model.observe(x, 0.52, 1e-4, 0.9, {0.8, 0.1, 0.1});
  model.addSemanticObservation(y, {0.8, 0.1, 0.1}, 0.9);
  model.updateDepth(y, 0.52, 1e-4, 0.9);
  EXPECT_EQ(x.mu, y.mu);
  EXPECT_EQ(x.aObs, y.aObs);
  EXPECT_EQ(x.bObs, y.bObs);
  EXPECT_EQ(x.semanticNll, y.semanticNll);
}

TEST(KeypointModel, LongRandomSequencesStayFiniteAndPositive) {
  const KeypointModel model{KeypointModelParams{}};
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> logTau(-12.0, 3.0);
  std::uniform_real_distribution<double> wide(-5.0, 50.0);
  for (int point = 0; point < 200; ++point) {
    KeypointState s = model.initialize(unit(rng) * 5, std::pow(10.0, logTau(rng)));
    for (int i = 0; i < 500; ++i) {
      ClassVector p{unit(rng), unit(rng), unit(rng)};
      if (unit(rng) < 0.2) p = {0, 0, 0}, p[int(unit(rng) * 3) % 3] = 1;  // one-hot labels with hard zeros
      model.addSemanticObservation(s, p, unit(rng));
      const double d = unit(rng) < 0.5 ? s.mu + 0.01 * (unit(rng) - 0.5) : wide(rng);
      const double alpha = unit(rng) < 0.1 ? (unit(rng) < 0.5 ? 0.0 : 1.0) : unit(rng);
      model.updateDepth(s, d, std::pow(10.0, logTau(rng)), alpha);
      ASSERT_TRUE(isValidState(s)) << "point " << point << " step " << i;
      const double phi = model.inlierRatio(s);
      ASSERT_TRUE(std::isfinite(phi) && phi >= 0 && phi <= 1);
      double a, b;
      model.combinedCounts(s, a, b);
      ASSERT_TRUE(std::isfinite(a) && std::isfinite(b) && a > 0 && b > 0);
    }
  }
}

// Figure 3.4: consistent depth measurements activate a dynamic-prior point after several observations, a
// static-prior point sooner, and a point with inconsistent measurements never.
TEST(KeypointModel, Figure34ActivationOrder) {
  const KeypointModel model{KeypointModelParams{}};
  auto observationsToActivate = [&](const ClassVector& cnn, bool consistent) {
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 0.02);
    std::uniform_real_distribution<double> anywhere(0.0, model.params().inverseDepthMax);
    KeypointState s = model.initialize(0.5 + noise(rng), 0.1 * 0.1);
    for (int i = 1; i <= 60; ++i) {
      model.addSemanticObservation(s, cnn, 0.9);
      model.updateDepth(s, consistent ? 0.5 + noise(rng) : anywhere(rng), 0.02 * 0.02, 0.9);
      if (model.isActive(s)) return i;
    }
    return -1;
  };
  const ClassVector staticCnn{0.9, 0.05, 0.05}, dynamicCnn{0.05, 0.9, 0.05};
  const int nStatic = observationsToActivate(staticCnn, true);
  const int nDynamic = observationsToActivate(dynamicCnn, true);
  EXPECT_GE(nStatic, 1);
  EXPECT_GT(nDynamic, nStatic);
  EXPECT_GE(nDynamic, 3);  // "several observations"
  EXPECT_EQ(observationsToActivate(staticCnn, false), -1);
  EXPECT_EQ(observationsToActivate(dynamicCnn, false), -1);
}

TEST(KeypointModelParams, LoadsTable31WithInfinityAndChecksKeys) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("pm", "A_static", "4");
  cfg.write("pm", "B_invalid", "inf");
  cfg.write("pm", "psiMin", "0.7");
  KeypointModelParams p;
  p.loadFromConfigFile(cfg, "pm");
  EXPECT_EQ(p.priorA[0], 4.0);
  EXPECT_TRUE(std::isinf(p.priorB[2]));
  EXPECT_EQ(p.psiMin, 0.7);
  mrpt::config::CConfigFileMemory saved;
  p.saveToConfigFile(saved, "x");
  KeypointModelParams q;
  q.loadFromConfigFile(saved, "x");
  EXPECT_TRUE(std::isinf(q.priorB[2]));
  EXPECT_EQ(q.priorA[0], 4.0);

  cfg.write("pm", "B_dynamic", "lots");
  try {
    p.loadFromConfigFile(cfg, "pm");
    FAIL() << "expected an error";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("B_dynamic"), std::string::npos);
  }
  cfg.write("pm", "B_dynamic", "5");
  cfg.write("pm", "psiMin", "1.5");
  try {
    p.loadFromConfigFile(cfg, "pm");
    FAIL() << "expected an error";
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("psiMin"), std::string::npos);
  }
}

// The same experiment through the simulation used for doc/img/semantic_fig34.png, over several seeds.
TEST(ActivationSimulation, Figure34OrderHoldsOverSeeds) {
  const KeypointModel model{KeypointModelParams{}};
  for (unsigned seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE(seed);
    ActivationScenario st, dy, bad;
    st.cnn = {0.9, 0.05, 0.05};
    dy.cnn = {0.05, 0.9, 0.05};
    bad.cnn = st.cnn;
    bad.consistent = false;
    std::mt19937 r1(seed), r2(seed), r3(seed);
    const auto sSteps = simulateActivation(model, st, r1);
    const auto dSteps = simulateActivation(model, dy, r2);
    const auto bSteps = simulateActivation(model, bad, r3);
    ASSERT_EQ(sSteps.size(), 31u);
    const int ns = firstActiveObservation(sSteps), nd = firstActiveObservation(dSteps);
    EXPECT_GE(ns, 0);
    EXPECT_GT(nd, ns);
    EXPECT_GE(nd, 3);
    EXPECT_EQ(firstActiveObservation(bSteps), -1);
    // With consistent measurements the inlier ratio of the dynamic-prior point rises monotonically-ish:
    // its last value is well above its first.
    EXPECT_GT(dSteps.back().inlierRatio, dSteps.front().inlierRatio + 0.2);
  }
}
