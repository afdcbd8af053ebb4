#pragma once
// A batch manifest (doc/batch.md): datasets x variants x seeds, and how to evaluate them. One run is one
// (dataset, variant, seed); its outputs live in their own folder <output>/<dataset>/<variant>/seed-<seed>.
//
//   name: ch3-kitti                      # optional, default: the file's stem
//   base: ../..                          # relative paths resolve against this (itself relative to the file)
//   output: batch/ch3-kitti              # where the run folders, results and plots go
//   slam_run: build/bin/slam-run         # optional, default: the slam-run next to slam-batch
//   datasets:
//     - {name: kitti_00, rawlog: rawlogs/kitti_00.rawlog, groundtruth: rawlogs/kitti_00_groundtruth.txt,
//        config: config/slam/kitti.ini, set: [..], first: 0, last: 199}
//   variants:
//     - {name: heuristic, set: [PointModel.model=heuristic]}          # config: overrides the dataset's
//   seeds: [1, 2, 3]
//   evaluation: {align: sim3, depth_ratio: false, association: nearest, max_time_difference: 0.01}
//
// Parsing is strict: unknown keys, wrong types, missing files, duplicate names and invalid configurations
// (each dataset x variant's ini with its overrides, loaded as slam-run would) are errors naming the manifest,
// the line and the key.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pslam/eval/EvalApp.h"

namespace pslam::batch {

struct DatasetSpec {
  std::string name;
  std::filesystem::path rawlog;
  std::filesystem::path groundTruth;
  std::filesystem::path config;         ///< default config of the variants (may be empty if each has one)
  std::vector<std::string> overrides;   ///< applied before the variant's
  std::optional<long long> first, last; ///< frame range (slam-run --first/--last)
};

struct VariantSpec {
  std::string name;
  std::filesystem::path config;        ///< empty: the dataset's
  std::vector<std::string> overrides;  ///< `Section.key=value`, after the dataset's
};

struct EvaluationSpec {
  eval::AlignmentMode alignment = eval::AlignmentMode::Sim3;
  eval::AssociationRule association = eval::AssociationRule::Nearest;
  double maxTimeDifference = 0.01;  ///< [s] evo's max_diff
  bool depthRatio = false;          ///< DR (eq. 2.104) from depths.txt and the rawlog's DEPTH channel
};

/// One run: what slam-run is given, and where its folder is.
struct RunSpec {
  std::size_t datasetIndex = 0, variantIndex = 0;
  std::uint32_t seed = 0;
  std::string id;                    ///< "<dataset>/<variant>/seed-<seed>": also its folder under the output
  std::filesystem::path config;      ///< effective ini file
  std::vector<std::string> overrides;
  std::string effectiveConfig;       ///< the ini text after overrides (SlamParams::toIniText)
  bool threaded = false;             ///< [System] threaded: local mapping in a second thread (2 CPUs)
  std::string hash;                  ///< 16 hex digits over effective config, rawlog identity, seed, range
};

struct Manifest {
  std::filesystem::path file;   ///< the manifest itself (absolute)
  std::string name;
  std::filesystem::path base;   ///< absolute
  std::filesystem::path output; ///< absolute
  std::filesystem::path slamRun;///< absolute; empty = next to slam-batch
  std::vector<DatasetSpec> datasets;
  std::vector<VariantSpec> variants;
  std::vector<std::uint32_t> seeds;
  EvaluationSpec evaluation;
  std::vector<RunSpec> runs;    ///< datasets x variants x seeds, in that order

  const DatasetSpec& dataset(const RunSpec& r) const { return datasets[r.datasetIndex]; }
  const VariantSpec& variant(const RunSpec& r) const { return variants[r.variantIndex]; }
  std::filesystem::path runFolder(const RunSpec& r) const { return output / r.id; }
  /// The run with this id, or nullptr.
  const RunSpec* findRun(const std::string& id) const;
};

/// Reads, validates and expands a manifest. `outputOverride` (non-empty) replaces its `output`. Throws
/// pslam::Error "<file>: line L: <what>" at the first problem.
Manifest loadManifest(const std::filesystem::path& file, const std::filesystem::path& outputOverride = {});

/// 64-bit FNV-1a of `text` as 16 lowercase hex digits (a change detector, not a cryptographic hash).
std::string fnv1aHex(const std::string& text);

/// Every file a manifest reads (itself, slam_run, each dataset's rawlog with its images folder, ground truth and
/// config, each variant's config): what no output of slam-batch may replace.
std::vector<std::filesystem::path> manifestInputs(const Manifest& m);
/// The files `collect` writes: results.csv, results.json, summary.md and ate_<dataset>.png under the output.
std::vector<std::filesystem::path> collectOutputs(const Manifest& m);

}  // namespace pslam::batch
