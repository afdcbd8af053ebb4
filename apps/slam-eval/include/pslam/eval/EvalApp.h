#pragma once
// The slam-eval application: reads a ground-truth and an estimated trajectory, associates, aligns and
// reports ATE, RPE, RE (and DR when map-point depths and a rawlog with DEPTH are given) as a text table,
// JSON and PNG plots. main() in apps/slam-eval only parses the command line into EvalOptions.
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
#include "pslam/eval/Association.h"
#include "pslam/eval/DepthRatio.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/Plot.h"
#include "pslam/eval/TrajectoryIO.h"

namespace mrpt::config {
class CConfigFileBase;
}

namespace pslam::eval {

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
  std::filesystem::path depthSamples;  ///< DR input (`timestamp u v depth`); empty = no DR
  std::filesystem::path depthRawlog;   ///< rawlog with the DEPTH channel
  DepthRatioOptions depthRatio;
  bool depthUseAlignmentScale = false;  ///< multiply estimated depths by the Sim(3) scale

  /// Keys (section e.g. "slam_eval"): association (nearest|tum|index), max_time_difference, time_offset,
  /// alignment (none|se3|sim3), align_first_n, rpe (bool), rpe_delta, rpe_delta_unit (frames|m),
  /// rpe_all_pairs, rpe_relative_tolerance, rotation_error (bool), dr_tau, dr_scale, dr_max_time_difference,
  /// dr_use_alignment_scale.
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const;
  /// Throws pslam::Error naming the key of a nonsensical value.
  void check() const;
  nlohmann::json toJson() const;
};

struct EvalResult {
  std::size_t gtPoses = 0, estPoses = 0;
  AssociationRule ruleUsed = AssociationRule::Nearest;
  Trajectory gtAssociated;   ///< pair k: ground truth
  Trajectory estAligned;     ///< pair k: estimate after alignment
  Alignment alignment;
  AteResult ate;
  std::optional<RpeResult> rpe;
  std::optional<RotationErrorResult> rotationError;
  std::optional<DepthRatioResult> depthRatio;
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
  /// The files a run reads besides the two trajectories: times files, DR samples, DR rawlog and its images.
  std::vector<std::filesystem::path> inputFiles() const;

 private:
  friend class EvalOutputFiles;
  std::vector<std::pair<std::string, Plot>> makePlots(const EvalResult& result, const std::string& titlePrefix) const;
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
