// Sim(3) pose graph (essential graph of loop closing): the edge residual is the documented 7-vector of the error
// similarity and its automatic Jacobian agrees with central differences through the quaternion manifold; the
// ground truth is a fixed point; a loop of 30 keyframes with injected yaw and scale drift is pulled back onto the
// truth by one loop edge; fixed and unused vertices keep their bits; bad input is refused naming the culprit; two
// runs give the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>

#include "pslam/core/Error.h"
#include "pslam/optimize/PoseGraph.h"

using pslam::geometry::Sim3;
using namespace pslam::optimize;

namespace {

constexpr double kDeg = M_PI / 180.0;
using Poses = std::map<std::uint64_t, Sim3>;
using Vector7d = Eigen::Matrix<double, 7, 1>;

Eigen::Matrix3d rot(double angleRad, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angleRad, axis.normalized()).toRotationMatrix();
}

Eigen::Vector3d randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

Sim3 randomSim3(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return {std::exp(0.5 * u(rng)), rot(M_PI * u(rng), randomUnit(rng)), 3.0 * Eigen::Vector3d(u(rng), u(rng), u(rng))};
}

/// A small random similarity: rotation of `rotSigma` rad, translation of `tSigma`, log-scale of `logSSigma`.
Sim3 noiseSim3(std::mt19937& rng, double rotSigma, double tSigma, double logSSigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  return {std::exp(logSSigma * n(rng)), rot(rotSigma * n(rng), randomUnit(rng)),
          tSigma * Eigen::Vector3d(n(rng), n(rng), n(rng))};
}

/// The camera centre in the world of a world-to-camera similarity: S_cw^-1 (0) = -R^T t / s.
Eigen::Vector3d centre(const Sim3& S_cw) { return -(S_cw.R.transpose() * S_cw.t) / S_cw.s; }

double maxCentreError(const Poses& poses, const Poses& truth) {
  double e = 0.0;
  for (const auto& [id, S] : truth) e = std::max(e, (centre(poses.at(id)) - centre(S)).norm());
  return e;
}

bool sameBits(const Sim3& a, const Sim3& b) {
  return std::memcmp(&a.s, &b.s, sizeof(double)) == 0 && std::memcmp(a.R.data(), b.R.data(), 9 * sizeof(double)) == 0 &&
         std::memcmp(a.t.data(), b.t.data(), 3 * sizeof(double)) == 0;
}

double sim3Distance(const Sim3& a, const Sim3& b) {
  return std::abs(a.s - b.s) + (a.R - b.R).norm() + (a.t - b.t).norm();
}

PoseGraphEdge edgeFromTruth(const Poses& truth, std::uint64_t i, std::uint64_t j) {
  PoseGraphEdge e;
  e.i = i;
  e.j = j;
  e.S_ij = truth.at(i) * truth.at(j).inverse();
  return e;
}

/// The loop closing scenario: `n` keyframes on a circle of radius 10 (scale 1, camera forward along the
/// tangent, y down), odometry edges k -> k+1 from the truth with small noise, initial poses composed from the
/// odometry with a yaw error of `yawDriftDeg` and a scale factor of `scaleDrift` per step (monocular drift), and one
/// loop edge (n-1) -> 0 from the truth, last in `edges`.
struct DriftedLoop {
  Poses truth, initial;
  std::vector<PoseGraphEdge> edges;
};

