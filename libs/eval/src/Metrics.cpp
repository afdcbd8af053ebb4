#include "pslam/eval/Metrics.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "pslam/core/Error.h"

namespace pslam::eval {

nlohmann::json ErrorStatistics::toJson() const {
  return {{"rmse", rmse}, {"mean", mean}, {"median", median}, {"std", std},
          {"min", min},   {"max", max},   {"sse", sse},       {"count", count}};
}

ErrorStatistics computeStatistics(const std::vector<double>& values, const std::string& what) {
  if (values.empty()) throw Error(what + ": no values to summarize");
  ErrorStatistics s;
  s.count = values.size();
  for (double v : values)
    if (!std::isfinite(v)) throw Error(what + ": NaN or Inf error value");
  const double n = static_cast<double>(values.size());
  s.sse = 0.0;
  for (double v : values) s.sse += v * v;
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  s.rmse = std::sqrt(s.sse / n);
  double var = 0.0;  // ddof = 0 (numpy.std default, used by evo)
  for (double v : values) var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const std::size_t m = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[m] : 0.5 * (sorted[m - 1] + sorted[m]);
  return s;
}

AlignmentMode parseAlignmentMode(const std::string& name) {
  if (name == "none") return AlignmentMode::None;
  if (name == "se3") return AlignmentMode::SE3;
  if (name == "sim3") return AlignmentMode::Sim3;
  throw Error("alignment '" + name + "': expected none, se3 or sim3");
}

std::string toString(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::None: return "none";
    case AlignmentMode::SE3: return "se3";
    case AlignmentMode::Sim3: return "sim3";
  }
  return "?";
}

nlohmann::json Alignment::toJson() const {
  nlohmann::json R = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) R.push_back({rotation(r, 0), rotation(r, 1), rotation(r, 2)});
  return {{"scale", scale}, {"rotation", R}, {"translation", {translation.x(), translation.y(), translation.z()}}};
}

Alignment alignTrajectories(const Trajectory& gt, const Trajectory& est, AlignmentMode mode, std::size_t firstN) {
  if (gt.size() != est.size())
    throw Error("alignment: " + std::to_string(gt.size()) + " ground-truth poses but " +
                std::to_string(est.size()) + " estimated poses");
  Alignment a;
  if (mode == AlignmentMode::None) return a;
  const std::size_t n = (firstN == 0 || firstN > gt.size()) ? gt.size() : firstN;
  if (n < 3)
    throw Error("alignment: " + std::to_string(n) + " associated poses used, at least 3 are needed for " +
                toString(mode));
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  for (std::size_t k = 0; k < n; ++k) {
    src.col(static_cast<Eigen::Index>(k)) = est[k].position;
    dst.col(static_cast<Eigen::Index>(k)) = gt[k].position;
  }
  // A rotation is only determined by points spanning at least a plane... or a line plus orientation,
  // which Umeyama does not use: refuse collinear or coincident estimates instead of returning garbage.
  const Eigen::Matrix3Xd centered = src.colwise() - src.rowwise().mean();
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3Xd>(centered).singularValues();
  if (!(sv(0) > 0.0) || sv(1) <= 1e-9 * sv(0))
    throw Error("alignment: the estimated positions are coincident or collinear, " + toString(mode) +
                " alignment is undetermined");
  // Ground-truth positions that coincide make the Sim(3) scale 0 (every estimate collapses onto them: ATE 0).
  const Eigen::Matrix3Xd gtCentered = dst.colwise() - dst.rowwise().mean();
  if (!(gtCentered.colwise().norm().maxCoeff() > 1e-9 * std::max(1.0, dst.colwise().norm().maxCoeff())))
    throw Error("alignment: the ground-truth positions of the associated poses coincide, " + toString(mode) +
                " alignment is degenerate (a static ground truth)");
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, mode == AlignmentMode::Sim3);
  a.scale = mode == AlignmentMode::Sim3 ? std::cbrt(T.block<3, 3>(0, 0).determinant()) : 1.0;
  a.rotation = T.block<3, 3>(0, 0) / a.scale;
  a.translation = T.block<3, 1>(0, 3);
  if (!a.rotation.allFinite() || !a.translation.allFinite() || !std::isfinite(a.scale) || a.scale <= 0.0)
    throw Error("alignment: " + toString(mode) + " alignment failed (non-finite result)");
  return a;
}

nlohmann::json SegmentAlignment::toJson() const {
  return {{"first_pair", first},     {"last_pair", last},          {"start_time", startTime},
          {"end_time", endTime},     {"path_length_m", pathLength}, {"alignment", alignment.toJson()},
          {"ate", ate.toJson()}};
}

