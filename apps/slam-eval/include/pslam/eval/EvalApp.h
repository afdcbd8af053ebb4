#pragma once
// The slam-eval application: reads a ground-truth and an estimated trajectory, associates, aligns and
// reports ATE, RPE, RE (and DR when map-point depths and a rawlog with DEPTH are given) as a text table,
// JSON and PNG plots. main() in apps/slam-eval only parses the command line into EvalOptions.
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "pslam/eval/Association.h"
#include "pslam/eval/DepthRatio.h"
#include "pslam/eval/Metrics.h"
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

 private:
  EvalOptions options_;
};

}  // namespace pslam::eval
