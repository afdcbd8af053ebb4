#include "pslam/batch/Collect.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "pslam/batch/Runs.h"
#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/eval/EvalApp.h"
#include "pslam/eval/Plot.h"

namespace pslam::batch {
namespace fs = std::filesystem;

std::optional<double> RunResult::trackedPercent() const {
  if (frames <= 0 || tracked < 0) return std::nullopt;
  return 100.0 * static_cast<double>(tracked) / static_cast<double>(frames);
}

std::optional<double> RunResult::cpuMsPerFrame() const {
  if (frames <= 0 || !(cpuSeconds > 0)) return std::nullopt;
  return 1000.0 * cpuSeconds / static_cast<double>(frames);
}

namespace {

/// %.6g: enough for the metrics, and the same text for the same double.
std::string num(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", *v);
  return buf;
}
std::string fixed(double v, int digits) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}
std::string intOrEmpty(long long v) { return v < 0 ? std::string() : std::to_string(v); }

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return out + "\"";
}

bool hasPoses(const fs::path& tum) {
  std::ifstream in(tum);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') return true;
  return false;
}

void readReport(const fs::path& report, RunResult& row) {
  std::ifstream in(report);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& s = j.at("summary");
  row.frames = s.at("frames_processed").get<long long>();
  row.tracked = s.at("frames_tracked").get<long long>();
  row.initFrame = s.at("initialized_at_frame").get<long long>();
  row.keyFrames = s.at("keyframes").get<long long>();
  row.mapPoints = s.at("map_points").get<long long>();
  row.resets = s.at("resets").get<long long>();
  row.relocalizations = s.at("relocalizations").get<long long>();
}

eval::EvalOptions evalOptions(const Manifest& m) {
  eval::EvalOptions o;
  o.alignment = m.evaluation.alignment;
  o.association.rule = m.evaluation.association;
  o.association.maxTimeDifference = m.evaluation.maxTimeDifference;
  return o;  // DR separately: the rawlog's depth frames are read once per dataset
}

}  // namespace

Spread spreadOf(std::vector<double> v) {
  Spread s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto q = [&](double p) {
    const double pos = p * static_cast<double>(v.size() - 1);
    const std::size_t i = static_cast<std::size_t>(std::floor(pos));
    const double f = pos - static_cast<double>(i);
    return i + 1 < v.size() ? v[i] + f * (v[i + 1] - v[i]) : v[i];
  };
  s.min = v.front();
  s.max = v.back();
  s.q1 = q(0.25);
  s.median = q(0.5);
  s.q3 = q(0.75);
  return s;
}

