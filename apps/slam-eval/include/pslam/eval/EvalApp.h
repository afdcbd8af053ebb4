#pragma once
// The slam-eval application: reads a ground-truth and an estimated trajectory, associates, aligns and
// reports ATE, RPE, RE (and DR when map-point depths and a rawlog with DEPTH are given) as a text table,
// JSON and PNG plots. main() in apps/slam-eval only parses the command line into EvalOptions.
#include <array>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Params.h"
#include "pslam/eval/Association.h"
#include "pslam/eval/DepthRatio.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/Plot.h"
#include "pslam/eval/TrajectoryIO.h"

namespace pslam::eval {

/// The names of the options' enums in an ini file (the first of a value is the one written).
constexpr std::array<std::pair<AssociationRule, const char*>, 5> enumNames(AssociationRule) {
  return {{{AssociationRule::Nearest, "nearest"},
           {AssociationRule::Nearest, "evo"},
           {AssociationRule::OneToOneGreedy, "tum"},
           {AssociationRule::OneToOneGreedy, "one-to-one"},
           {AssociationRule::ByIndex, "index"}}};
}
constexpr std::array<std::pair<AlignmentMode, const char*>, 3> enumNames(AlignmentMode) {
  return {{{AlignmentMode::None, "none"}, {AlignmentMode::SE3, "se3"}, {AlignmentMode::Sim3, "sim3"}}};
}
constexpr std::array<std::pair<DeltaUnit, const char*>, 5> enumNames(DeltaUnit) {
  return {{{DeltaUnit::Frames, "frames"},
           {DeltaUnit::Frames, "f"},
           {DeltaUnit::Meters, "m"},
           {DeltaUnit::Meters, "meters"},
           {DeltaUnit::Meters, "metres"}}};
}

struct EvalOptions {
  TrajectoryFormat gtFormat = TrajectoryFormat::Auto;
  TrajectoryFormat estFormat = TrajectoryFormat::Auto;
  std::filesystem::path gtTimes, estTimes;  ///< KITTI times files (optional)
  AssociationOptions association;           ///< default: evo's nearest rule and max_diff, 0.01 s
  /// Both KITTI files without times files: association by index is used automatically.
  AlignmentMode alignment = AlignmentMode::Sim3;  ///< monocular default
  std::size_t alignFirstN = 0;                    ///< 0 = all pairs
  bool rpe = true;
  RpeOptions rpeOptions;
  bool rotationError = true;
  /// > 0: the pairs also split into this many consecutive segments, each aligned on its own (alignSegments): the
  /// per-segment Sim(3) scales show scale drift along the path.
  std::size_t segments = 0;
  std::filesystem::path depthSamples;  ///< DR input (`timestamp u v depth`); empty = no DR
  std::filesystem::path depthRawlog;   ///< rawlog with the DEPTH channel
  DepthRatioOptions depthRatio;
  bool depthUseAlignmentScale = false;  ///< multiply estimated depths by the Sim(3) scale
  /// --align-from: the alignment is not fitted to this estimate but taken from another estimate of the same
  /// run coordinate frame and its ground truth (same association and alignment options), e.g. the map-building
  /// run whose map a localization run reused (doc/maps.md). Both empty = align the estimate itself.
  std::filesystem::path alignFromGt, alignFromEst;

  /// The ini keys (section e.g. [slam_eval], pslam/core/Params.h: strict, unknown keys are errors). The input
  /// files (formats, times, DR inputs) come from the command line only.
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_KEY(v, "association", association.rule, anyValue, "nearest (evo) | tum (associate.py, one-to-one) | index");
    PSLAM_KEY(v, "max_time_difference", association.maxTimeDifference, atLeast(0),
              "[s] association window (evo's max_diff)");
    PSLAM_KEY(v, "time_offset", association.offset, finite(), "[s] added to the estimate's stamps");
    PSLAM_KEY(v, "alignment", alignment, anyValue, "none | se3 | sim3 (monocular default)");
    PSLAM_KEY(v, "align_first_n", alignFirstN, anyValue, "align on the first N pairs only (0 = all)");
    PSLAM_KEY(v, "rpe", rpe, anyValue, "compute the RPE");
    PSLAM_KEY(v, "rpe_delta", rpeOptions.delta,
              satisfies([this](double d) {
                return std::isfinite(d) && d > 0 && (rpeOptions.unit != DeltaUnit::Frames || d == std::floor(d));
              }, "must be > 0 (a whole number when rpe_delta_unit = frames)"),
              "RPE delta");
    PSLAM_KEY(v, "rpe_delta_unit", rpeOptions.unit, anyValue, "frames | m");
    PSLAM_KEY(v, "rpe_all_pairs", rpeOptions.allPairs, anyValue, "RPE over all pairs with the delta");
    PSLAM_KEY(v, "rpe_relative_tolerance", rpeOptions.relativeTolerance, atLeast(0),
              "[m] RPE delta tolerance (all pairs, unit m)");
    PSLAM_KEY(v, "rotation_error", rotationError, anyValue, "compute RE (eq. 4.8)");
    PSLAM_KEY(v, "segments", segments, anyValue, "also align this many consecutive segments on their own (0 = off)");
    PSLAM_KEY(v, "dr_use_alignment_scale", depthUseAlignmentScale,
              satisfies([this](bool b) { return !b || alignment == AlignmentMode::Sim3; }, "needs alignment = sim3"),
              "multiply estimated depths by the Sim(3) scale");
    v.flat(depthRatio);
  }
  /// loadFromConfigFile / saveToConfigFile (section default slam_eval); check() throws params::ParamError naming
  /// the key of a nonsensical value, or pslam::Error when only one of the DR inputs is given.
  PSLAM_PARAMS("slam_eval")
  nlohmann::json toJson() const;
};

