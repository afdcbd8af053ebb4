#include "pslam/manhattan/ManhattanTracker.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "pslam/core/Error.h"

namespace pslam::manhattan {

namespace {

constexpr double kDeg = M_PI / 180.0;

/// Q_a of eq. 2.65: rows r_{a+1}, r_{a+2}, r_a, so that Q_a maps axis a onto +z (a cyclic, proper rotation).
Eigen::Matrix3d alignAxisToZ(const Eigen::Matrix3d& R_cam_mf, int a) {
  Eigen::Matrix3d Q;
  Q.row(0) = R_cam_mf.col((a + 1) % 3).transpose();
  Q.row(1) = R_cam_mf.col((a + 2) % 3).transpose();
  Q.row(2) = R_cam_mf.col(a).transpose();
  return Q;
}

/// Closest rotation in the Frobenius sense (Algorithm 4, line 16), forcing det = +1.
Eigen::Matrix3d orthogonalize(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  if ((U * svd.matrixV().transpose()).determinant() < 0) U.col(2) *= -1.0;
  return U * svd.matrixV().transpose();
}

/// Replaces axis `missing` by the cross product of the other two, in right-handed cyclic order (§4.4.1).
Eigen::Matrix3d completeAxis(const Eigen::Matrix3d& M, int missing) {
  Eigen::Matrix3d out = M;
  const int i = (missing + 1) % 3, j = (missing + 2) % 3;
  out.col(missing) = M.col(i).cross(M.col(j)).normalized();
  return out;
}

struct AxisStats {
  std::array<std::size_t, 3> count{};
  std::array<double, 3> sumSqAngle{};
};

AxisStats supportInCone(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R, double coneDeg) {
  AxisStats s;
  const double cosCone = std::cos(coneDeg * kDeg);
  for (const auto& v : normals) {
    for (int a = 0; a < 3; ++a) {
      const double c = std::abs(v.dot(R.col(a)));  // Algorithm 4, line 6, as |cos| > cos(rho) for unit vectors
      if (c > cosCone) {
        ++s.count[static_cast<std::size_t>(a)];
        const double ang = std::acos(std::min(1.0, c));
        s.sumSqAngle[static_cast<std::size_t>(a)] += ang * ang;
      }
    }
  }
  return s;
}

}  // namespace

// ------------------------------------------------------------------------------------------- parameters
PSLAM_DEFINE_PARAMS(ManhattanParams)

nlohmann::json ManhattanEstimate::toJson() const {
  nlohmann::json axesJson = nlohmann::json::array();
  for (const auto& a : axes)
    axesJson.push_back({{"count", a.count}, {"share", a.share}, {"spread_deg", a.spreadDeg}, {"observed", a.observed}});
  return {{"valid", valid},         {"reason", reason},       {"observed_axes", observedAxes},
          {"completed_axis", completedAxis}, {"iterations", iterations}, {"converged", converged},
          {"reinitialized", reinitialized}, {"axes", axesJson}};
}

// ------------------------------------------------------------------------------------------ S^2 maps
Eigen::Vector2d logMapS2(const Eigen::Vector3d& v) {
  const double s = std::hypot(v.x(), v.y());
  if (s < 1e-12) return Eigen::Vector2d::Zero();
  // eq. 2.66; sign(v_z) folds the lower hemisphere onto the upper one (v and -v are the same direction)
  const double sgn = v.z() >= 0 ? 1.0 : -1.0;
  return std::asin(std::clamp(sgn * s, -1.0, 1.0)) / s * Eigen::Vector2d(v.x(), v.y());
}

Eigen::Vector3d expMapS2(const Eigen::Vector2d& m) {
  const double theta = m.norm();
  if (theta < 1e-12) return Eigen::Vector3d::UnitZ();
  const Eigen::Vector2d t = std::tan(theta) / theta * m;  // eq. 2.68
  return Eigen::Vector3d(t.x(), t.y(), 1.0).normalized();
}

double rotationAngleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const double c = std::clamp(((A.transpose() * B).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) / kDeg;
}

const std::vector<Eigen::Matrix3d>& cubeSymmetries() {
  static const std::vector<Eigen::Matrix3d> sym = [] {
    std::vector<Eigen::Matrix3d> out;
    const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& p : perms)
      for (int signs = 0; signs < 8; ++signs) {
        Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
        for (int k = 0; k < 3; ++k) S(p[k], k) = (signs >> k) & 1 ? -1.0 : 1.0;
        if (S.determinant() > 0) out.push_back(S);
      }
    return out;
  }();
  return sym;
}

Eigen::Matrix3d alignToReference(const Eigen::Matrix3d& R, const Eigen::Matrix3d& reference, double* angleDeg) {
  Eigen::Matrix3d best = R;
  double bestAngle = 1e9;
  for (const auto& S : cubeSymmetries()) {
    const Eigen::Matrix3d candidate = R * S;  // relabels the MF axes (columns), keeps det = +1
    const double a = rotationAngleDeg(reference, candidate);
    if (a < bestAngle) {
      bestAngle = a;
      best = candidate;
    }
  }
  if (angleDeg) *angleDeg = bestAngle;
  return best;
}