std::vector<RunResult> evaluateRuns(const Manifest& m, bool progress) {
  std::vector<RunResult> rows(m.runs.size());
  std::vector<std::size_t> withTrajectory;
  for (std::size_t i = 0; i < m.runs.size(); ++i) {
    const RunSpec& r = m.runs[i];
    RunResult& row = rows[i];
    row.run = &r;
    RunRecord rec;
    const RunState state = runState(m, r, &rec);
    const fs::path folder = m.runFolder(r);
    if (state != RunState::Pending) {
      row.wallSeconds = rec.wallSeconds;
      row.cpuSeconds = rec.cpuSeconds;
      row.host = rec.host;
      row.error = rec.error;
    }
    if (state != RunState::Done) {
      row.status = toString(state);
      continue;
    }
    try {
      readReport(folder / "report.json", row);
    } catch (const std::exception& e) {
      row.status = "eval-failed";
      row.error = (folder / "report.json").string() + ": " + oneLineMessage(e);
      continue;
    }
    if (!hasPoses(folder / "trajectory.txt")) {
      row.status = "no-trajectory";
      row.error = "never initialized";
      continue;
    }
    withTrajectory.push_back(i);
  }

  const eval::EvalApp app(evalOptions(m));
  std::size_t done = 0;
  for (std::size_t di = 0; di < m.datasets.size(); ++di) {
    std::vector<std::size_t> runs;
    for (std::size_t i : withTrajectory)
      if (m.runs[i].datasetIndex == di) runs.push_back(i);
    if (runs.empty()) continue;
    // DR: every run's depth samples first, then the rawlog's depth frames they refer to, read once.
    const eval::DepthRatioOptions drDefaults;
    std::vector<std::vector<eval::DepthSample>> samples(runs.size());
    std::vector<eval::DepthFrame> frames;
    std::string depthError;
    if (m.evaluation.depthRatio) {
      std::vector<double> stamps;
      for (std::size_t k = 0; k < runs.size(); ++k) {
        try {
          samples[k] = eval::readDepthSamples(m.runFolder(m.runs[runs[k]]) / "depths.txt");
        } catch (const std::exception& e) {
          rows[runs[k]].error = oneLineMessage(e);
        }
        for (const eval::DepthSample& s : samples[k]) stamps.push_back(s.timestamp);
      }
      try {
        frames = eval::readDepthFrames(m.datasets[di].rawlog, std::move(stamps), drDefaults.maxTimeDifference);
      } catch (const std::exception& e) {
        depthError = oneLineMessage(e);
      }
    }
    for (std::size_t k = 0; k < runs.size(); ++k) {
      RunResult& row = rows[runs[k]];
      const RunSpec& r = m.runs[runs[k]];
      try {
        const eval::EvalResult res = app.run(m.dataset(r).groundTruth, m.runFolder(r) / "trajectory.txt");
        row.posesEvaluated = res.ate.stats.count;
        row.ateRmse = res.ate.stats.rmse;
        row.ateMedian = res.ate.stats.median;
        if (res.rpe) row.rpeTranslationRmse = res.rpe->translation.rmse;
        if (res.rotationError) row.rotationErrorMean = res.rotationError->stats.mean;
        if (m.evaluation.depthRatio) {
          if (!depthError.empty()) throw Error(depthError);
          if (!row.error.empty()) throw Error(row.error);  // its depths.txt could not be read
          eval::DepthRatioOptions dr = drDefaults;
          if (m.evaluation.alignment == eval::AlignmentMode::Sim3) dr.scale *= res.alignment.scale;
          row.depthRatio = 100.0 * eval::computeDepthRatio(samples[k], frames, dr).ratio;
        }
        row.status = "ok";
      } catch (const std::exception& e) {
        row.status = "eval-failed";
        row.error = oneLineMessage(e);
      }
      ++done;
      if (progress)
        std::cerr << "slam-batch: collect [" << done << "/" << withTrajectory.size() << "] " << r.id << " "
                  << row.status << (row.ateRmse ? " ATE " + num(row.ateRmse) + " m" : std::string()) << "\n";
    }
  }
  return rows;
}

std::string resultsCsv(const Manifest& m, const std::vector<RunResult>& rows) {
  std::ostringstream os;
  os << "run,dataset,variant,seed,status,frames,tracked,tracked_pct,init_frame,keyframes,map_points,resets,"
        "relocalizations,poses_evaluated,ate_rmse_m,ate_median_m,rpe_t_rmse_m,re_mean_deg,dr_pct,error\n";
  for (const RunResult& r : rows) {
    os << r.run->id << ',' << m.dataset(*r.run).name << ',' << m.variant(*r.run).name << ',' << r.run->seed
       << ',' << r.status << ',' << intOrEmpty(r.frames) << ',' << intOrEmpty(r.tracked) << ','
       << num(r.trackedPercent()) << ',' << intOrEmpty(r.initFrame) << ',' << intOrEmpty(r.keyFrames) << ','
       << intOrEmpty(r.mapPoints) << ',' << intOrEmpty(r.resets) << ',' << intOrEmpty(r.relocalizations) << ','
       << (r.status == "ok" ? std::to_string(r.posesEvaluated) : std::string()) << ',' << num(r.ateRmse) << ','
       << num(r.ateMedian) << ',' << num(r.rpeTranslationRmse) << ',' << num(r.rotationErrorMean) << ','
       << num(r.depthRatio) << ',' << csvField(r.error) << '\n';
  }
  return os.str();
}

