// slam-eval: ATE / RPE / RE / DR of an estimated trajectory against ground truth (see doc/eval.md).
// Thin CLI around pslam::eval::EvalApp.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/eval/EvalApp.h"

int main(int argc, char** argv) {
  using namespace pslam::eval;
  using namespace pslam::params;  // cliCheck and its rules: the ini's strict parsing for command-line numbers
  CLI::App cli{"Trajectory evaluation: ATE, RPE, RE (thesis eq. 4.8) and DR (eq. 2.104), evo-compatible.\n"
               "Defaults are evo's (evo_ape / evo_rpe), except alignment: evo aligns only when asked, slam-eval\n"
               "aligns with Sim(3) (evo's -as) unless told otherwise, as monocular runs have no scale. The TUM\n"
               "benchmark scripts (associate.py, evaluate_ate.py) are reproduced with\n"
               "--association tum --max-diff 0.02 --align se3. See doc/eval.md."};
  const EvalOptions defaults;
  std::string gtPath, estPath, gtFormat = "auto", estFormat = "auto", assoc = "nearest", align = "sim3";
  std::string deltaUnit = "frames", configPath, configSection = "slam_eval", jsonPath, plotDir, gtTimes, estTimes;
  std::string depthSamples, depthRawlog;
  double maxDiff = defaults.association.maxTimeDifference, offset = 0.0, delta = 1.0, relTol = 0.1, tau = 0.1;
  std::size_t alignFirst = 0, segments = 0;
  bool allPairs = false, noRpe = false, drScale = false;
  cli.add_option("ground_truth", gtPath, "ground-truth trajectory (TUM, KITTI or EuRoC csv)")->required();
  cli.add_option("estimate", estPath, "estimated trajectory (TUM, KITTI or EuRoC csv)")->required();
  cli.add_option("--config", configPath, "MRPT ini file with the options (command-line flags given override it)");
  cli.add_option("--section", configSection, "section of --config")->capture_default_str();
  cli.add_option("--gt-format", gtFormat, "auto|tum|kitti|euroc")->capture_default_str();
  cli.add_option("--est-format", estFormat, "auto|tum|kitti|euroc")->capture_default_str();
  cli.add_option("--gt-times", gtTimes, "KITTI times file of the ground truth");
  cli.add_option("--est-times", estTimes, "KITTI times file of the estimate");
  auto* oAssoc = cli.add_option("--association", assoc, "nearest (evo's rule, default) | tum (TUM associate.py: one-to-one greedy) | index (KITTI)")
                     ->capture_default_str();
  auto* oMaxDiff = cli.add_option("--max-diff", maxDiff, "max. time difference for association [s]; default = evo's max_diff (TUM associate.py: 0.02)")
                      ->check(cliCheck<double>(atLeast(0)))
                      ->capture_default_str();
  auto* oOffset = cli.add_option("--offset", offset, "time offset added to the estimate's stamps [s]")
                     ->check(cliCheck<double>(finite()))
                     ->capture_default_str();
  auto* oAlign = cli.add_option("--align", align, "none|se3|sim3; default sim3 = evo's -as, for monocular runs (evo: none; TUM evaluate_ate.py: se3)")->capture_default_str();
  auto* oFirst = cli.add_option("--align-first", alignFirst, "align on the first N pairs only (0 = all)")
                    ->check(cliCheck<std::size_t>());
  std::vector<std::string> alignFrom;
  cli.add_option("--align-from", alignFrom,
                 "GT EST: apply the alignment fitted to this other pair (same --align, --align-first, association) "
                 "instead of fitting one to the estimate, e.g. a localization run in the map of EST")
      ->expected(2);
  auto* oDelta = cli.add_option("--delta", delta, "RPE delta (evo's default)")
                    ->check(cliCheck<double>(greaterThan(0)))
                    ->capture_default_str();
  auto* oUnit = cli.add_option("--delta-unit", deltaUnit, "RPE delta unit: frames|m (evo's default frames)")->capture_default_str();
  auto* oAll = cli.add_flag("--all-pairs", allPairs, "RPE over all pairs with the delta, not consecutive ones");
  auto* oTol = cli.add_option("--rel-tol", relTol, "RPE relative delta tolerance (metres, all pairs; evo's default)")
                  ->check(cliCheck<double>(atLeast(0)))
                  ->capture_default_str();
  auto* oNoRpe = cli.add_flag("--no-rpe", noRpe, "skip RPE");
  auto* oSegments = cli.add_option("--segments", segments,
                                   "also split the pairs into N consecutive segments, each aligned on its own (the "
                                   "alignment's mode; sim3 for none): per-segment scale and ATE show scale drift")
                        ->check(cliCheck<std::size_t>());
  cli.add_option("--depths", depthSamples, "map-point depths `timestamp u v depth` for DR");
  cli.add_option("--rawlog", depthRawlog, "rawlog whose DEPTH channel gives the GT depth for DR");
  auto* oTau = cli.add_option("--tau", tau, "DR relative depth error threshold (thesis eq. 2.104, Tateno et al.)")
                  ->check(cliCheck<double>(greaterThan(0)))
                  ->capture_default_str();
  auto* oDrScale = cli.add_flag("--dr-scale", drScale, "scale estimated depths by the Sim(3) alignment scale");
  cli.add_option("--json", jsonPath, "write the results as JSON (atomic)");
  cli.add_option("--plot-dir", plotDir, "write PNG plots into this folder");
  CLI11_PARSE(cli, argc, argv);

  try {
    EvalOptions o;
    // The file may hold only the one section (strict: unknown sections and keys are errors naming the file).
    if (!configPath.empty()) pslam::params::loadSectionFromFile(o, configPath, configSection);
    o.gtFormat = parseTrajectoryFormat(gtFormat);
    o.estFormat = parseTrajectoryFormat(estFormat);
    o.gtTimes = gtTimes;
    o.estTimes = estTimes;
    if (oAssoc->count() || configPath.empty()) o.association.rule = parseAssociationRule(assoc);
    if (oMaxDiff->count()) o.association.maxTimeDifference = maxDiff;
    if (oOffset->count()) o.association.offset = offset;
    if (oAlign->count() || configPath.empty()) o.alignment = parseAlignmentMode(align);
    if (oFirst->count()) o.alignFirstN = alignFirst;
    if (oDelta->count()) o.rpeOptions.delta = delta;
    if (oUnit->count()) o.rpeOptions.unit = parseDeltaUnit(deltaUnit);
    if (oAll->count()) o.rpeOptions.allPairs = allPairs;
    if (oTol->count()) o.rpeOptions.relativeTolerance = relTol;
    if (oNoRpe->count()) o.rpe = !noRpe;
    if (oSegments->count()) o.segments = segments;
    if (alignFrom.size() == 2) {
      o.alignFromGt = alignFrom[0];
      o.alignFromEst = alignFrom[1];
    }
    o.depthSamples = depthSamples;
    o.depthRawlog = depthRawlog;
    if (oTau->count()) o.depthRatio.tau = tau;
    if (oDrScale->count()) o.depthUseAlignmentScale = drScale;
    const EvalApp app(o);
    EvalOutputFiles outputs(app, jsonPath, plotDir, {gtPath, estPath, configPath});  // checked before the work
    const EvalResult result = app.run(gtPath, estPath);
    for (const auto& w : result.warnings) std::cerr << "slam-eval: warning: " << w << "\n";
    std::cout << app.formatTable(result);
    outputs.write(result);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "slam-eval: error: " << e.what() << "\n";
    return 1;
  }
}
