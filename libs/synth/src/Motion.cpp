#include "pslam/synth/Motion.h"

#include <algorithm>
#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/synth/Texture.h"

namespace pslam::synth {

MonotoneCubic::MonotoneCubic(std::vector<double> t, std::vector<double> y, bool periodic)
    : t_(std::move(t)), y_(std::move(y)), periodic_(periodic) {
  require(t_.size() == y_.size() && t_.size() >= 2, "MonotoneCubic", "needs at least two keys of (t, y)");
  for (std::size_t i = 1; i < t_.size(); ++i) require(t_[i] > t_[i - 1], "MonotoneCubic", "key times must increase");
  const std::size_t n = t_.size();
  std::vector<double> d(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) d[i] = (y_[i + 1] - y_[i]) / (t_[i + 1] - t_[i]);
  m_.assign(n, 0.0);
  // Fritsch-Carlson: harmonic-mean tangents, zero at local extrema, which keeps each segment monotone.
  auto tangent = [](double dl, double dr, double hl, double hr) {
    if (dl * dr <= 0) return 0.0;
    const double w1 = 2 * hr + hl, w2 = hr + 2 * hl;
    return (w1 + w2) / (w1 / dl + w2 / dr);
  };
  for (std::size_t i = 1; i + 1 < n; ++i)
    m_[i] = tangent(d[i - 1], d[i], t_[i] - t_[i - 1], t_[i + 1] - t_[i]);
  if (periodic_) {
    require(std::abs(y_.front() - y_.back()) < 1e-9, "MonotoneCubic", "periodic keys must end where they start");
    m_[0] = m_[n - 1] = tangent(d[n - 2], d[0], t_[n - 1] - t_[n - 2], t_[1] - t_[0]);
  } else if (n == 2) {
    m_[0] = m_[1] = d[0];
  } else {
    // Shape-preserving three-point end tangents (as in MATLAB's pchip).
    auto endTangent = [](double h0, double h1, double d0, double d1) {
      double m = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
      if (m * d0 <= 0) m = 0;
      else if (d0 * d1 <= 0 && std::abs(m) > 3 * std::abs(d0)) m = 3 * d0;
      return m;
    };
    m_[0] = endTangent(t_[1] - t_[0], t_[2] - t_[1], d[0], d[1]);
    m_[n - 1] = endTangent(t_[n - 1] - t_[n - 2], t_[n - 2] - t_[n - 3], d[n - 2], d[n - 3]);
  }
}

double MonotoneCubic::operator()(double t) const {
  if (periodic_) {
    const double P = period();
    t = t_.front() + std::fmod(std::fmod(t - t_.front(), P) + P, P);
  }
  if (t <= t_.front()) return y_.front();
  if (t >= t_.back()) return y_.back();
  const std::size_t i = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin()) - 1;
  const double h = t_[i + 1] - t_[i];
  const double u = (t - t_[i]) / h;
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * y_[i] + (u3 - 2 * u2 + u) * h * m_[i] + (-2 * u3 + 3 * u2) * y_[i + 1] +
         (u3 - u2) * h * m_[i + 1];
}

SpeedProfile::SpeedProfile(std::vector<double> t, std::vector<double> v, double s0)
    : t_(std::move(t)), v_(std::move(v)), s0_(s0) {
  require(t_.size() == v_.size() && !t_.empty(), "SpeedProfile", "needs at least one key of (t, v)");
  for (std::size_t i = 1; i < t_.size(); ++i) require(t_[i] > t_[i - 1], "SpeedProfile", "key times must increase");
  s_.assign(t_.size(), 0.0);
  for (std::size_t i = 1; i < t_.size(); ++i) s_[i] = s_[i - 1] + 0.5 * (t_[i] - t_[i - 1]) * (v_[i - 1] + v_[i]);
}

double SpeedProfile::speed(double t) const {
  if (t <= t_.front()) return v_.front();
  if (t >= t_.back()) return v_.back();
  const std::size_t i = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin()) - 1;
  const double u = (t - t_[i]) / (t_[i + 1] - t_[i]);
  return v_[i] + (v_[i + 1] - v_[i]) * u * u * (3 - 2 * u);
}

double SpeedProfile::distance(double t) const {
  if (t <= t_.front()) return s0_ + v_.front() * (t - t_.front());
  if (t >= t_.back()) return s0_ + s_.back() + v_.back() * (t - t_.back());
  const std::size_t i = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin()) - 1;
  const double h = t_[i + 1] - t_[i];
  const double u = (t - t_[i]) / h;
  // integral_0^u smoothstep = u^3 - u^4/2
  return s0_ + s_[i] + h * (v_[i] * u + (v_[i + 1] - v_[i]) * (u * u * u - 0.5 * u * u * u * u));
}

Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up, double roll) {
  const Eigen::Vector3d z = forward.normalized();
  Eigen::Vector3d x = z.cross(up);
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Isometry3d applyJitter(const Eigen::Isometry3d& T, const Jitter& j, double t) {
  if (j.angle == 0 && j.position == 0) return T;
  const double x = t * j.frequency;
  // Two octaves per axis: a slow sway and a faster tremor.
  auto n = [&](std::uint32_t k) { return smoothNoise1D(x, j.seed + k) + 0.35 * smoothNoise1D(3.1 * x, j.seed + 50 + k); };
  const Eigen::Matrix3d dR = (Eigen::AngleAxisd(j.angle * n(1), Eigen::Vector3d::UnitX()) *
                              Eigen::AngleAxisd(j.angle * n(2), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(0.5 * j.angle * n(3), Eigen::Vector3d::UnitZ()))
                                 .toRotationMatrix();
  Eigen::Isometry3d out = T;
  out.linear() = T.linear() * dR;
  out.translation() += j.position * Eigen::Vector3d(n(4), n(5), n(6));
  return out;
}

CameraPath::CameraPath(const std::vector<Key>& keys, Jitter jitter, bool periodic) : jitter_(jitter) {
  std::vector<double> t;
  std::vector<double> p[3], q[3];
  for (const auto& k : keys) {
    t.push_back(k.t);
    for (int a = 0; a < 3; ++a) {
      p[a].push_back(k.position[a]);
      q[a].push_back(k.target[a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    p_[a] = MonotoneCubic(t, p[a], periodic);
    q_[a] = MonotoneCubic(t, q[a], periodic);
  }
}

Eigen::Isometry3d CameraPath::pose(double t) const {
  const Eigen::Vector3d pos(p_[0](t), p_[1](t), p_[2](t));
  const Eigen::Vector3d tgt(q_[0](t), q_[1](t), q_[2](t));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = lookAtRotation(tgt - pos, Eigen::Vector3d::UnitZ());
  T.translation() = pos;
  return applyJitter(T, jitter_, t);
}

}  // namespace pslam::synth