nlohmann::json resultsJson(const Manifest& m, const std::vector<RunResult>& rows) {
  auto opt = [](const std::optional<double>& v) -> nlohmann::json {
    return v && std::isfinite(*v) ? nlohmann::json(*v) : nlohmann::json();
  };
  nlohmann::json j;
  j["manifest"] = m.file.string();
  j["name"] = m.name;
  j["evaluation"] = {{"align", toString(m.evaluation.alignment)},
                     {"max_time_difference", m.evaluation.maxTimeDifference},
                     {"depth_ratio", m.evaluation.depthRatio}};
  for (const auto& [value, name] : eval::enumNames(eval::AssociationRule{}))
    if (value == m.evaluation.association) {
      j["evaluation"]["association"] = name;
      break;
    }
  nlohmann::json arr = nlohmann::json::array();
  for (const RunResult& r : rows) {
    arr.push_back({{"run", r.run->id},
                   {"dataset", m.dataset(*r.run).name},
                   {"variant", m.variant(*r.run).name},
                   {"seed", r.run->seed},
                   {"status", r.status},
                   {"error", r.error},
                   {"hash", r.run->hash},
                   {"frames", r.frames},
                   {"tracked", r.tracked},
                   {"tracked_pct", opt(r.trackedPercent())},
                   {"init_frame", r.initFrame},
                   {"keyframes", r.keyFrames},
                   {"map_points", r.mapPoints},
                   {"resets", r.resets},
                   {"relocalizations", r.relocalizations},
                   {"poses_evaluated", r.posesEvaluated},
                   {"ate_rmse_m", opt(r.ateRmse)},
                   {"ate_median_m", opt(r.ateMedian)},
                   {"rpe_t_rmse_m", opt(r.rpeTranslationRmse)},
                   {"re_mean_deg", opt(r.rotationErrorMean)},
                   {"dr_pct", opt(r.depthRatio)},
                   {"wall_s", r.wallSeconds},
                   {"cpu_s", r.cpuSeconds},
                   {"cpu_ms_per_frame", opt(r.cpuMsPerFrame())},
                   {"host", r.host}});
  }
  j["runs"] = arr;
  return j;
}

namespace {

using Getter = std::optional<double> (*)(const RunResult&);

/// One Markdown table: rows datasets, columns variants, cells "median [min, max] (n/N)" over seeds.
void metricTable(std::ostringstream& os, const Manifest& m, const std::vector<RunResult>& rows,
                 const std::string& title, Getter get, int digits) {
  os << "\n## " << title << "\n\n| dataset |";
  for (const VariantSpec& v : m.variants) os << ' ' << v.name << " |";
  os << "\n|---|";
  for (std::size_t i = 0; i < m.variants.size(); ++i) os << "---|";
  os << '\n';
  for (std::size_t di = 0; di < m.datasets.size(); ++di) {
    os << "| " << m.datasets[di].name << " |";
    for (std::size_t vi = 0; vi < m.variants.size(); ++vi) {
      std::vector<double> values;
      std::size_t total = 0;
      for (const RunResult& r : rows) {
        if (r.run->datasetIndex != di || r.run->variantIndex != vi) continue;
        ++total;
        if (const auto v = get(r); v && std::isfinite(*v)) values.push_back(*v);
      }
      if (values.empty()) {
        os << " - (0/" << total << ") |";
        continue;
      }
      const Spread s = spreadOf(values);
      os << ' ' << fixed(s.median, digits);
      if (values.size() > 1) os << " [" << fixed(s.min, digits) << ", " << fixed(s.max, digits) << "]";
      os << " (" << values.size() << "/" << total << ") |";
    }
    os << '\n';
  }
}

}  // namespace

std::string summaryMarkdown(const Manifest& m, const std::vector<RunResult>& rows) {
  std::map<std::string, std::size_t> counts;
  for (const RunResult& r : rows) counts[r.status]++;
  std::ostringstream os;
  os << "# slam-batch results: " << m.name << "\n\n"
     << rows.size() << " runs (" << m.datasets.size() << " datasets x " << m.variants.size() << " variants x "
     << m.seeds.size() << " seeds):";
  bool first = true;
  for (const auto& [status, n] : counts) {
    os << (first ? " " : ", ") << status << " " << n;
    first = false;
  }
  os << ". Cells: median over seeds [min, max] (runs with a value / runs). ATE, RPE and RE after "
     << toString(m.evaluation.alignment) << " alignment of each run's trajectory.txt (the tracked frames) to "
     << "its ground truth; a run that never initialized has no value.\n";
  metricTable(os, m, rows, "ATE RMSE [m]", [](const RunResult& r) { return r.ateRmse; }, 3);
  metricTable(os, m, rows, "Tracked frames [%]", [](const RunResult& r) { return r.trackedPercent(); }, 1);
  metricTable(os, m, rows, "RPE translation RMSE [m]", [](const RunResult& r) { return r.rpeTranslationRmse; }, 3);
  metricTable(os, m, rows, "RE mean [deg] (eq. 4.8)", [](const RunResult& r) { return r.rotationErrorMean; }, 2);
  if (m.evaluation.depthRatio)
    metricTable(os, m, rows, "DR [%] (eq. 2.104)", [](const RunResult& r) { return r.depthRatio; }, 1);
  metricTable(os, m, rows, "CPU [ms/frame] (slam-run process; depends on the machine)",
              [](const RunResult& r) { return r.cpuMsPerFrame(); }, 1);
  bool anyProblem = false;
  for (const RunResult& r : rows) {
    if (r.status == "ok" || r.status == "pending") continue;
    if (!anyProblem) os << "\n## Runs without metrics\n\n";
    anyProblem = true;
    os << "- `" << r.run->id << "`: " << r.status << (r.error.empty() ? "" : ": " + r.error) << '\n';
  }
  return os.str();
}

