// e2e: runs the slam-map executable as a user would (info text and JSON, export, one-line errors, exit codes).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "SyntheticMap.h"
#include "pslam/map/MapIO.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;

namespace {
const fs::path kExe = fs::path(PRIORSLAM_BINARY_DIR) / "bin" / "slam-map";

struct CliRun {
  int exitCode;
  std::string out, err;
};

CliRun runCli(const std::string& args, const fs::path& dir) {
  const fs::path errFile = dir / "stderr.txt";
  const std::string cmd = kExe.string() + " " + args + " 2>" + errFile.string();
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
  std::string out;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), pipe.get())) out += buf.data();
  const int status = pclose(pipe.release());
  std::string err;
  if (FILE* f = std::fopen(errFile.c_str(), "r")) {
    while (fgets(buf.data(), buf.size(), f)) err += buf.data();
    std::fclose(f);
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err};
}

struct TempDir : pslam::test_support::TempDir {
  TempDir() : pslam::test_support::TempDir("pslam_slam_map_cli") {}
};
}  // namespace

TEST(SlamMapCli, InfoAndExport) {
  ASSERT_TRUE(fs::exists(kExe)) << kExe;
  TempDir tmp;
  pslam::map::testing::SyntheticScene scene;
  const pslam::map::Map m = pslam::map::testing::buildSyntheticMap(5, 120, scene);
  const fs::path file = tmp.path / "m.slammap";
  pslam::map::saveMap(m, file);

  const CliRun text = runCli("info " + file.string(), tmp.path);
  EXPECT_EQ(text.exitCode, 0) << text.err;
  EXPECT_NE(text.out.find("keyframes:    5"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("format version 2"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("lines:        none stored"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("direct:       none stored"), std::string::npos) << text.out;
  // Direct points that do not fit the map are named, not counted.
  pslam::map::Map withDirect = m;
  withDirect.setExtension("direct_points", "PSDP");
  pslam::map::saveMap(withDirect, tmp.path / "d.slammap");
  const CliRun direct = runCli("info " + (tmp.path / "d.slammap").string(), tmp.path);
  EXPECT_EQ(direct.exitCode, 0) << direct.err;
  EXPECT_NE(direct.out.find("direct:       stored but unusable: direct points: truncated (at version)"),
            std::string::npos) << direct.out;

  const CliRun json = runCli("info " + file.string() + " --json", tmp.path);
  ASSERT_EQ(json.exitCode, 0) << json.err;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  EXPECT_EQ(j["keyframes"], 5);
  EXPECT_EQ(j["map_points"], m.numMapPoints());
  EXPECT_EQ(j["file_bytes"], fs::file_size(file));
  EXPECT_EQ(j["camera"]["width"], 640);

  const CliRun ex = runCli("export " + file.string() + " --ply " + (tmp.path / "m.ply").string() + " --png " +
                               (tmp.path / "top.png").string(), tmp.path);
  EXPECT_EQ(ex.exitCode, 0) << ex.err;
  EXPECT_TRUE(fs::is_regular_file(tmp.path / "m.ply"));
  EXPECT_TRUE(fs::is_regular_file(tmp.path / "top.png"));

  // The synthetic keypoints are exact projections: every level's residuals are zero.
  const CliRun res = runCli("residuals " + file.string(), tmp.path);
  EXPECT_EQ(res.exitCode, 0) << res.err;
  EXPECT_NE(res.out.find("level  observations"), std::string::npos) << res.out;
  const CliRun resJson = runCli("residuals " + file.string() + " --json", tmp.path);
  ASSERT_EQ(resJson.exitCode, 0) << resJson.err;
  const nlohmann::json r = nlohmann::json::parse(resJson.out);
  EXPECT_GT(r["all"]["count"].get<long>(), 0);
  EXPECT_LT(r["all"]["rms_px"].get<double>(), 1e-3);

  // The keyframe poses are the truth of these exact keypoints: every state has zero error.
  const fs::path gt = tmp.path / "gt.txt", curvedFile = tmp.path / "curved.slammap";
  {
    std::ofstream out(gt);
    pslam::map::testing::SyntheticScene curvedScene;
    const pslam::map::Map curved =
        pslam::map::testing::buildSyntheticMap(6, 120, curvedScene, 7, pslam::map::testing::poseOnCurve);
    pslam::map::saveMap(curved, curvedFile);
    for (const auto& [id, kf] : curved.keyFrames()) {
      const Eigen::Isometry3d T = kf.T_world_cam();
      const Eigen::Quaterniond q(T.linear());
      out << kf.timestamp << " " << T.translation().x() << " " << T.translation().y() << " " << T.translation().z()
          << " " << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
    }
  }
  const CliRun opt = runCli("optimum " + curvedFile.string() + " " + gt.string() + " --segments 2 --json", tmp.path);
  ASSERT_EQ(opt.exitCode, 0) << opt.err;
  const nlohmann::json o = nlohmann::json::parse(opt.out);
  ASSERT_EQ(o["stages"].size(), 4u);
  for (const auto& st : o["stages"]) EXPECT_LT(st["keyframe_ate_m"].get<double>(), 1e-4) << st.dump();
  const CliRun optText = runCli("optimum " + curvedFile.string() + " " + gt.string() + " --segments 1", tmp.path);
  EXPECT_EQ(optText.exitCode, 0) << optText.err;
  EXPECT_NE(optText.out.find("ba_from_groundtruth"), std::string::npos) << optText.out;
  const CliRun noGt = runCli("optimum " + file.string() + " " + (tmp.path / "none.txt").string(), tmp.path);
  EXPECT_EQ(noGt.exitCode, 1);
  EXPECT_EQ(std::count(noGt.err.begin(), noGt.err.end(), '\n'), 1) << noGt.err;
  EXPECT_NE(noGt.err.find("none.txt"), std::string::npos) << noGt.err;
}

TEST(SlamMapCli, BadInputIsOneErrorLineAndExitCodeOne) {
  TempDir tmp;
  const CliRun missing = runCli("info /nonexistent/x.slammap", tmp.path);
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.err, "slam-map: error: /nonexistent/x.slammap: map file not found\n");
  const CliRun residuals = runCli("residuals /nonexistent/x.slammap", tmp.path);
  EXPECT_EQ(residuals.exitCode, 1);
  EXPECT_EQ(residuals.err, "slam-map: error: /nonexistent/x.slammap: map file not found\n");
  const CliRun nothing = runCli("export /nonexistent/x.slammap", tmp.path);
  EXPECT_EQ(nothing.exitCode, 1);
  EXPECT_EQ(std::count(nothing.err.begin(), nothing.err.end(), '\n'), 1) << nothing.err;
  EXPECT_NE(nothing.err.find("nothing to export"), std::string::npos) << nothing.err;
}

// Reliability (doc/reliability.md): `export --width 65536 --height 65536` allocated 12.8 GB (and `--width 100000`
// printed OpenCV's out-of-memory text without naming the option); `optimum --segments 0` was accepted. Refused by
// the command line, naming the option and the value, before any map is read.
TEST(SlamMapCli, AbsurdSizesAndZeroSegmentsAreRefused) {
  TempDir tmp;
  const CliRun wide = runCli("export /nonexistent/x.slammap --png " + (tmp.path / "x.png").string() +
                                 " --width 65536 --height 65536",
                             tmp.path);
  EXPECT_NE(wide.exitCode, 0);
  EXPECT_NE(wide.err.find("--width: 65536: must be in [200, 16384]"), std::string::npos) << wide.err;
  const CliRun tall = runCli("export /nonexistent/x.slammap --png " + (tmp.path / "x.png").string() +
                                 " --height 100000",
                             tmp.path);
  EXPECT_NE(tall.err.find("--height: 100000: must be in [200, 16384]"), std::string::npos) << tall.err;
  EXPECT_FALSE(fs::exists(tmp.path / "x.png"));
  const CliRun zero = runCli("optimum /nonexistent/x.slammap /nonexistent/gt.txt --segments 0", tmp.path);
  EXPECT_NE(zero.exitCode, 0);
  EXPECT_NE(zero.err.find("--segments: 0: must be >= 1"), std::string::npos) << zero.err;
}