// ------------------------------------------------------------------------------------ Algorithm 4
Eigen::Matrix3d meanShiftIteration(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R,
                                   double coneAngleDeg, double kernelWidth, std::size_t minSupport,
                                   std::array<std::size_t, 3>* support) {
  const double cosCone = std::cos(coneAngleDeg * kDeg);
  Eigen::Matrix3d M = R;
  std::array<std::size_t, 3> count{};
  for (int a = 0; a < 3; ++a) {
    const Eigen::Vector3d r_a = R.col(a);
    const Eigen::Matrix3d Q = alignAxisToZ(R, a);
    Eigen::Vector2d weightedSum = Eigen::Vector2d::Zero();
    double weightSum = 0.0;
    for (const auto& v : normals) {
      // line 6: inside the cone only (|v x r| < sin(rho) is |v . r| > cos(rho) for unit vectors)
      if (std::abs(v.dot(r_a)) <= cosCone) continue;
      const Eigen::Vector2d p = logMapS2(Q * v);           // lines 8-9, eq. 2.66
      const double w = std::exp(-kernelWidth * p.squaredNorm());  // eq. 2.67
      weightedSum += w * p;
      weightSum += w;
      ++count[static_cast<std::size_t>(a)];
    }
    if (count[static_cast<std::size_t>(a)] < std::max<std::size_t>(1, minSupport)) continue;  // keep previous axis
    const Eigen::Vector2d m = weightedSum / weightSum;      // line 10
    M.col(a) = Q.transpose() * expMapS2(m);                 // lines 11-12, eq. 2.68
  }
  const std::size_t need = std::max<std::size_t>(1, minSupport);
  const int unsupported =
      static_cast<int>(std::count_if(count.begin(), count.end(), [&](std::size_t c) { return c < need; }));
  if (unsupported == 1) {
    const int missing = static_cast<int>(
        std::find_if(count.begin(), count.end(), [&](std::size_t c) { return c < need; }) - count.begin());
    M = completeAxis(M, missing);  // §4.4.1: a weakly supported axis must not tilt the two observed ones
  }
  if (support) *support = count;
  return orthogonalize(M);  // lines 15-16
}

ManhattanEstimate refineManhattanFrame(const std::vector<Eigen::Vector3d>& normals, const Eigen::Matrix3d& R_start,
                                       const ManhattanParams& P) {
  ManhattanEstimate e;
  Eigen::Matrix3d R = orthogonalize(R_start);
  // An axis steers the iteration only with the support that would make it "observed" (count and share).
  const std::size_t minSupport = std::max<std::size_t>(
      P.minAxisSupport, static_cast<std::size_t>(std::ceil(P.minAxisShare * static_cast<double>(normals.size()))));
  auto run = [&](double coneDeg) {
    bool converged = false;
    for (int it = 0; it < P.maxIterations; ++it) {
      const Eigen::Matrix3d Rn = meanShiftIteration(normals, R, coneDeg, P.kernelWidth, minSupport, nullptr);
      const double change = rotationAngleDeg(R, Rn);
      R = Rn;
      ++e.iterations;
      if (change < P.convergenceDeg) {
        converged = true;
        break;
      }
    }
    return converged;
  };
  if (P.coarseConeAngleDeg > 0) run(P.coarseConeAngleDeg);
  e.converged = run(P.coneAngleDeg);

  // Support and spread in the rho_th cone: the validity measure callers use to reject an estimate.
  AxisStats s = supportInCone(normals, R, P.coneAngleDeg);
  const double n = std::max<std::size_t>(1, normals.size());
  for (std::size_t a = 0; a < 3; ++a) {
    AxisSupport& ax = e.axes[a];
    ax.count = s.count[a];
    ax.share = ax.count / n;
    ax.spreadDeg = ax.count ? std::sqrt(s.sumSqAngle[a] / ax.count) / kDeg : 0.0;
    ax.observed = ax.count >= P.minAxisSupport && ax.share >= P.minAxisShare && ax.spreadDeg <= P.maxAxisSpreadDeg;
    e.observedAxes += ax.observed ? 1 : 0;
  }
  if (e.observedAxes == 2) {
    // Only two orthogonal planes: the third axis is their cross product (§4.4.1), not a weakly supported mean.
    for (int a = 0; a < 3; ++a)
      if (!e.axes[static_cast<std::size_t>(a)].observed) e.completedAxis = a;
    R = orthogonalize(completeAxis(R, e.completedAxis));
  }
  e.R_cam_mf = R;
  e.valid = e.converged && e.observedAxes >= P.minObservedAxes;
  if (!e.converged)
    e.reason = "mean shift did not converge";
  else if (e.observedAxes < P.minObservedAxes)
    e.reason = "only " + std::to_string(e.observedAxes) + " Manhattan axes observed";
  return e;
}

// -------------------------------------------------------------------------------------------- tracker
ManhattanTracker::ManhattanTracker(ManhattanParams params) : params_(params), rng_(params.seed) { params_.check(); }

