#include "pslam/eval/EvalApp.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Plot.h"

namespace pslam::eval {

void EvalOptions::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  params::load(*this, cfg, section);
  check();
}

void EvalOptions::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  params::save(*this, cfg, section);
}

void EvalOptions::check() const {
  params::check(*this, kSection);
  if (depthSamples.empty() != depthRawlog.empty())
    throw Error("DR needs both the map-point depth file and the rawlog with DEPTH");
  if (alignFromGt.empty() != alignFromEst.empty())
    throw Error("--align-from needs both a ground truth and an estimate");
  if (!alignFromGt.empty() && alignment == AlignmentMode::None)
    throw Error("--align-from needs an alignment (se3 or sim3), not none");
}

nlohmann::json EvalOptions::toJson() const {
  return {{"gt_format", toString(gtFormat)},
          {"est_format", toString(estFormat)},
          {"gt_times", gtTimes.string()},
          {"est_times", estTimes.string()},
          {"association", toString(association.rule)},
          {"max_time_difference", association.maxTimeDifference},
          {"time_offset", association.offset},
          {"alignment", toString(alignment)},
          {"align_first_n", alignFirstN},
          {"rpe", rpe},
          {"rpe_delta", rpeOptions.delta},
          {"rpe_delta_unit", toString(rpeOptions.unit)},
          {"rpe_all_pairs", rpeOptions.allPairs},
          {"rpe_relative_tolerance", rpeOptions.relativeTolerance},
          {"rotation_error", rotationError},
          {"segments", segments},
          {"dr_samples", depthSamples.string()},
          {"dr_rawlog", depthRawlog.string()},
          {"dr_tau", depthRatio.tau},
          {"dr_scale", depthRatio.scale},
          {"dr_max_time_difference", depthRatio.maxTimeDifference},
          {"dr_use_alignment_scale", depthUseAlignmentScale},
          {"align_from_ground_truth", alignFromGt.string()},
          {"align_from_estimate", alignFromEst.string()}};
}

EvalApp::EvalApp(EvalOptions options) : options_(std::move(options)) { options_.check(); }

namespace {
/// How --segments aligns each segment: the run's alignment mode, Sim(3) when the run is not aligned.
AlignmentMode segmentAlignmentMode(AlignmentMode runMode) {
  return runMode == AlignmentMode::None ? AlignmentMode::Sim3 : runMode;
}

/// Reads one trajectory file in the format the options give (or detect); KITTI without times: by index.
Trajectory readOne(const std::filesystem::path& path, TrajectoryFormat format, const std::filesystem::path& times,
                   bool& indexOnly) {
  const TrajectoryFormat f = format == TrajectoryFormat::Auto ? detectTrajectoryFormat(path) : format;
  Trajectory t = readTrajectory(path, f, times);
  if (t.empty()) throw Error(path.string() + ": no poses");
  // KITTI poses without times files carry only their index: timestamps would be meaningless.
  indexOnly = f == TrajectoryFormat::Kitti && times.empty();
  return t;
}
}  // namespace

namespace {
/// Refuses a trajectory that no evaluation can score: every pose at one stamp (nothing to associate in time), or,
/// when it is to be aligned, every pose at one position (a static ground truth makes the Sim(3) scale 0 and any
/// estimate "perfect"; a static estimate leaves the alignment undetermined). `what`: "ground truth" / "estimate".
void requireNotDegenerate(const Trajectory& t, const std::filesystem::path& path, bool indexOnly, bool aligned,
                          const char* what) {
  if (t.size() < 2) return;
  char buf[256];
  const bool sameStamp = std::all_of(t.begin(), t.end(), [&](const StampedPose& p) { return p.timestamp == t[0].timestamp; });
  if (sameStamp && !indexOnly) {
    std::snprintf(buf, sizeof buf, ": all %zu poses have the timestamp %.6f: the %s has no time to associate by",
                  t.size(), t[0].timestamp, what);
    throw Error(path.string() + buf);
  }
  if (!aligned) return;
  double spread = 0.0, size = 1.0;
  for (const StampedPose& p : t) {
    spread = std::max(spread, (p.position - t[0].position).norm());
    size = std::max(size, p.position.norm());
  }
  if (spread <= 1e-9 * size) {
    std::snprintf(buf, sizeof buf, ": all %zu poses are at one position (%g %g %g): a static %s cannot be aligned",
                  t.size(), t[0].position.x(), t[0].position.y(), t[0].position.z(), what);
    throw Error(path.string() + buf +
                (std::string(what) == "ground truth" ? " (the Sim(3) scale would be 0 and any estimate perfect)" : ""));
  }
}
}  // namespace

