#include "pslam/optimize/PoseGraph.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>

#include <ceres/autodiff_cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/rotation.h>
#include <ceres/solver.h>

#include <Eigen/Geometry>

#include "pslam/core/Error.h"

PSLAM_DEFINE_PARAMS(pslam::optimize::PoseGraphParams)

namespace pslam::optimize {

namespace {

using geometry::Sim3;
using Vector7d = Eigen::Matrix<double, kSim3ResidualSize, 1>;

const char* const kContext = "Sim(3) pose graph";

/// The measurement is stored pre-inverted: E = S_ij^-1 * A with S_ij^-1 = (1/s, R^T, -R^T t / s).
struct Sim3EdgeCost {
  Eigen::Quaterniond q_ji;  ///< R_ij^T as a unit quaternion
  Eigen::Matrix3d R_ji;     ///< R_ij^T
  Eigen::Vector3d t_ij;
  double invS_ij = 1.0, logS_ij = 0.0, sqrtWeight = 1.0;

  Sim3EdgeCost(const Sim3& S_ij, double weight)
      : q_ji(Eigen::Quaterniond(S_ij.R).normalized().conjugate()),
        R_ji(q_ji.toRotationMatrix()),
        t_ij(S_ij.t),
        invS_ij(1.0 / S_ij.s),
        logS_ij(std::log(S_ij.s)),
        sqrtWeight(std::sqrt(weight)) {}

  template <typename T>
  bool operator()(const T* qi, const T* ti, const T* logSi, const T* qj, const T* tj, const T* logSj, T* r) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_iw(qi), q_jw(qj);
    const Eigen::Map<const Vec3> t_iw(ti), t_jw(tj);
    // A = S_iw * S_jw^-1 = (s_i / s_j, R_i R_j^T, t_i - (s_i / s_j) R_i R_j^T t_j).
    const T logS_A = logSi[0] - logSj[0];
    const Eigen::Quaternion<T> q_A = q_iw * q_jw.conjugate();
    const Vec3 t_A = t_iw - exp(logS_A) * (q_A * t_jw);
    // E = S_ij^-1 * A = (s_A / s_ij, R_ij^T R_A, R_ij^T (t_A - t_ij) / s_ij).
    const Eigen::Quaternion<T> q_E = q_ji.cast<T>() * q_A;
    const Vec3 t_E = (R_ji.cast<T>() * (t_A - t_ij.cast<T>())) * T(invS_ij);
    // Log(R_E); QuaternionToAngleAxis takes the shorter of +-q_E itself, so the angle stays within [0, pi].
    const T wxyz[4] = {q_E.w(), q_E.x(), q_E.y(), q_E.z()};
    ceres::QuaternionToAngleAxis(wxyz, r);
    r[3] = t_E[0];
    r[4] = t_E[1];
    r[5] = t_E[2];
    r[6] = logS_A - T(logS_ij);
    for (int k = 0; k < kSim3ResidualSize; ++k) r[k] *= T(sqrtWeight);
    return true;
  }
};

bool isRotation(const Eigen::Matrix3d& R) {
  return R.allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 && R.determinant() > 0.0;
}

/// Empty when `S` is a similarity, else why not.
std::string similarityProblem(const Sim3& S) {
  if (!std::isfinite(S.s) || !(S.s > 0.0)) return "scale is not a positive number";
  if (!S.t.allFinite()) return "translation has NaN/Inf";
  if (!isRotation(S.R)) return "R is not a rotation matrix";
  return {};
}

std::string edgeName(std::size_t index, const PoseGraphEdge& e) {
  return "edge " + std::to_string(index) + " (" + std::to_string(e.i) + " -> " + std::to_string(e.j) + ")";
}

void validate(const std::map<std::uint64_t, Sim3>& poses, const std::set<std::uint64_t>& fixed,
              const std::vector<PoseGraphEdge>& edges) {
  for (const auto& [id, S] : poses) {
    const std::string why = similarityProblem(S);
    require(why.empty(), kContext, "vertex " + std::to_string(id) + ": " + why);
  }
  bool anyFixed = false;
  for (std::uint64_t id : fixed) anyFixed = anyFixed || poses.count(id) != 0;
  if (!anyFixed) {
    std::ostringstream ids;
    for (std::uint64_t id : fixed) ids << (ids.tellp() > 0 ? ", " : "") << id;
    require(false, kContext,
            fixed.empty() ? "no fixed vertex: the gauge (world frame and scale) would be free"
                          : "the fixed vertices {" + ids.str() +
                                "} name no vertex of the graph: the gauge would be free");
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const PoseGraphEdge& e = edges[k];
    const std::string name = edgeName(k, e);
    require(poses.count(e.i) != 0, kContext, name + " refers to unknown vertex " + std::to_string(e.i));
    require(poses.count(e.j) != 0, kContext, name + " refers to unknown vertex " + std::to_string(e.j));
    require(e.i != e.j, kContext, name + " connects vertex " + std::to_string(e.i) + " to itself");
    require(std::isfinite(e.weight) && e.weight > 0.0, kContext, name + ": weight must be a positive number");
    const std::string why = similarityProblem(e.S_ij);
    require(why.empty(), kContext, name + ": measurement " + why);
  }
}

/// One vertex's Ceres blocks.
struct VertexBlocks {
  std::array<double, 4> q{};  ///< x, y, z, w
  std::array<double, 3> t{};
  double logS = 0.0;
};

}  // namespace