std::vector<Eigen::Vector3d> ManhattanTracker::subsample(const std::vector<Eigen::Vector3d>& normals) {
  if (normals.size() <= params_.maxNormals) return normals;
  std::vector<Eigen::Vector3d> out;
  out.reserve(params_.maxNormals);
  std::sample(normals.begin(), normals.end(), std::back_inserter(out), params_.maxNormals, rng_);
  return out;
}

ManhattanEstimate ManhattanTracker::sampleAndCluster(const std::vector<Eigen::Vector3d>& normals) {
  // Sampling runs on a smaller subset for speed; the winner is refined on all normals.
  const std::size_t sampleCount = std::min<std::size_t>(normals.size(), 1500);
  std::vector<Eigen::Vector3d> few;
  std::sample(normals.begin(), normals.end(), std::back_inserter(few), sampleCount, rng_);
  ManhattanParams fewParams = params_;
  fewParams.minAxisSupport = std::max<std::size_t>(
      1, params_.minAxisSupport * sampleCount / std::max<std::size_t>(1, normals.size()));
  fewParams.maxIterations = std::min(fewParams.maxIterations, 20);
  fewParams.convergenceDeg = std::max(fewParams.convergenceDeg, 0.05);

  struct Candidate {
    Eigen::Matrix3d R;
    double support;
  };
  std::vector<Candidate> candidates;
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int i = 0; i < params_.initSamples; ++i) {
    // Uniform random rotation: a normalized 4D Gaussian is uniform on S^3.
    Eigen::Quaterniond q(gauss(rng_), gauss(rng_), gauss(rng_), gauss(rng_));
    q.normalize();
    const ManhattanEstimate e = refineManhattanFrame(few, q.toRotationMatrix(), fewParams);
    if (!e.valid) continue;
    double support = 0;
    for (const auto& a : e.axes) support += a.observed ? static_cast<double>(a.count) : 0.0;
    candidates.push_back({e.R_cam_mf, support});
  }
  if (candidates.empty()) {
    ManhattanEstimate e;
    e.reason = "initialization: no sampled rotation converged to a Manhattan frame";
    return e;
  }
  // Greedy clustering modulo the cube symmetry; the dominant cluster has the largest summed support.
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.support > b.support; });
  struct Cluster {
    Eigen::Matrix3d representative;
    double support;
  };
  std::vector<Cluster> clusters;
  for (const auto& c : candidates) {
    bool placed = false;
    for (auto& cl : clusters) {
      double angle = 0;
      alignToReference(c.R, cl.representative, &angle);
      if (angle < params_.initClusterDeg) {
        cl.support += c.support;
        placed = true;
        break;
      }
    }
    if (!placed) clusters.push_back({c.R, c.support});
  }
  const auto best = std::max_element(clusters.begin(), clusters.end(),
                                     [](const Cluster& a, const Cluster& b) { return a.support < b.support; });
  return refineManhattanFrame(normals, best->representative, params_);
}

ManhattanEstimate ManhattanTracker::initialize(const std::vector<Eigen::Vector3d>& normals) {
  const auto sub = subsample(normals);
  ManhattanEstimate e = sampleAndCluster(sub);
  // Label the axes so that the MF is as close as possible to the camera axes of the first frame.
  e.R_cam_mf = alignToReference(e.R_cam_mf, Eigen::Matrix3d::Identity());
  if (e.valid) {
    R_cam_mf_ = e.R_cam_mf;
    initialized_ = true;
  }
  return e;
}

ManhattanEstimate ManhattanTracker::track(const std::vector<Eigen::Vector3d>& normals) {
  require(initialized_, "ManhattanTracker", "track() before a successful initialize()");
  const auto sub = subsample(normals);
  ManhattanEstimate e = refineManhattanFrame(sub, R_cam_mf_, params_);
  double step = 0;
  if (e.valid) {
    e.R_cam_mf = alignToReference(e.R_cam_mf, R_cam_mf_, &step);
    if (step > params_.maxStepDeg) {
      e.valid = false;
      e.reason = "step of " + std::to_string(step) + " deg from the previous frame";
    }
  }
  if (!e.valid) {
    // Lost the previous frame's basin: re-initialize from samples and keep the previous axis labels.
    ManhattanEstimate r = sampleAndCluster(sub);
    r.reinitialized = true;
    if (r.valid) {
      r.R_cam_mf = alignToReference(r.R_cam_mf, R_cam_mf_, &step);
      if (step > params_.maxStepDeg) {
        r.valid = false;
        r.reason = "re-initialized frame is " + std::to_string(step) + " deg from the previous one";
      }
    }
    if (r.valid || !e.valid) e = r;
  }
  if (e.valid) R_cam_mf_ = e.R_cam_mf;
  return e;
}

ManhattanEstimate ManhattanTracker::process(const std::vector<Eigen::Vector3d>& normals) {
  return initialized_ ? track(normals) : initialize(normals);
}

}  // namespace pslam::manhattan