DriftedLoop makeDriftedLoop(int n = 30, double yawDriftDeg = 0.5, double scaleDrift = 1.01, unsigned seed = 7) {
  std::mt19937 rng(seed);
  DriftedLoop d;
  for (int k = 0; k < n; ++k) {
    const double th = 2.0 * M_PI * k / n;
    const Eigen::Vector3d c(10.0 * std::cos(th), 10.0 * std::sin(th), 0.5 * std::sin(3.0 * th));
    Eigen::Matrix3d R_wc;
    R_wc.col(2) = Eigen::Vector3d(-std::sin(th), std::cos(th), 0.0);  // forward: the tangent
    R_wc.col(1) = Eigen::Vector3d(0.0, 0.0, -1.0);                    // down
    R_wc.col(0) = R_wc.col(1).cross(R_wc.col(2));                     // right: outwards
    d.truth[static_cast<std::uint64_t>(k)] = Sim3(1.0, R_wc.transpose(), -(R_wc.transpose() * c));
  }
  d.initial[0] = d.truth.at(0);
  const Sim3 drift(scaleDrift, rot(yawDriftDeg * kDeg, Eigen::Vector3d::UnitY()), Eigen::Vector3d::Zero());
  for (int k = 0; k + 1 < n; ++k) {
    const auto i = static_cast<std::uint64_t>(k), j = i + 1;
    PoseGraphEdge e = edgeFromTruth(d.truth, i, j);
    e.S_ij = e.S_ij * noiseSim3(rng, 0.05 * kDeg, 0.005, 0.001);
    d.edges.push_back(e);
    // S_jw = S_ji * S_iw with the drift applied in frame j.
    d.initial[j] = drift * e.S_ij.inverse() * d.initial.at(i);
  }
  d.edges.push_back(edgeFromTruth(d.truth, static_cast<std::uint64_t>(n - 1), 0));
  return d;
}

}  // namespace

// ---------------------------------------------------------------------------------------------- residual

TEST(Sim3PoseGraph, ResidualIsTheDocumentedErrorVector) {
  std::mt19937 rng(1);
  const Sim3 S_iw = randomSim3(rng), S_jw = randomSim3(rng);
  // A known error E = S_ij^-1 * S_iw * S_jw^-1, i.e. S_ij = S_iw * S_jw^-1 * E^-1.
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1.0, 0.2).normalized();
  const Eigen::Vector3d t_E(0.1, -0.2, 0.3);
  const Sim3 E(1.1, rot(0.25, axis), t_E);
  PoseGraphEdge edge;
  edge.i = 3;
  edge.j = 8;
  edge.S_ij = S_iw * S_jw.inverse() * E.inverse();
  edge.weight = 4.0;
  Vector7d expected;
  expected << 0.25 * axis, t_E, std::log(1.1);
  EXPECT_LT((sim3EdgeResidual(edge, S_iw, S_jw) - 2.0 * expected).norm(), 1e-12) << sim3EdgeResidual(edge, S_iw, S_jw);
  // An error rotation beyond pi/2 (quaternion with w < 0 for one sign): the angle stays the shorter one.
  const Sim3 E2(1.0, rot(2.5, axis), Eigen::Vector3d::Zero());
  edge.S_ij = S_iw * S_jw.inverse() * E2.inverse();
  EXPECT_LT((sim3EdgeResidual(edge, S_iw, S_jw).head<3>() - 2.0 * 2.5 * axis).norm(), 1e-9);
  const Sim3 E3(1.0, rot(-2.5, axis), Eigen::Vector3d::Zero());
  edge.S_ij = S_iw * S_jw.inverse() * E3.inverse();
  EXPECT_LT((sim3EdgeResidual(edge, S_iw, S_jw).head<3>() + 2.0 * 2.5 * axis).norm(), 1e-9);
  // No error at the measurement.
  edge.S_ij = S_iw * S_jw.inverse();
  EXPECT_LT(sim3EdgeResidual(edge, S_iw, S_jw).norm(), 1e-12);
}

