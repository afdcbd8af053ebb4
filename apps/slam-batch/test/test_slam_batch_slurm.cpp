// The Slurm back end against a real Slurm: scripts/slurm-local.sh starts a private single-node cluster on
// localhost (munge, slurmctld, slurmd); a 2 datasets x 2 variants x 1 seed manifest of short synthetic clips is
// submitted as one job array, followed with `status` (squeue) until done, collected, and compared with a local
// `run` of the same manifest: the same results.csv, byte for byte (sequential mode is deterministic). Skips, with
// the script's reason, where the daemons cannot start (exit code 77).
#include <cstdio>
#include <cstdlib>
#include <regex>
#include <thread>

#include <gtest/gtest.h>

#include "BatchTestData.h"

using namespace batchtest;

namespace {

const fs::path& root() {
  static const TempRoot r("pslam_batch_slurm_");
  return r.path;
}

/// Starts the cluster in the constructor and stops it in the destructor, whatever the test did.
struct LocalSlurm {
  fs::path dir = root() / "slurm";
  int startCode = -1;
  std::string startError;

  LocalSlurm() {
    const fs::path err = root() / "slurm-start.err";
    const ToolResult r = run("bash " + (kSource / "scripts/slurm-local.sh").string() + " start " + dir.string() +
                             " 2>" + err.string());
    startCode = r.exitCode;
    startError = readText(err);
    if (startCode != 0) return;
    // stdout: `export NAME=VALUE` lines for the clients (SLURM_CONF, ...)
    static const std::regex exportLine(R"(^export ([A-Za-z_][A-Za-z0-9_]*)=['"]?([^'"]*)['"]?$)");
    std::istringstream lines(r.output);
    for (std::string l; std::getline(lines, l);) {
      std::smatch m;
      if (std::regex_match(l, m, exportLine)) ::setenv(m[1].str().c_str(), m[2].str().c_str(), 1);
    }
  }
  ~LocalSlurm() {
    if (startCode == 0 || fs::exists(dir))
      run("bash " + (kSource / "scripts/slurm-local.sh").string() + " stop " + dir.string());
  }
};

}  // namespace

TEST(SlamBatchSlurm, JobArrayGivesTheSameResultsAsLocalRuns) {
  LocalSlurm slurm;
  if (slurm.startCode == 77) GTEST_SKIP() << "no local Slurm on this machine: " << slurm.startError;
  ASSERT_EQ(slurm.startCode, 0) << slurm.startError;
  ASSERT_NE(std::getenv("SLURM_CONF"), nullptr);

  const std::vector<Dataset> datasets = {{"room", render(root(), "room", 40, 3)},
                                         {"street", render(root(), "street", 30, 1)}};
  const fs::path manifest = writeManifest(root(), "slurm.yaml", datasets);
  const fs::path local = root() / "out_local", viaSlurm = root() / "out_slurm";

  const ToolResult localRun = run(batch("run " + manifest.string() + " --out " + local.string() + " -j 2 -q"));
  ASSERT_EQ(localRun.exitCode, 0) << localRun.output;

  const ToolResult submit = run(batch("submit " + manifest.string() + " --out " + viaSlurm.string() +
                                      " --backend slurm --time 00:10:00 --max-parallel 2"));
  ASSERT_EQ(submit.exitCode, 0) << submit.output;
  EXPECT_TRUE(std::regex_search(submit.output, std::regex(R"(^\d+\n)"))) << submit.output;
  EXPECT_NE(submit.output.find("submitted job array"), std::string::npos) << submit.output;

  // Follow it: squeue's view while it runs, done when every run folder is there.
  bool sawSlurmState = false;
  ToolResult status;
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    status = run(batch("status " + manifest.string() + " --out " + viaSlurm.string()));
    sawSlurmState = sawSlurmState || status.output.find("slurm:") != std::string::npos;
    if (status.exitCode != 3) break;  // 3: not all done yet
    ASSERT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(600)) << status.output;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  ASSERT_EQ(status.exitCode, 0) << status.output;
  EXPECT_NE(status.output.find("done 4"), std::string::npos) << status.output;
  EXPECT_TRUE(sawSlurmState) << "status never showed a run queued or running in Slurm";
  EXPECT_EQ(status.output.find("Slurm not asked"), std::string::npos) << status.output;

  const ToolResult collect = run(batch("collect " + manifest.string() + " --out " + viaSlurm.string() + " -q"));
  ASSERT_EQ(collect.exitCode, 0) << collect.output;
  const std::string csvLocal = readText(local / "results.csv"), csvSlurm = readText(viaSlurm / "results.csv");
  EXPECT_EQ(std::count(csvLocal.begin(), csvLocal.end(), '\n'), 5);
  EXPECT_EQ(csvSlurm, csvLocal);
  // Each task wrote its log; the array script and task list are kept.
  std::size_t logs = 0, scripts = 0;
  for (const auto& e : fs::recursive_directory_iterator(viaSlurm / "slurm")) {
    logs += e.path().extension() == ".out";
    scripts += e.path().extension() == ".sbatch";
  }
  EXPECT_EQ(logs, 4u);
  EXPECT_EQ(scripts, 1u);
  // Nothing left to submit.
  const ToolResult again = run(batch("submit " + manifest.string() + " --out " + viaSlurm.string()));
  EXPECT_EQ(again.exitCode, 0);
  EXPECT_NE(again.output.find("nothing to submit"), std::string::npos) << again.output;
}