namespace {

eval::Plot atePlot(const Manifest& m, const std::vector<RunResult>& rows, std::size_t di) {
  eval::Plot plot("ATE RMSE per variant: " + m.datasets[di].name + " (" + m.name + ")",
                  "variant (1.." + std::to_string(m.variants.size()) + ", see legend)", "ATE RMSE [m]");
  plot.setXRange(0.4, static_cast<double>(m.variants.size()) + 0.6);
  double ymax = 0;
  for (std::size_t vi = 0; vi < m.variants.size(); ++vi) {
    std::vector<double> values;
    for (const RunResult& r : rows)
      if (r.run->datasetIndex == di && r.run->variantIndex == vi && r.ateRmse) values.push_back(*r.ateRmse);
    const double x = static_cast<double>(vi + 1), w = 0.25;
    const cv::Scalar color = eval::colors::cycle(vi);
    const std::string label = std::to_string(vi + 1) + " " + m.variants[vi].name + " (" +
                              std::to_string(values.size()) + " runs)";
    if (values.empty()) {
      plot.addScatter({}, {}, label + ": no value", color, 4);
      continue;
    }
    const Spread s = spreadOf(values);
    ymax = std::max(ymax, s.max);
    const double nan = std::nan("");
    // box (q1..q3), median, whiskers to min and max, as one broken polyline
    std::vector<double> xs = {x - w, x + w, x + w, x - w, x - w, nan, x - w, x + w, nan, x, x, nan, x, x,
                              nan, x - w / 2, x + w / 2, nan, x - w / 2, x + w / 2};
    std::vector<double> ys = {s.q1, s.q1, s.q3, s.q3, s.q1, nan, s.median, s.median, nan, s.q3, s.max, nan,
                              s.q1, s.min, nan, s.max, s.max, nan, s.min, s.min};
    plot.addLine(xs, ys, label, color, 2);
    plot.addScatter(std::vector<double>(values.size(), x), values, "", color, 4);
  }
  plot.setYRange(0, ymax > 0 ? ymax * 1.1 : 1.0);
  return plot;
}

}  // namespace

std::vector<fs::path> collect(const Manifest& m, const std::vector<RunResult>& rows) {
  OutputSet outputs(manifestInputs(m));
  const std::string csv = resultsCsv(m, rows);
  const nlohmann::json json = resultsJson(m, rows);
  const std::string md = summaryMarkdown(m, rows);
  std::vector<fs::path> paths;
  auto text = [&](const fs::path& p, const std::string& content) {
    AtomicOutput& out = outputs.add(p);
    writeOutputFile(out, [&](std::ostream& os) { os << content; });
    paths.push_back(p);
  };
  text(m.output / "results.csv", csv);
  text(m.output / "results.json", json.dump(1) + "\n");
  text(m.output / "summary.md", md);
  for (std::size_t di = 0; di < m.datasets.size(); ++di) {
    const fs::path p = m.output / ("ate_" + m.datasets[di].name + ".png");
    AtomicOutput& out = outputs.add(p);
    eval::savePngAtomically(out.tempPath(), atePlot(m, rows, di).render());
    paths.push_back(p);
  }
  outputs.commit();
  return paths;
}

}  // namespace pslam::batch