TEST(Sim3PoseGraph, JacobianAgreesWithCentralDifferences) {
  std::mt19937 rng(2);
  for (const double errorScale : {0.0, 0.02, 1.0}) {
    const Sim3 S_iw = randomSim3(rng), S_jw = randomSim3(rng);
    // The measurement off by a random error whose size is `errorScale` (0: at the truth).
    const Sim3 S_ij =
        S_iw * S_jw.inverse() * noiseSim3(rng, 0.5 * errorScale, 0.5 * errorScale, 0.2 * errorScale);
    const std::unique_ptr<ceres::CostFunction> cost(newSim3EdgeCostFunction(S_ij, 2.5));
    ceres::EigenQuaternionManifold quaternion;
    const std::vector<const ceres::Manifold*> manifolds{&quaternion, nullptr, nullptr, &quaternion, nullptr, nullptr};
    ceres::NumericDiffOptions nd;
    nd.relative_step_size = 1e-6;
    ceres::GradientChecker checker(cost.get(), &manifolds, nd);

    Eigen::Quaterniond qi(S_iw.R), qj(S_jw.R);
    double ti[3] = {S_iw.t.x(), S_iw.t.y(), S_iw.t.z()}, tj[3] = {S_jw.t.x(), S_jw.t.y(), S_jw.t.z()};
    double li = std::log(S_iw.s), lj = std::log(S_jw.s);
    const double* blocks[] = {qi.coeffs().data(), ti, &li, qj.coeffs().data(), tj, &lj};
    ceres::GradientChecker::ProbeResults results;
    checker.Probe(blocks, 1e-6, &results);
    ASSERT_TRUE(results.return_value);
    const std::vector<int> tangentSizes{3, 3, 1, 3, 3, 1};
    for (std::size_t b = 0; b < tangentSizes.size(); ++b) {
      const Eigen::MatrixXd& J = results.local_jacobians.at(b);
      const Eigen::MatrixXd& Jn = results.local_numeric_jacobians.at(b);
      ASSERT_EQ(J.rows(), 7);
      ASSERT_EQ(J.cols(), tangentSizes[b]);
      // Absolute floor: at zero error many entries are exactly 0 and a relative test divides rounding by them.
      EXPECT_LT((J - Jn).cwiseAbs().maxCoeff(), 1e-6 * std::max(1.0, J.cwiseAbs().maxCoeff()))
          << "error scale " << errorScale << ", block " << b << "\n" << J << "\n\n" << Jn;
      EXPECT_GT(J.norm(), 0.1) << "block " << b;  // every block takes part
    }
  }
}

// ---------------------------------------------------------------------------------------------- optimization

TEST(Sim3PoseGraph, TheGroundTruthIsAFixedPoint) {
  std::mt19937 rng(3);
  Poses truth;
  for (std::uint64_t id = 10; id < 22; ++id) truth[id] = randomSim3(rng);
  std::vector<PoseGraphEdge> edges;
  for (std::uint64_t id = 10; id + 1 < 22; ++id) edges.push_back(edgeFromTruth(truth, id, id + 1));
  std::uniform_int_distribution<std::uint64_t> pick(10, 21);
  while (edges.size() < 25) {
    const std::uint64_t i = pick(rng), j = pick(rng);
    if (i != j) edges.push_back(edgeFromTruth(truth, i, j));
  }
  Poses poses = truth;
  const PoseGraphResult r = optimizeSim3PoseGraph(poses, {10}, edges, {});
  ASSERT_TRUE(r.usable);
  EXPECT_EQ(r.freeVertices, 11);
  EXPECT_LT(r.initialCost, 1e-20);
  EXPECT_LT(r.finalCost, 1e-20);
  for (const auto& [id, S] : truth) EXPECT_LT(sim3Distance(poses.at(id), S), 1e-12) << "vertex " << id;
}

TEST(Sim3PoseGraph, OneLoopEdgeRemovesTheDriftOfALoop) {
  const DriftedLoop d = makeDriftedLoop();
  Poses poses = d.initial;
  const double initialError = maxCentreError(poses, d.truth);
  const PoseGraphEdge& loop = d.edges.back();
  const double initialLoopResidual = sim3EdgeResidual(loop, poses.at(loop.i), poses.at(loop.j)).norm();
  ASSERT_GT(initialError, 3.0);  // the drift is visible: metres on a circle of radius 10
  ASSERT_GT(initialLoopResidual, 0.3);

  const PoseGraphResult r = optimizeSim3PoseGraph(poses, {0}, d.edges, {});
  ASSERT_TRUE(r.usable);
  EXPECT_GE(r.iterations, 1);
  EXPECT_LE(r.iterations, PoseGraphParams{}.maxIterations);
  EXPECT_LT(r.finalCost, 1e-3 * r.initialCost);

  const double finalError = maxCentreError(poses, d.truth);
  const double finalLoopResidual = sim3EdgeResidual(loop, poses.at(loop.i), poses.at(loop.j)).norm();
  RecordProperty("initial_max_centre_error", std::to_string(initialError));
  RecordProperty("final_max_centre_error", std::to_string(finalError));
  EXPECT_LT(finalError, initialError / 5.0) << "initial " << initialError << ", final " << finalError;
  EXPECT_LT(finalError, 0.1);  // the odometry noise's level, not the drift's
  EXPECT_LT(finalLoopResidual, 0.01) << "initial " << initialLoopResidual;
  for (const auto& [id, S] : poses) EXPECT_NEAR(S.s, 1.0, 0.01) << "vertex " << id;  // the scale drift is undone
}