std::vector<SegmentAlignment> alignSegments(const Trajectory& gt, const Trajectory& est, AlignmentMode mode,
                                            std::size_t segments) {
  if (gt.size() != est.size())
    throw Error("segments: " + std::to_string(gt.size()) + " ground-truth poses but " + std::to_string(est.size()) +
                " estimated poses");
  if (segments == 0) throw Error("segments: at least one segment is needed");
  const std::size_t n = gt.size(), size = n / segments, longer = n % segments;
  if (size < 3)
    throw Error("segments: " + std::to_string(n) + " associated poses in " + std::to_string(segments) +
                " segments leave fewer than 3 per segment");
  std::vector<SegmentAlignment> out;
  std::size_t begin = 0;
  for (std::size_t k = 0; k < segments; ++k) {
    const std::size_t end = begin + size + (k < longer ? 1 : 0);
    const Trajectory g(gt.begin() + static_cast<std::ptrdiff_t>(begin), gt.begin() + static_cast<std::ptrdiff_t>(end));
    const Trajectory e(est.begin() + static_cast<std::ptrdiff_t>(begin),
                       est.begin() + static_cast<std::ptrdiff_t>(end));
    SegmentAlignment seg;
    seg.first = begin;
    seg.last = end - 1;
    seg.startTime = g.front().timestamp;
    seg.endTime = g.back().timestamp;
    for (std::size_t i = 1; i < g.size(); ++i) seg.pathLength += (g[i].position - g[i - 1].position).norm();
    try {
      seg.alignment = alignTrajectories(g, e, mode);
    } catch (const Error& err) {
      throw Error("segment " + std::to_string(k + 1) + " of " + std::to_string(segments) + " (pairs " +
                  std::to_string(seg.first) + "-" + std::to_string(seg.last) + "): " + err.what());
    }
    seg.ate = computeAte(g, applyAlignment(e, seg.alignment)).stats;
    out.push_back(std::move(seg));
    begin = end;
  }
  return out;
}

SegmentScaleRange segmentScaleRange(const std::vector<SegmentAlignment>& segments) {
  if (segments.empty()) throw Error("segments: no segment to take a scale range of");
  SegmentScaleRange r;
  r.smallest = r.largest = segments.front().alignment.scale;
  for (const SegmentAlignment& s : segments) {
    r.smallest = std::min(r.smallest, s.alignment.scale);
    r.largest = std::max(r.largest, s.alignment.scale);
  }
  return r;
}

Trajectory applyAlignment(const Trajectory& trajectory, const Alignment& alignment) {
  Trajectory out = trajectory;
  const Eigen::Quaterniond qAlign(alignment.rotation);
  for (auto& p : out) {
    p.position = alignment.scale * (alignment.rotation * p.position) + alignment.translation;
    p.orientation = (qAlign * p.orientation).normalized();
  }
  return out;
}

namespace {
void requireSameNonEmpty(const Trajectory& gt, const Trajectory& est, const std::string& metric) {
  if (gt.empty() || gt.size() != est.size())
    throw Error(metric + ": needs the same non-zero number of associated poses (" + std::to_string(gt.size()) +
                " ground truth, " + std::to_string(est.size()) + " estimate)");
}

Eigen::Isometry3d relative(const StampedPose& a, const StampedPose& b) {
  return a.T_world_cam().inverse() * b.T_world_cam();
}
}  // namespace

double rotationAngle(const Eigen::Matrix3d& R) {
  // Through the quaternion: accurate for small angles, unlike acos((trace - 1) / 2).
  return std::abs(Eigen::AngleAxisd(Eigen::Quaterniond(R).normalized()).angle());
}

AteResult computeAte(const Trajectory& gt, const Trajectory& estAligned) {
  requireSameNonEmpty(gt, estAligned, "ATE");
  AteResult r;
  r.errors.reserve(gt.size());
  for (std::size_t k = 0; k < gt.size(); ++k) r.errors.push_back((gt[k].position - estAligned[k].position).norm());
  r.stats = computeStatistics(r.errors, "ATE");
  return r;
}

DeltaUnit parseDeltaUnit(const std::string& name) {
  if (name == "f" || name == "frames") return DeltaUnit::Frames;
  if (name == "m" || name == "meters" || name == "metres") return DeltaUnit::Meters;
  throw Error("RPE delta unit '" + name + "': expected frames (f) or m");
}

std::string toString(DeltaUnit unit) { return unit == DeltaUnit::Frames ? "frames" : "m"; }

