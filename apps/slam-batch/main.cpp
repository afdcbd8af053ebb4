// slam-batch: datasets x variants x seeds of slam-run, run locally or on Slurm, evaluated into tables and plots.
// Thin CLI around pslam::batch (apps/slam-batch/include/pslam/batch/BatchApp.h). See doc/batch.md.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <thread>

#include "pslam/batch/BatchApp.h"
#include "pslam/core/Error.h"

int main(int argc, char** argv) {
  using namespace pslam::batch;
  CLI::App cli{"Batch runs of slam-run from a YAML manifest (datasets x variants x seeds): run locally or submit to\n"
               "Slurm, follow their status, and collect results.csv / results.json / summary.md / box plots.\n"
               "See doc/batch.md."};
  cli.require_subcommand(1);
  CommonOptions common;
  auto addCommon = [&](CLI::App* sub) {
    sub->add_option("manifest", common.manifest, "the manifest (YAML)")->required();
    sub->add_option("--out", common.out, "output folder (overrides the manifest's `output`)");
    sub->add_flag("-q,--quiet", common.quiet, "no progress output");
  };

  std::size_t jobs = std::max(1u, std::thread::hardware_concurrency());
  bool noCollect = false;
  CLI::App* run = cli.add_subcommand("run", "run every run not done yet on this machine, then collect");
  addCommon(run);
  run->add_option("-j,--jobs", jobs, "slam-run processes at a time (default: the number of cores)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  run->add_flag("--no-collect", noCollect, "do not collect after the runs");

  std::string runId, backend = "slurm";
  std::string tasks;
  long long index = -1;
  CLI::App* one = cli.add_subcommand("run-one", "execute one run (what each Slurm array task calls)");
  addCommon(one);
  one->add_option("--run", runId, "run id <dataset>/<variant>/seed-<seed>");
  one->add_option("--tasks", tasks, "task list of a submission (one run id per line)");
  one->add_option("--index", index, "0-based line of --tasks (Slurm: $SLURM_ARRAY_TASK_ID)")->check(CLI::NonNegativeNumber);

  SlurmOptions slurm;
  CLI::App* submit = cli.add_subcommand("submit", "submit the runs not done yet as one Slurm job array");
  addCommon(submit);
  submit->add_option("--backend", backend, "scheduler (slurm)")->check(CLI::IsMember({"slurm"}))->capture_default_str();
  submit->add_option("--partition", slurm.partition, "sbatch --partition");
  submit->add_option("--time", slurm.time, "sbatch --time per run, e.g. 01:00:00");
  submit->add_option("--mem", slurm.mem, "sbatch --mem per run, e.g. 2G");
  submit->add_option("--max-parallel", slurm.maxParallel, "at most this many tasks at once (array %N; 0 = no limit)");
  submit->add_flag("--dry-run", slurm.dryRun, "write the sbatch script and task list, do not submit");

  bool verbose = false;
  CLI::App* status = cli.add_subcommand("status", "done / failed / stale / pending runs, and Slurm's state of submitted ones");
  addCommon(status);
  status->add_flag("-v,--verbose", verbose, "one line per run");

  CLI::App* coll = cli.add_subcommand("collect", "evaluate finished runs: results.csv, results.json, summary.md, ate_<dataset>.png");
  addCommon(coll);

  CLI11_PARSE(cli, argc, argv);
  try {
    if (*run) return commandRun(common, jobs, noCollect);
    if (*one) return commandRunOne(common, runId, tasks, index);
    if (*submit) return commandSubmit(common, slurm);
    if (*status) return commandStatus(common, verbose);
    if (*coll) return commandCollect(common);
  } catch (const std::exception& e) {
    std::cerr << "slam-batch: " << pslam::oneLineMessage(e) << "\n";
    return 1;
  }
  return 2;
}