EvalResult EvalApp::run(const std::filesystem::path& gtPath, const std::filesystem::path& estPath) const {
  bool gtIndexOnly = false, estIndexOnly = false;
  const Trajectory gt = readOne(gtPath, options_.gtFormat, options_.gtTimes, gtIndexOnly);
  const Trajectory est = readOne(estPath, options_.estFormat, options_.estTimes, estIndexOnly);
  const bool aligned = options_.alignment != AlignmentMode::None && options_.alignFromGt.empty();
  requireNotDegenerate(gt, gtPath, gtIndexOnly, aligned, "ground truth");
  requireNotDegenerate(est, estPath, estIndexOnly, aligned, "estimate");
  std::vector<std::string> warnings;
  for (const auto& note : {duplicateStampNote(gt, gtPath), duplicateStampNote(est, estPath)})
    if (!note.empty()) warnings.push_back(note);
  EvalOptions effective = options_;
  if (gtIndexOnly || estIndexOnly) effective.association.rule = AssociationRule::ByIndex;
  EvalResult result;
  if (options_.alignFromGt.empty()) {
    result = EvalApp(effective).evaluate(gt, est);
  } else {
    // The alignment of the other pair (same formats and options; its files have no times files of their own).
    std::size_t pairs = 0;
    Alignment given;
    try {
      bool aGtIndexOnly = false, aEstIndexOnly = false;
      const Trajectory alignGt = readOne(options_.alignFromGt, options_.gtFormat, {}, aGtIndexOnly);
      const Trajectory alignEst = readOne(options_.alignFromEst, options_.estFormat, {}, aEstIndexOnly);
      EvalOptions alignOptions = effective;
      if (aGtIndexOnly || aEstIndexOnly) alignOptions.association.rule = AssociationRule::ByIndex;
      given = EvalApp(alignOptions).computeAlignment(alignGt, alignEst, &pairs);
    } catch (const Error& e) {
      throw Error("--align-from " + options_.alignFromGt.string() + " " + options_.alignFromEst.string() + ": " +
                  e.what());
    }
    result = EvalApp(effective).evaluate(gt, est, given, pairs);
  }
  result.warnings = std::move(warnings);
  return result;
}

Alignment EvalApp::computeAlignment(const Trajectory& gt, const Trajectory& est, std::size_t* pairs) const {
  const Association association = associate(gt, est, options_.association);
  Trajectory gtAssociated, estAssociated;
  selectAssociated(gt, est, association, gtAssociated, estAssociated);
  if (pairs) *pairs = gtAssociated.size();
  return alignTrajectories(gtAssociated, estAssociated, options_.alignment, options_.alignFirstN);
}

EvalResult EvalApp::evaluate(const Trajectory& gt, const Trajectory& est) const {
  return evaluateImpl(gt, est, nullptr, 0);
}

EvalResult EvalApp::evaluate(const Trajectory& gt, const Trajectory& est, const Alignment& given,
                             std::size_t givenPairs) const {
  return evaluateImpl(gt, est, &given, givenPairs);
}

EvalResult EvalApp::evaluateImpl(const Trajectory& gt, const Trajectory& est, const Alignment* given,
                                 std::size_t givenPairs) const {
  EvalResult r;
  r.gtPoses = gt.size();
  r.estPoses = est.size();
  r.ruleUsed = options_.association.rule;
  const Association association = associate(gt, est, options_.association);
  Trajectory estAssociated;
  selectAssociated(gt, est, association, r.gtAssociated, estAssociated);
  if (given) {
    if (r.gtAssociated.empty()) throw Error("no pose of the estimate is associated with the ground truth");
    r.alignment = *given;
    r.alignmentGiven = true;
    r.alignmentPairs = givenPairs;
  } else {
    r.alignment = alignTrajectories(r.gtAssociated, estAssociated, options_.alignment, options_.alignFirstN);
  }
  r.estAligned = applyAlignment(estAssociated, r.alignment);
  r.ate = computeAte(r.gtAssociated, r.estAligned);
  if (options_.rpe) r.rpe = computeRpe(r.gtAssociated, r.estAligned, options_.rpeOptions);
  if (options_.rotationError) r.rotationError = computeRotationError(r.gtAssociated, r.estAligned);
  if (options_.segments > 0) {
    r.segments = alignSegments(r.gtAssociated, estAssociated, segmentAlignmentMode(options_.alignment),
                               options_.segments);
  }
  if (!options_.depthSamples.empty()) {
    DepthRatioOptions dr = options_.depthRatio;
    if (options_.depthUseAlignmentScale) dr.scale *= r.alignment.scale;
    r.depthRatio = computeDepthRatio(readDepthSamples(options_.depthSamples), options_.depthRawlog, dr);
  }
  return r;
}