std::vector<std::pair<std::size_t, std::size_t>> selectRpePairs(const Trajectory& poses, const RpeOptions& o) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  const std::size_t n = poses.size();
  if (!(o.delta > 0.0) || !std::isfinite(o.delta)) throw Error("RPE: delta must be > 0");
  if (o.unit == DeltaUnit::Frames) {
    if (o.delta != std::floor(o.delta)) throw Error("RPE: a delta in frames must be an integer");
    const auto d = static_cast<std::size_t>(o.delta);
    if (o.allPairs) {
      for (std::size_t i = 0; i + d < n; ++i) pairs.emplace_back(i, i + d);
    } else {
      for (std::size_t i = 0; i + d < n; i += d) pairs.emplace_back(i, i + d);
    }
  } else if (!o.allPairs) {
    // evo filter_pairs_by_path: accumulate the path from pose 0; each time it reaches delta, the current
    // pose becomes an id and the accumulator restarts at 0. Pairs are consecutive ids.
    std::vector<std::size_t> ids;
    double path = 0.0;
    for (std::size_t i = 1; i < n; ++i) {
      path += (poses[i].position - poses[i - 1].position).norm();
      if (path >= o.delta) {
        ids.push_back(i);
        path = 0.0;
      }
    }
    for (std::size_t k = 1; k < ids.size(); ++k) pairs.emplace_back(ids[k - 1], ids[k]);
  } else {
    // evo filter_pairs_by_path(all_pairs=True): per start i, evo's bounded binary search over j for an arc
    // length arc(i..j) within [delta - tol, delta + tol], tol = relTol * delta; reproduced step by step so
    // that the chosen j (not only "a" valid j) is the same.
    std::vector<double> cumulative(n, 0.0);
    for (std::size_t k = 1; k < n; ++k)
      cumulative[k] = cumulative[k - 1] + (poses[k].position - poses[k - 1].position).norm();
    const double tol = o.delta * o.relativeTolerance;
    const double lower = o.delta - tol, upper = o.delta + tol;
    const auto n64 = static_cast<long long>(n);
    for (std::size_t i = 0; i < n; ++i) {
      // arc length of positions[i : x+1] in Python slice semantics
      const auto arc = [&](long long x) {
        const long long last = std::min(x, n64 - 1);
        if (last <= static_cast<long long>(i)) return 0.0;
        return cumulative[static_cast<std::size_t>(last)] - cumulative[i];
      };
      long long start = 0, end = n64 - 1, mid = -1;
      bool found = false;
      while (start <= end && !found) {
        mid = (start + end) / 2;
        const double val = arc(mid);
        if (lower <= val && val <= upper) {
          const double residual = std::abs(val - o.delta);
          if (std::abs(arc(mid - 1) - o.delta) <= residual) {
            end = mid - 1;
            continue;
          } else if (std::abs(arc(mid + 1) - o.delta) < residual) {
            start = mid + 1;
            continue;
          } else {
            found = true;
          }
        }
        if (!found) {
          if (o.delta < val)
            end = mid - 1;
          else
            start = mid + 1;
        }
      }
      if (found) pairs.emplace_back(i, static_cast<std::size_t>(mid));
    }
  }
  if (pairs.empty())
    throw Error("RPE: delta = " + std::to_string(o.delta) + " " + toString(o.unit) + " gives no pose pair among " +
                std::to_string(n) + " poses (try a smaller delta)");
  return pairs;
}

RpeResult computeRpe(const Trajectory& gt, const Trajectory& estAligned, const RpeOptions& options) {
  requireSameNonEmpty(gt, estAligned, "RPE");
  RpeResult r;
  r.pairs = selectRpePairs(estAligned, options);
  for (const auto& [i, j] : r.pairs) {
    // Eq. 2.103 error for one pair: E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j).
    const Eigen::Isometry3d E = relative(gt[i], gt[j]).inverse() * relative(estAligned[i], estAligned[j]);
    r.translationErrors.push_back(E.translation().norm());
    r.rotationErrorsDeg.push_back(rotationAngle(E.linear()) * 180.0 / M_PI);
  }
  r.translation = computeStatistics(r.translationErrors, "RPE translation");
  r.rotation = computeStatistics(r.rotationErrorsDeg, "RPE rotation");
  return r;
}

RotationErrorResult computeRotationError(const Trajectory& gt, const Trajectory& estAligned) {
  requireSameNonEmpty(gt, estAligned, "RE");
  RotationErrorResult r;
  for (std::size_t k = 0; k < gt.size(); ++k) {
    const Eigen::Vector3d zGt = gt[k].orientation.normalized() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d zEst = estAligned[k].orientation.normalized() * Eigen::Vector3d::UnitZ();
    // atan2(|a x b|, a.b) equals acos(a.b) of eq. 4.8 for unit vectors but stays accurate near 0 and 180.
    r.errorsDeg.push_back(std::atan2(zGt.cross(zEst).norm(), zGt.dot(zEst)) * 180.0 / M_PI);
  }
  r.stats = computeStatistics(r.errorsDeg, "RE");
  return r;
}

}  // namespace pslam::eval
