// priorslam.eval: association, alignment, ATE and RPE with the functions of libs/eval, in the order slam-eval
// applies them (apps/slam-eval/src/EvalApp.cpp: associate, select the pairs, align, apply, measure), so that the
// numbers are slam-eval's.
#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "Common.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Association.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/TrajectoryIO.h"

namespace pslam::python {

namespace {

using namespace pslam::eval;

/// A trajectory argument: a file (TUM, KITTI, EuRoC; format detected as slam-eval does) or an (N, 8) array.
struct TrajectoryInput {
  Trajectory poses;
  bool indexOnly = false;  ///< a KITTI file without times: poses carry only their index
};

bool isPath(const py::handle& o) { return py::isinstance<py::str>(o) || py::hasattr(o, "__fspath__"); }

/// Converted with the GIL held; a file is read later, without it.
struct PendingInput {
  std::filesystem::path path;
  Trajectory poses;
};

PendingInput pending(const py::handle& o, const std::string& what) {
  PendingInput p;
  if (isPath(o)) p.path = py::module_::import("os").attr("fspath")(o).cast<std::string>();
  else p.poses = trajectoryFromArray(o, what);
  return p;
}

TrajectoryInput load(PendingInput p) {
  TrajectoryInput in;
  if (p.path.empty()) {
    in.poses = std::move(p.poses);
    return in;
  }
  // As slam-eval reads its two files (EvalApp.cpp, readOne).
  const TrajectoryFormat format = detectTrajectoryFormat(p.path);
  in.poses = readTrajectory(p.path, format);
  if (in.poses.empty()) throw Error(p.path.string() + ": no poses");
  in.indexOnly = format == TrajectoryFormat::Kitti;
  return in;
}

struct Options {
  AssociationOptions association;
  AlignmentMode alignment = AlignmentMode::Sim3;
  std::size_t alignFirstN = 0;
};

Options options(const std::string& align, double maxDiff, const std::string& association, double offset,
                std::size_t alignFirstN) {
  Options o;
  o.alignment = parseAlignmentMode(align);
  o.association.rule = parseAssociationRule(association);
  if (!(std::isfinite(maxDiff) && maxDiff >= 0))
    throw Error("max_diff = " + std::to_string(maxDiff) + ": must be a finite number >= 0");
  if (!std::isfinite(offset)) throw Error("offset: must be finite");
  o.association.maxTimeDifference = maxDiff;
  o.association.offset = offset;
  o.alignFirstN = alignFirstN;
  return o;
}

/// The pairs and the aligned estimate: the first steps of every metric.
struct Aligned {
  std::size_t gtPoses = 0, estPoses = 0;
  AssociationRule ruleUsed = AssociationRule::Nearest;
  Association association;
  Trajectory gtAssociated, estAligned;
  Alignment alignment;
};

Aligned associateAndAlign(const TrajectoryInput& gt, const TrajectoryInput& est, Options o) {
  Aligned a;
  a.gtPoses = gt.poses.size();
  a.estPoses = est.poses.size();
  if (gt.indexOnly || est.indexOnly) o.association.rule = AssociationRule::ByIndex;
  a.ruleUsed = o.association.rule;
  a.association = associate(gt.poses, est.poses, o.association);
  Trajectory estAssociated;
  selectAssociated(gt.poses, est.poses, a.association, a.gtAssociated, estAssociated);
  a.alignment = alignTrajectories(a.gtAssociated, estAssociated, o.alignment, o.alignFirstN);
  a.estAligned = applyAlignment(estAssociated, a.alignment);
  return a;
}

struct AteOut {
  Aligned aligned;
  AteResult ate;
};

struct RpeOut {
  Aligned aligned;
  RpeResult rpe;
};

py::array_t<double> vectorArray(const std::vector<double>& v) {
  py::array_t<double> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

py::array_t<std::int64_t> indexArray(const std::vector<std::size_t>& v) {
  py::array_t<std::int64_t> out(static_cast<py::ssize_t>(v.size()));
  auto* d = out.mutable_data();
  for (std::size_t k = 0; k < v.size(); ++k) d[k] = static_cast<std::int64_t>(v[k]);
  return out;
}

py::array_t<double> matrixArray(const Eigen::MatrixXd& m) {
  py::array_t<double> out({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  auto r = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  return out;
}

/// Properties shared by AteResult and RpeResult.
template <class C, class Get>
void alignedProperties(C& cls, Get aligned) {
  cls.def_property_readonly("alignment", [aligned](const typename C::type& r) { return aligned(r).alignment; },
                            "the alignment fitted to the pairs (Alignment)")
      .def_property_readonly("gt_index", [aligned](const typename C::type& r) { return indexArray(aligned(r).association.gtIndex); },
                             "per pair: the index of its ground-truth pose")
      .def_property_readonly("est_index", [aligned](const typename C::type& r) { return indexArray(aligned(r).association.estIndex); },
                             "per pair: the index of its estimated pose")
      .def_property_readonly("gt_associated", [aligned](const typename C::type& r) { return trajectoryArray(aligned(r).gtAssociated); },
                             "(K, 8) ground-truth pose of each pair")
      .def_property_readonly("est_aligned", [aligned](const typename C::type& r) { return trajectoryArray(aligned(r).estAligned); },
                             "(K, 8) estimated pose of each pair after the alignment")
      .def_property_readonly("association",
                             [aligned](const typename C::type& r) { return eval::toString(aligned(r).ruleUsed); },
                             "the association rule used ('index' for a KITTI file without times)")
      .def_property_readonly("gt_poses", [aligned](const typename C::type& r) { return aligned(r).gtPoses; })
      .def_property_readonly("est_poses", [aligned](const typename C::type& r) { return aligned(r).estPoses; });
}

}  // namespace

void bindEval(py::module_& root) {
  py::module_ m = root.def_submodule(
      "eval",
      "Trajectory metrics with slam-eval's functions and defaults (doc/eval.md): evo's nearest-stamp association "
      "with max_diff 0.01 s, Sim(3) alignment (monocular), ATE and RPE. Trajectories are TUM / KITTI / EuRoC files "
      "(format detected) or (N, 8) arrays t, x, y, z, qx, qy, qz, qw (T_world_cam).");

  py::class_<ErrorStatistics>(m, "Statistics", "Statistics of per-pair errors (as slam-eval's table and JSON).")
      .def_readonly("rmse", &ErrorStatistics::rmse)
      .def_readonly("mean", &ErrorStatistics::mean)
      .def_readonly("median", &ErrorStatistics::median)
      .def_readonly("std", &ErrorStatistics::std, "standard deviation (ddof = 0, as evo)")
      .def_readonly("min", &ErrorStatistics::min)
      .def_readonly("max", &ErrorStatistics::max)
      .def_readonly("sse", &ErrorStatistics::sse)
      .def_readonly("count", &ErrorStatistics::count)
      .def("to_dict", [](const ErrorStatistics& s) { return toPython(s.toJson()); },
           "{rmse, mean, median, std, min, max, sse, count}: the JSON of slam-eval")
      .def("__repr__", [](const ErrorStatistics& s) {
        return "Statistics(" + py::str(toPython(s.toJson())).cast<std::string>() + ")";
      });

  py::class_<Alignment>(m, "Alignment", "p_gt ~ scale * rotation @ p_est + translation.")
      .def_readonly("scale", &Alignment::scale)
      .def_property_readonly("rotation", [](const Alignment& a) { return matrixArray(a.rotation); }, "3x3")
      .def_property_readonly("translation", [](const Alignment& a) { return vectorArray({a.translation.x(), a.translation.y(), a.translation.z()}); }, "(3,)")
      .def_property_readonly(
          "matrix",
          [](const Alignment& a) {
            Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
            S.topLeftCorner<3, 3>() = a.scale * a.rotation;
            S.topRightCorner<3, 1>() = a.translation;
            return matrixArray(S);
          },
          "4x4 [s R, t; 0 1]")
      .def("__repr__", [](const Alignment& a) {
        return "Alignment(scale=" + py::repr(py::float_(a.scale)).cast<std::string>() + ")";
      });

  py::class_<AteOut> ate(m, "AteResult", "Absolute trajectory error after the alignment.");
  ate.def_property_readonly("stats", [](const AteOut& r) { return r.ate.stats; }, "metres (Statistics)")
      .def_property_readonly("rmse", [](const AteOut& r) { return r.ate.stats.rmse; }, "stats.rmse, metres")
      .def_property_readonly("errors", [](const AteOut& r) { return vectorArray(r.ate.errors); }, "per pair, metres");
  alignedProperties(ate, [](const AteOut& r) -> const Aligned& { return r.aligned; });
  ate.def("__repr__", [](const AteOut& r) {
    return "AteResult(rmse=" + py::repr(py::float_(r.ate.stats.rmse)).cast<std::string>() +
           ", pairs=" + std::to_string(r.ate.stats.count) + ")";
  });

  py::class_<RpeOut> rpe(m, "RpeResult", "Relative pose error over pairs of poses `delta` apart (evo's definition).");
  rpe.def_property_readonly("translation", [](const RpeOut& r) { return r.rpe.translation; }, "metres (Statistics)")
      .def_property_readonly("rotation", [](const RpeOut& r) { return r.rpe.rotation; }, "degrees (Statistics)")
      .def_property_readonly(
          "pairs",
          [](const RpeOut& r) {
            py::array_t<std::int64_t> out({static_cast<py::ssize_t>(r.rpe.pairs.size()), py::ssize_t{2}});
            auto w = out.mutable_unchecked<2>();
            for (std::size_t k = 0; k < r.rpe.pairs.size(); ++k) {
              w(static_cast<py::ssize_t>(k), 0) = static_cast<std::int64_t>(r.rpe.pairs[k].first);
              w(static_cast<py::ssize_t>(k), 1) = static_cast<std::int64_t>(r.rpe.pairs[k].second);
            }
            return out;
          },
          "(M, 2) indices i, j into the associated pairs")
      .def_property_readonly("translation_errors", [](const RpeOut& r) { return vectorArray(r.rpe.translationErrors); })
      .def_property_readonly("rotation_errors_deg", [](const RpeOut& r) { return vectorArray(r.rpe.rotationErrorsDeg); });
  alignedProperties(rpe, [](const RpeOut& r) -> const Aligned& { return r.aligned; });
  rpe.def("__repr__", [](const RpeOut& r) {
    return "RpeResult(translation_rmse=" + py::repr(py::float_(r.rpe.translation.rmse)).cast<std::string>() +
           ", rotation_rmse_deg=" + py::repr(py::float_(r.rpe.rotation.rmse)).cast<std::string>() + ")";
  });

  m.def(
      "read_trajectory",
      [](const std::filesystem::path& path, const std::string& format, const std::filesystem::path& times) {
        const TrajectoryFormat f = parseTrajectoryFormat(format);
        Trajectory t;
        {
          py::gil_scoped_release release;
          t = readTrajectory(path, f, times);
        }
        return trajectoryArray(t);
      },
      py::arg("path"), py::arg("format") = "auto", py::arg("times") = std::filesystem::path(),
      "A trajectory file as an (N, 8) array t, x, y, z, qx, qy, qz, qw. format: auto | tum | kitti | euroc; "
      "times: a KITTI times file (else KITTI poses are stamped with their index).");

  m.def(
      "associate",
      [](const py::object& gt, const py::object& est, double maxDiff, const std::string& association, double offset) {
        const Options o = options("none", maxDiff, association, offset, 0);
        PendingInput g = pending(gt, "gt"), e = pending(est, "est");
        Association a;
        {
          py::gil_scoped_release release;
          const TrajectoryInput gi = load(std::move(g)), ei = load(std::move(e));
          AssociationOptions ao = o.association;
          if (gi.indexOnly || ei.indexOnly) ao.rule = AssociationRule::ByIndex;
          a = associate(gi.poses, ei.poses, ao);
        }
        return py::make_tuple(indexArray(a.gtIndex), indexArray(a.estIndex));
      },
      py::arg("gt"), py::arg("est"), py::arg("max_diff") = 0.01, py::arg("association") = "nearest",
      py::arg("offset") = 0.0,
      "Pairs the poses by timestamp: (gt_index, est_index) arrays. association: nearest (evo, default) | tum "
      "(associate.py: one-to-one) | index; offset is added to the estimate's stamps.");

  m.def(
      "ate",
      [](const py::object& gt, const py::object& est, const std::string& align, double maxDiff,
         const std::string& association, double offset, std::size_t alignFirstN) {
        const Options o = options(align, maxDiff, association, offset, alignFirstN);
        PendingInput g = pending(gt, "gt"), e = pending(est, "est");
        py::gil_scoped_release release;
        AteOut out;
        out.aligned = associateAndAlign(load(std::move(g)), load(std::move(e)), o);
        out.ate = computeAte(out.aligned.gtAssociated, out.aligned.estAligned);
        return out;
      },
      py::arg("gt"), py::arg("est"), py::arg("align") = "sim3", py::arg("max_diff") = 0.01,
      py::arg("association") = "nearest", py::arg("offset") = 0.0, py::arg("align_first_n") = 0,
      "ATE (RMSE of the position errors after the alignment) as slam-eval computes it. align: sim3 (default, "
      "monocular) | se3 | none; align_first_n: align on the first N pairs only (0 = all).");

  m.def(
      "rpe",
      [](const py::object& gt, const py::object& est, const std::string& align, double maxDiff,
         const std::string& association, double offset, std::size_t alignFirstN, double delta,
         const std::string& deltaUnit, bool allPairs, double relTol) {
        const Options o = options(align, maxDiff, association, offset, alignFirstN);
        RpeOptions ro;
        ro.delta = delta;
        ro.unit = parseDeltaUnit(deltaUnit);
        ro.allPairs = allPairs;
        ro.relativeTolerance = relTol;
        PendingInput g = pending(gt, "gt"), e = pending(est, "est");
        py::gil_scoped_release release;
        RpeOut out;
        out.aligned = associateAndAlign(load(std::move(g)), load(std::move(e)), o);
        out.rpe = computeRpe(out.aligned.gtAssociated, out.aligned.estAligned, ro);
        return out;
      },
      py::arg("gt"), py::arg("est"), py::arg("align") = "sim3", py::arg("max_diff") = 0.01,
      py::arg("association") = "nearest", py::arg("offset") = 0.0, py::arg("align_first_n") = 0,
      py::arg("delta") = 1.0, py::arg("delta_unit") = "frames", py::arg("all_pairs") = false,
      py::arg("rel_tol") = 0.1,
      "RPE (translation in metres, rotation in degrees) as slam-eval computes it: pairs `delta` frames (or metres, "
      "delta_unit='m') apart on the aligned estimate, consecutive or all_pairs; rel_tol: evo's relative delta "
      "tolerance (metres, all pairs).");
}

}  // namespace pslam::python