namespace {
std::string statsRow(const std::string& name, const ErrorStatistics& s) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%-16s %10.6f %10.6f %10.6f %10.6f %10.6f %10.6f %7zu", name.c_str(), s.rmse,
                s.mean, s.median, s.std, s.min, s.max, s.count);
  return buf;
}
}  // namespace

std::string EvalApp::formatTable(const EvalResult& r) const {
  std::ostringstream out;
  out << "poses: ground truth " << r.gtPoses << ", estimate " << r.estPoses << "; pairs " << r.gtAssociated.size()
      << " (association " << toString(r.ruleUsed);
  if (r.ruleUsed != AssociationRule::ByIndex)
    out << ", max dt " << options_.association.maxTimeDifference << " s, offset " << options_.association.offset
        << " s";
  out << ")\n";
  char buf[128];
  std::snprintf(buf, sizeof(buf), "%.6f", r.alignment.scale);
  out << "alignment: " << toString(options_.alignment) << " on "
      << (options_.alignFirstN == 0 ? std::string("all pairs") : "first " + std::to_string(options_.alignFirstN));
  if (r.alignmentGiven)
    out << " of " << options_.alignFromEst.string() << " vs " << options_.alignFromGt.string() << " ("
        << r.alignmentPairs << " pairs; not fitted to this estimate)";
  out << ", scale " << buf << "\n";
  std::snprintf(buf, sizeof(buf), "%-16s %10s %10s %10s %10s %10s %10s %7s", "metric", "rmse", "mean", "median",
                "std", "min", "max", "n");
  out << buf << "\n";
  out << statsRow("ATE [m]", r.ate.stats) << "\n";
  if (r.rpe) {
    std::ostringstream d;
    d << options_.rpeOptions.delta << " " << toString(options_.rpeOptions.unit)
      << (options_.rpeOptions.allPairs ? ", all pairs" : "");
    out << statsRow("RPE t [m]", r.rpe->translation) << "  delta " << d.str() << "\n";
    out << statsRow("RPE r [deg]", r.rpe->rotation) << "\n";
  }
  if (r.rotationError) out << statsRow("RE [deg]", r.rotationError->stats) << "  (eq. 4.8 = mean)\n";
  if (r.depthRatio) {
    std::snprintf(buf, sizeof(buf), "%.4f", r.depthRatio->ratio);
    out << "DR (tau " << options_.depthRatio.tau << "): " << buf << " (" << r.depthRatio->inliers << " / "
        << r.depthRatio->evaluated << " points, " << r.depthRatio->withoutGroundTruth << " without GT depth)\n";
  }
  if (!r.segments.empty()) {
    const AlignmentMode mode = segmentAlignmentMode(options_.alignment);
    out << "segments, each aligned on its own (" << toString(mode) << "):\n";
    std::snprintf(buf, sizeof(buf), "%7s %13s %18s %9s %10s %10s", "segment", "pairs", "time [s]", "path [m]",
                  "scale", "ATE [m]");
    out << buf << "\n";
    const double t0 = r.gtAssociated.front().timestamp;
    for (std::size_t k = 0; k < r.segments.size(); ++k) {
      const SegmentAlignment& g = r.segments[k];
      char pairs[64], span[64], row[256];
      std::snprintf(pairs, sizeof(pairs), "%zu-%zu", g.first, g.last);
      std::snprintf(span, sizeof(span), "%.2f-%.2f", g.startTime - t0, g.endTime - t0);
      std::snprintf(row, sizeof(row), "%7zu %13s %18s %9.3f %10.6f %10.6f", k + 1, pairs, span, g.pathLength,
                    g.alignment.scale, g.ate.rmse);
      out << row << "\n";
    }
    if (mode == AlignmentMode::Sim3) {
      const SegmentScaleRange scales = segmentScaleRange(r.segments);
      std::snprintf(buf, sizeof(buf), "segment scales %.6f-%.6f: largest / smallest - 1 = %.2f %%", scales.smallest,
                    scales.largest, 100.0 * scales.spread());
      out << buf << "\n";
    }
  }
  return out.str();
}