struct EvalResult {
  std::size_t gtPoses = 0, estPoses = 0;
  AssociationRule ruleUsed = AssociationRule::Nearest;
  Trajectory gtAssociated;   ///< pair k: ground truth
  Trajectory estAligned;     ///< pair k: estimate after alignment
  Alignment alignment;
  /// --align-from: the alignment came from that pair (alignmentPairs associated poses), not from this estimate.
  bool alignmentGiven = false;
  std::size_t alignmentPairs = 0;
  AteResult ate;
  std::optional<RpeResult> rpe;
  std::optional<RotationErrorResult> rotationError;
  std::optional<DepthRatioResult> depthRatio;
  std::vector<SegmentAlignment> segments;  ///< options.segments > 0: each segment aligned on its own
  /// Notes about the inputs, e.g. poses with the timestamp of the previous one (kept, as evo keeps them).
  std::vector<std::string> warnings;
};

class EvalApp {
 public:
  explicit EvalApp(EvalOptions options);
  const EvalOptions& options() const { return options_; }

  /// Reads both files (formats per options) and evaluates. Errors name the file.
  EvalResult run(const std::filesystem::path& gtPath, const std::filesystem::path& estPath) const;
  /// Evaluates trajectories in memory.
  EvalResult evaluate(const Trajectory& gt, const Trajectory& est) const;
  /// Evaluates with a given alignment (applied to the associated estimate instead of fitting one).
  EvalResult evaluate(const Trajectory& gt, const Trajectory& est, const Alignment& given,
                      std::size_t givenPairs) const;
  /// The alignment evaluate() fits to `est` and `gt` (association and alignment options); `pairs` = the number
  /// of associated poses it used.
  Alignment computeAlignment(const Trajectory& gt, const Trajectory& est, std::size_t* pairs = nullptr) const;

  /// Human-readable table (one line per metric).
  std::string formatTable(const EvalResult& result) const;
  /// Options, counts, alignment and all statistics.
  nlohmann::json toJson(const EvalResult& result) const;
  /// Writes the JSON atomically.
  void writeJson(const EvalResult& result, const std::filesystem::path& path) const;
  /// Writes eval_top_view.png, eval_ate_over_time.png and (if computed) eval_rpe_over_time.png into `dir`
  /// (each atomically); returns the written paths.
  std::vector<std::filesystem::path> writePlots(const EvalResult& result, const std::filesystem::path& dir,
                                                const std::string& titlePrefix = "") const;
  /// The file names of the plots writePlots() writes with these options.
  std::vector<std::string> plotFileNames() const;
  /// The files a run reads besides the two trajectories: times files, DR samples, DR rawlog and its images,
  /// the --align-from pair.
  std::vector<std::filesystem::path> inputFiles() const;

 private:
  friend class EvalOutputFiles;
  std::vector<std::pair<std::string, Plot>> makePlots(const EvalResult& result, const std::string& titlePrefix) const;
  EvalResult evaluateImpl(const Trajectory& gt, const Trajectory& est, const Alignment* given,
                          std::size_t givenPairs) const;
  EvalOptions options_;
};

/// The files of one slam-eval run (the JSON, the plots), prepared before the evaluation as one pslam::OutputSet:
/// none may be an input (`inputs`, plus app.inputFiles()) or replace a folder, and either all are written or none.
class EvalOutputFiles {
 public:
  /// Empty `jsonPath` / `plotDir`: no JSON / no plots. Throws pslam::Error naming the path at fault.
  EvalOutputFiles(const EvalApp& app, const std::filesystem::path& jsonPath, const std::filesystem::path& plotDir,
                  std::vector<std::filesystem::path> inputs);
  ~EvalOutputFiles();
  /// Writes `result` into every prepared output, then commits them all.
  void write(const EvalResult& result);

 private:
  const EvalApp& app_;
  std::unique_ptr<OutputSet> outputs_;
  AtomicOutput* json_ = nullptr;
  std::vector<AtomicOutput*> plots_;  // in the order of EvalApp::plotFileNames()
};

}  // namespace pslam::eval