ceres::CostFunction* newSim3EdgeCostFunction(const Sim3& S_ij, double weight) {
  return new ceres::AutoDiffCostFunction<Sim3EdgeCost, kSim3ResidualSize, 4, 3, 1, 4, 3, 1>(
      new Sim3EdgeCost(S_ij, weight));
}

Vector7d sim3EdgeResidual(const PoseGraphEdge& edge, const Sim3& S_iw, const Sim3& S_jw) {
  const Eigen::Quaterniond q_i = Eigen::Quaterniond(S_iw.R).normalized();
  const Eigen::Quaterniond q_j = Eigen::Quaterniond(S_jw.R).normalized();
  const double logS_i = std::log(S_iw.s), logS_j = std::log(S_jw.s);
  Vector7d r;
  Sim3EdgeCost(edge.S_ij, edge.weight)(q_i.coeffs().data(), S_iw.t.data(), &logS_i, q_j.coeffs().data(),
                                       S_jw.t.data(), &logS_j, r.data());
  return r;
}

PoseGraphResult optimizeSim3PoseGraph(std::map<std::uint64_t, Sim3>& poses, const std::set<std::uint64_t>& fixed,
                                      const std::vector<PoseGraphEdge>& edges, const PoseGraphParams& params) {
  params.check();
  validate(poses, fixed, edges);

  // Blocks of the vertices named by some edge. std::map: stable addresses and a fixed (id) order.
  std::map<std::uint64_t, VertexBlocks> blocks;
  for (const PoseGraphEdge& e : edges) {
    for (std::uint64_t id : {e.i, e.j}) {
      if (blocks.count(id) != 0) continue;
      const Sim3& S = poses.at(id);
      VertexBlocks& b = blocks[id];
      const Eigen::Quaterniond q = Eigen::Quaterniond(S.R).normalized();
      std::copy(q.coeffs().data(), q.coeffs().data() + 4, b.q.begin());
      std::copy(S.t.data(), S.t.data() + 3, b.t.begin());
      b.logS = std::log(S.s);
    }
  }

  ceres::EigenQuaternionManifold quaternionManifold;  // shared by every vertex, outlives the problem
  ceres::Problem::Options problemOptions;
  problemOptions.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problemOptions);
  // Parameter blocks in id order, then the residuals in edge order: the same input builds the same problem.
  PoseGraphResult result;
  for (auto& [id, b] : blocks) {
    problem.AddParameterBlock(b.q.data(), 4, &quaternionManifold);
    problem.AddParameterBlock(b.t.data(), 3);
    problem.AddParameterBlock(&b.logS, 1);
    if (fixed.count(id) != 0) {
      problem.SetParameterBlockConstant(b.q.data());
      problem.SetParameterBlockConstant(b.t.data());
      problem.SetParameterBlockConstant(&b.logS);
    } else {
      ++result.freeVertices;
    }
  }
  for (const PoseGraphEdge& e : edges) {
    VertexBlocks& bi = blocks.at(e.i);
    VertexBlocks& bj = blocks.at(e.j);
    ceres::LossFunction* loss = params.huberDelta > 0.0 ? new ceres::HuberLoss(params.huberDelta) : nullptr;
    problem.AddResidualBlock(newSim3EdgeCostFunction(e.S_ij, e.weight), loss, bi.q.data(), bi.t.data(), &bi.logS,
                             bj.q.data(), bj.t.data(), &bj.logS);
  }

  if (result.freeVertices == 0) {
    // Nothing to optimize (no edge, or only edges between fixed vertices): report the cost as it is.
    double cost = 0.0;
    problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
    result.initialCost = result.finalCost = cost;
    result.usable = std::isfinite(cost);
    return result;
  }

  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  // The graph is sparse (a spanning tree plus a few covisibility and loop edges per keyframe); the normal
  // equations' fill-reducing ordering is deterministic for a given problem.
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.max_num_iterations = params.maxIterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);

  result.initialCost = summary.initial_cost;
  result.finalCost = summary.final_cost;
  result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);  // entry 0: the start point
  result.usable = summary.IsSolutionUsable();
  if (!result.usable) return result;

  for (const auto& [id, b] : blocks) {
    if (fixed.count(id) != 0) continue;
    Sim3& S = poses.at(id);
    S.R = Eigen::Quaterniond(b.q[3], b.q[0], b.q[1], b.q[2]).normalized().toRotationMatrix();
    S.t = Eigen::Vector3d(b.t[0], b.t[1], b.t[2]);
    S.s = std::exp(b.logS);
  }
  return result;
}

}  // namespace pslam::optimize