nlohmann::json EvalApp::toJson(const EvalResult& r) const {
  nlohmann::json j;
  j["options"] = options_.toJson();
  j["association_used"] = toString(r.ruleUsed);
  j["poses"] = {{"ground_truth", r.gtPoses}, {"estimate", r.estPoses}, {"pairs", r.gtAssociated.size()}};
  j["alignment"] = r.alignment.toJson();
  if (r.alignmentGiven)
    j["alignment_from"] = {{"ground_truth", options_.alignFromGt.string()},
                           {"estimate", options_.alignFromEst.string()},
                           {"pairs", r.alignmentPairs}};
  j["ate"] = r.ate.stats.toJson();
  if (r.rpe) {
    j["rpe"] = {{"translation", r.rpe->translation.toJson()},
                {"rotation_deg", r.rpe->rotation.toJson()},
                {"pairs", r.rpe->pairs.size()}};
  }
  if (r.rotationError) j["re_deg"] = r.rotationError->stats.toJson();
  if (r.depthRatio) j["dr"] = r.depthRatio->toJson();
  if (!r.segments.empty()) {
    j["segments"] = nlohmann::json::array();
    for (const SegmentAlignment& g : r.segments) j["segments"].push_back(g.toJson());
  }
  if (!r.warnings.empty()) j["warnings"] = r.warnings;
  return j;
}