TEST(Sim3PoseGraph, FixedAndUnusedVerticesKeepTheirBits) {
  const DriftedLoop d = makeDriftedLoop();
  Poses poses = d.initial;
  std::mt19937 rng(4);
  poses[100] = randomSim3(rng);  // in no edge
  const Poses before = poses;
  const PoseGraphResult r = optimizeSim3PoseGraph(poses, {0, 15, 4242}, d.edges, {});  // 4242: no vertex, ignored
  ASSERT_TRUE(r.usable);
  EXPECT_EQ(r.freeVertices, 28);
  EXPECT_TRUE(sameBits(poses.at(0), before.at(0)));
  EXPECT_TRUE(sameBits(poses.at(15), before.at(15)));
  EXPECT_TRUE(sameBits(poses.at(100), before.at(100)));
  EXPECT_EQ(poses.count(4242), 0u);
  EXPECT_GT(sim3Distance(poses.at(29), before.at(29)), 0.1);  // the others moved
  EXPECT_LT(r.finalCost, r.initialCost);
}

TEST(Sim3PoseGraph, IterationsAreLimited) {
  const DriftedLoop d = makeDriftedLoop();
  Poses poses = d.initial;
  PoseGraphParams params;
  params.maxIterations = 1;
  const PoseGraphResult r = optimizeSim3PoseGraph(poses, {0}, d.edges, params);
  EXPECT_EQ(r.iterations, 1);
}

TEST(Sim3PoseGraph, HuberLossActsOnTheNormOfTheWholeResidual) {
  // One edge between two fixed vertices: the reported cost is Ceres' 1/2 rho(|r|^2) of the edge's 7-vector.
  const DriftedLoop d = makeDriftedLoop(4);
  Poses poses = d.initial;
  const PoseGraphEdge& e = d.edges.back();
  const double norm = sim3EdgeResidual(e, poses.at(e.i), poses.at(e.j)).norm();
  PoseGraphParams params;
  params.huberDelta = 0.5 * norm;  // in the linear part
  const PoseGraphResult r = optimizeSim3PoseGraph(poses, {e.i, e.j}, {e}, params);
  const double delta = params.huberDelta;
  EXPECT_NEAR(r.finalCost, 0.5 * (2.0 * delta * norm - delta * delta), 1e-12);
  params.huberDelta = 2.0 * norm;  // in the quadratic part
  EXPECT_NEAR(optimizeSim3PoseGraph(poses, {e.i, e.j}, {e}, params).finalCost, 0.5 * norm * norm, 1e-12);
}

TEST(Sim3PoseGraph, IsDeterministic) {
  DriftedLoop d = makeDriftedLoop();
  d.edges.push_back(edgeFromTruth(d.truth, 5, 12));
  d.edges.back().weight = 3.0;
  Poses a = d.initial, b = d.initial;
  PoseGraphParams params;
  params.huberDelta = 1.0;
  const PoseGraphResult ra = optimizeSim3PoseGraph(a, {0}, d.edges, params);
  const PoseGraphResult rb = optimizeSim3PoseGraph(b, {0}, d.edges, params);
  EXPECT_EQ(std::memcmp(&ra.finalCost, &rb.finalCost, sizeof(double)), 0);
  EXPECT_EQ(ra.iterations, rb.iterations);
  for (const auto& [id, S] : a) EXPECT_TRUE(sameBits(S, b.at(id))) << "vertex " << id;
}

// ---------------------------------------------------------------------------------------------- bad input

namespace {
template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const pslam::Error& e) {
    return e.what();
  }
  return "(no pslam::Error thrown)";
}
}  // namespace

