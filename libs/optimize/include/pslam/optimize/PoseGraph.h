#pragma once
// Sim(3) pose-graph optimization of loop closing (ORB-SLAM Optimizer::OptimizeEssentialGraph) with Ceres.
// After a loop is detected, the keyframes near the current one are corrected by the loop's similarity, the rest
// of the map keeps its drifted poses, and this optimization spreads the correction over the whole loop: every
// keyframe's world-to-camera similarity S_iw is a vertex, every edge of the essential graph (spanning tree,
// strong covisibility, previous loops, the new loop links) a relative similarity measured before the correction.
// Similarities rather than rigid poses, because a monocular map drifts in scale as well.
//
// Vertex parameterization: the rotation as a unit quaternion (Eigen's x, y, z, w order) on
// ceres::EigenQuaternionManifold, the translation (3), and the log of the scale (1), so that the scale stays
// positive without a bound and a relative scale error is symmetric (x 2 and / 2 cost the same).
//
// Edge residual (7-vector, automatic differentiation): with the error similarity
//   E = S_ij^-1 * S_iw * S_jw^-1 = (s_E, R_E, t_E)    (identity when the vertices agree with the measurement),
//   r = sqrt(weight) * [ Log(R_E) (3, angle-axis), t_E (3), log(s_E) (1) ].
// E is the error of g2o's EdgeSim3 in ORB-SLAM (C * S_iw * S_jw^-1 with C = S_ji), but r is not its Sim(3)
// logarithm (whose translation part is V^-1 t_E): both agree to first order at E = I, where the optimization
// ends, and this one has no singular branch near the identity for automatic differentiation. t_E is
// in the units of frame j; g2o's ORB-SLAM uses identity information on its 7-vector, i.e. the same mixing of
// radians, map units and log-scale. The cost of an edge is 1/2 |r|^2 (or its Huber loss).
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include <Eigen/Core>

#include "pslam/core/Params.h"
#include "pslam/geometry/Sim3.h"

namespace ceres {
class CostFunction;
}

namespace pslam::optimize {

inline constexpr int kSim3ResidualSize = 7;  ///< [rotation (3), translation (3), log-scale (1)]

struct PoseGraphEdge {
  std::uint64_t i = 0, j = 0;  ///< vertex ids (distinct)
  /// The measured relative transform S_iw * S_jw^-1 (maps frame-j to frame-i coordinates), e.g. from the poses
  /// before the loop correction, or the loop's own Sim(3) for the new loop links.
  geometry::Sim3 S_ij;
  double weight = 1.0;  ///< information scale of the whole 7-vector residual (> 0); ORB-SLAM: 1
};

/// [PoseGraph]
struct PoseGraphParams {
  int maxIterations = 20;   ///< ORB-SLAM: 20 Levenberg-Marquardt iterations
  double huberDelta = 0.0;  ///< 0 = no robust loss (ORB-SLAM uses none here)

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, maxIterations, atLeast(1), "Levenberg-Marquardt iterations of the essential graph (ORB-SLAM: 20)");
    PSLAM_FIELD(v, huberDelta, atLeast(0),
                "Huber delta on the norm of an edge's weighted 7-vector residual; 0 = plain least squares (ORB-SLAM)");
  }
  PSLAM_PARAMS("PoseGraph")
};

struct PoseGraphResult {
  double initialCost = 0, finalCost = 0;  ///< Ceres cost (1/2 sum of robustified squares), every edge
  int iterations = 0;                     ///< LM iterations run after the start point (<= maxIterations)
  bool usable = false;                    ///< Ceres reported a usable solution (the poses were written back)
  int freeVertices = 0;                   ///< vertices in some edge and not fixed: the ones that may have moved
};

/// Optimizes the world-to-camera similarities S_iw (in/out) of the vertices in `poses` so that every edge's S_ij
/// agrees with S_iw * S_jw^-1 (residual: see the top of this file). Only vertices named by some edge take part;
/// the others, and the vertices in `fixed`, are returned bit-for-bit unchanged. `fixed` fixes the gauge (world
/// frame and scale): typically the loop's matched keyframe or the first keyframe. Ids in `fixed` that are not in
/// `poses` are ignored (e.g. keyframes erased meanwhile), but at least one must be a vertex. Connectivity is not
/// checked: a connected part of the graph without a fixed vertex is held only by the LM damping.
/// Throws pslam::Error on: an empty `fixed` or one naming no vertex of `poses`; an edge naming an unknown vertex,
/// the same vertex twice, a non-finite or non-positive weight or a measurement that is not a similarity; a pose
/// that is not a similarity (non-finite, scale <= 0, R not a rotation); bad params.
/// Deterministic: single-threaded Ceres, vertex blocks added in id order and edges in their order, so the same
/// input gives the same bits.
/// When Ceres reports no usable solution (e.g. non-finite costs), `poses` is left unchanged.
PoseGraphResult optimizeSim3PoseGraph(std::map<std::uint64_t, geometry::Sim3>& poses,
                                      const std::set<std::uint64_t>& fixed, const std::vector<PoseGraphEdge>& edges,
                                      const PoseGraphParams& params = {});

/// The cost function of one edge, for Ceres problems built elsewhere and for Jacobian checks. Parameter blocks:
/// q_iw (4, Eigen order), t_iw (3), log s_iw (1), q_jw (4), t_jw (3), log s_jw (1). The caller owns it.
ceres::CostFunction* newSim3EdgeCostFunction(const geometry::Sim3& S_ij, double weight);

/// The weighted residual of `edge` at the vertex values S_iw, S_jw (for tests and diagnostics, e.g. the loop
/// edges' remaining error).
Eigen::Matrix<double, kSim3ResidualSize, 1> sim3EdgeResidual(const PoseGraphEdge& edge, const geometry::Sim3& S_iw,
                                                              const geometry::Sim3& S_jw);

}  // namespace pslam::optimize