void EvalApp::writeJson(const EvalResult& result, const std::filesystem::path& path) const {
  const nlohmann::json j = toJson(result);
  writeFileAtomically(path, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
}

std::vector<std::string> EvalApp::plotFileNames() const {
  std::vector<std::string> names{"eval_top_view.png", "eval_ate_over_time.png"};
  if (options_.rpe) {
    names.push_back("eval_rpe_over_time.png");
    names.push_back("eval_rpe_rot_over_time.png");
  }
  if (options_.segments > 0) names.push_back("eval_segments.png");
  return names;
}

std::vector<std::filesystem::path> EvalApp::inputFiles() const {
  std::vector<std::filesystem::path> files{options_.gtTimes,      options_.estTimes,    options_.depthSamples,
                                           options_.depthRawlog, options_.alignFromGt, options_.alignFromEst};
  if (!options_.depthRawlog.empty())
    files.push_back(options_.depthRawlog.parent_path() / (options_.depthRawlog.stem().string() + "_Images"));
  return files;
}

std::vector<std::filesystem::path> EvalApp::writePlots(const EvalResult& r, const std::filesystem::path& dir,
                                                       const std::string& titlePrefix) const {
  std::vector<std::filesystem::path> written;
  for (const auto& [name, plot] : makePlots(r, titlePrefix)) {
    written.push_back(dir / name);
    plot.save(written.back());
  }
  return written;
}

std::vector<std::pair<std::string, Plot>> EvalApp::makePlots(const EvalResult& r, const std::string& titlePrefix) const {
  std::vector<std::pair<std::string, Plot>> plots;
  const std::size_t n = r.gtAssociated.size();
  // Top view: the two world axes along which the ground truth spreads most (x-y for TUM/EuRoC, x-z KITTI).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : r.gtAssociated) mean += p.position;
  mean /= static_cast<double>(n);
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();
  for (const auto& p : r.gtAssociated) spread += (p.position - mean).cwiseAbs2();
  int a0 = 0, a1 = 1;
  {
    int smallest = 0;
    for (int k = 1; k < 3; ++k)
      if (spread(k) < spread(smallest)) smallest = k;
    a0 = smallest == 0 ? 1 : 0;
    a1 = smallest == 2 ? 1 : 2;
  }
  const char* axisName[] = {"x [m]", "y [m]", "z [m]"};
  std::vector<double> gx, gy, ex, ey;
  for (std::size_t k = 0; k < n; ++k) {
    gx.push_back(r.gtAssociated[k].position(a0));
    gy.push_back(r.gtAssociated[k].position(a1));
    ex.push_back(r.estAligned[k].position(a0));
    ey.push_back(r.estAligned[k].position(a1));
  }
  const bool byIndex = r.ruleUsed == AssociationRule::ByIndex;
  std::vector<double> t;
  for (const auto& p : r.gtAssociated) t.push_back(p.timestamp - r.gtAssociated.front().timestamp);
  const std::string timeLabel = byIndex ? "frame index" : "time [s]";
  const std::string align = " (" + toString(options_.alignment) + " aligned)";

  Plot top(titlePrefix + "Top view" + align, axisName[a0], axisName[a1]);
  top.style().equalAspect = true;
  top.addLine(gx, gy, "ground truth", colors::grey(), 2);
  top.addLine(ex, ey, "estimate", colors::black(), 1);
  top.addColoredScatter(ex, ey, r.ate.errors, "ATE error", "ATE [m]", 3);
  plots.emplace_back("eval_top_view.png", std::move(top));

  Plot ate(titlePrefix + "ATE over time" + align, timeLabel, "ATE [m]");
  ate.addLine(t, r.ate.errors, "ATE", colors::blue(), 2);
  ate.addLine({t.front(), t.back()}, {r.ate.stats.rmse, r.ate.stats.rmse}, "rmse", colors::red(), 1);
  ate.addLine({t.front(), t.back()}, {r.ate.stats.median, r.ate.stats.median}, "median", colors::green(), 1);
  plots.emplace_back("eval_ate_over_time.png", std::move(ate));

  if (r.rpe) {
    std::vector<double> tp;  // stamp of the pair's second pose, as evo's plots
    for (const auto& pr : r.rpe->pairs) tp.push_back(t[pr.second]);
    std::ostringstream d;
    d << options_.rpeOptions.delta << " " << toString(options_.rpeOptions.unit);
    Plot rt(titlePrefix + "RPE translation over time, delta " + d.str() + align, timeLabel, "RPE t [m]");
    rt.addLine(tp, r.rpe->translationErrors, "RPE t", colors::orange(), 2);
    rt.addLine({tp.front(), tp.back()}, {r.rpe->translation.rmse, r.rpe->translation.rmse}, "rmse", colors::red(), 1);
    plots.emplace_back("eval_rpe_over_time.png", std::move(rt));
    Plot rr(titlePrefix + "RPE rotation over time, delta " + d.str(), timeLabel, "RPE r [deg]");
    rr.addLine(tp, r.rpe->rotationErrorsDeg, "RPE r", colors::purple(), 2);
    rr.addLine({tp.front(), tp.back()}, {r.rpe->rotation.rmse, r.rpe->rotation.rmse}, "rmse", colors::red(), 1);
    plots.emplace_back("eval_rpe_rot_over_time.png", std::move(rr));
  }
  if (!r.segments.empty()) {
    // Each segment at its middle: with Sim(3), its scale against the whole run's (the scale drift along the path);
    // with SE(3), where every scale is 1, its own ATE.
    const bool sim3 = segmentAlignmentMode(options_.alignment) == AlignmentMode::Sim3;
    std::vector<double> mid, value;
    for (const SegmentAlignment& g : r.segments) {
      mid.push_back(0.5 * (g.startTime + g.endTime) - r.gtAssociated.front().timestamp);
      value.push_back(sim3 ? 100.0 * (g.alignment.scale / r.alignment.scale - 1.0) : g.ate.rmse);
    }
    Plot sg(titlePrefix + (sim3 ? "Segment scale against the whole run's (each segment Sim(3) aligned on its own)"
                                : "Segment ATE (each segment SE(3) aligned on its own)"),
            timeLabel + " (segment middle)", sim3 ? "scale / whole-run scale - 1 [%]" : "segment ATE [m]");
    sg.addLine(mid, value, sim3 ? "segment scale" : "segment ATE", colors::blue(), 2);
    sg.addScatter(mid, value, "", colors::blue(), 5);
    if (sim3) sg.addLine({mid.front(), mid.back()}, {0.0, 0.0}, "whole run", colors::grey(), 1);
    plots.emplace_back("eval_segments.png", std::move(sg));
  }
  return plots;
}

// ---------------------------------------------------------------------------------------- output files

EvalOutputFiles::EvalOutputFiles(const EvalApp& app, const std::filesystem::path& jsonPath,
                                 const std::filesystem::path& plotDir, std::vector<std::filesystem::path> inputs)
    : app_(app) {
  for (const auto& f : app.inputFiles()) inputs.push_back(f);
  outputs_ = std::make_unique<OutputSet>(std::move(inputs));
  if (!jsonPath.empty()) json_ = &outputs_->add(jsonPath);
  if (!plotDir.empty())
    for (const auto& name : app.plotFileNames()) plots_.push_back(&outputs_->add(plotDir / name));
}

EvalOutputFiles::~EvalOutputFiles() = default;

void EvalOutputFiles::write(const EvalResult& result) {
  if (json_) {
    const nlohmann::json j = app_.toJson(result);
    writeOutputFile(*json_, [&](std::ostream& out) { out << j.dump(2) << "\n"; });
  }
  if (!plots_.empty()) {
    const auto plots = app_.makePlots(result, "");
    if (plots.size() != plots_.size()) throw Error("slam-eval: internal error: plot count differs from the prepared files");
    for (std::size_t k = 0; k < plots.size(); ++k) plots[k].second.save(plots_[k]->tempPath());
  }
  outputs_->commit();
}



}  // namespace pslam::eval