TEST(Sim3PoseGraph, RefusesBadInputNamingIt) {
  const DriftedLoop d = makeDriftedLoop(6);
  Poses poses = d.initial;
  const Poses before = poses;
  auto run = [&](const std::set<std::uint64_t>& fixed, const std::vector<PoseGraphEdge>& edges) {
    return [&, fixed, edges] { optimizeSim3PoseGraph(poses, fixed, edges, {}); };
  };
  auto withEdge = [&](const PoseGraphEdge& e) {
    std::vector<PoseGraphEdge> edges = d.edges;
    edges.push_back(e);
    return edges;
  };

  PoseGraphEdge unknown = edgeFromTruth(d.truth, 2, 3);
  unknown.j = 999;
  const std::string unknownJ = errorOf(run({0}, withEdge(unknown)));
  EXPECT_NE(unknownJ.find("999"), std::string::npos) << unknownJ;
  unknown.i = 998;
  unknown.j = 3;
  EXPECT_NE(errorOf(run({0}, withEdge(unknown))).find("998"), std::string::npos);

  EXPECT_NE(errorOf(run({}, d.edges)).find("no fixed vertex"), std::string::npos) << errorOf(run({}, d.edges));
  EXPECT_NE(errorOf(run({777}, d.edges)).find("777"), std::string::npos) << errorOf(run({777}, d.edges));

  PoseGraphEdge self = edgeFromTruth(d.truth, 2, 3);
  self.j = 2;
  EXPECT_NE(errorOf(run({0}, withEdge(self))).find("itself"), std::string::npos);
  PoseGraphEdge weightless = edgeFromTruth(d.truth, 2, 3);
  weightless.weight = 0.0;
  EXPECT_NE(errorOf(run({0}, withEdge(weightless))).find("weight"), std::string::npos);
  PoseGraphEdge badScale = edgeFromTruth(d.truth, 2, 3);
  badScale.S_ij.s = -1.0;
  EXPECT_NE(errorOf(run({0}, withEdge(badScale))).find("scale"), std::string::npos);
  PoseGraphEdge notRotation = edgeFromTruth(d.truth, 2, 3);
  notRotation.S_ij.R *= 1.1;
  EXPECT_NE(errorOf(run({0}, withEdge(notRotation))).find("rotation"), std::string::npos);
  for (const auto& [id, S] : before) EXPECT_TRUE(sameBits(poses.at(id), S));  // nothing written on refusal

  poses.at(4).s = std::nan("");
  EXPECT_NE(errorOf(run({0}, d.edges)).find("vertex 4"), std::string::npos) << errorOf(run({0}, d.edges));
}

TEST(Sim3PoseGraph, ParamsCheckNamesTheField) {
  EXPECT_NO_THROW(PoseGraphParams{}.check());
  PoseGraphParams p;
  p.maxIterations = 0;
  EXPECT_NE(errorOf([&] { p.check(); }).find("maxIterations"), std::string::npos);
  Poses poses{{0, Sim3()}, {1, Sim3()}};
  EXPECT_THROW(optimizeSim3PoseGraph(poses, {0}, {}, p), pslam::Error);
  p = {};
  p.huberDelta = -0.5;
  EXPECT_NE(errorOf([&] { p.check(); }).find("huberDelta"), std::string::npos);
  p.huberDelta = 0.0;
  EXPECT_NO_THROW(p.check());
}

TEST(Sim3PoseGraph, WithNothingToOptimizeReportsTheCost) {
  const DriftedLoop d = makeDriftedLoop(4);
  Poses poses = d.initial;
  const Poses before = poses;
  // No edge.
  PoseGraphResult r = optimizeSim3PoseGraph(poses, {0}, {}, {});
  EXPECT_TRUE(r.usable);
  EXPECT_EQ(r.freeVertices, 0);
  EXPECT_EQ(r.finalCost, 0.0);
  // Only an edge between two fixed vertices: its cost, 1/2 |r|^2, nothing moves.
  const PoseGraphEdge& e = d.edges.back();
  r = optimizeSim3PoseGraph(poses, {e.i, e.j}, {e}, {});
  EXPECT_TRUE(r.usable);
  EXPECT_NEAR(r.finalCost, 0.5 * sim3EdgeResidual(e, poses.at(e.i), poses.at(e.j)).squaredNorm(), 1e-12);
  EXPECT_GT(r.finalCost, 1e-4);
  for (const auto& [id, S] : before) EXPECT_TRUE(sameBits(poses.at(id), S));
}
