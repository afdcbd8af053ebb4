// End-to-end tests of map reuse (doc/maps.md): a map built by slam-run on one synthetic room path is saved,
// loaded again (byte-identical when saved again), localized in from another path through the same world
// (slam-synth --path-variant) with the map kept fixed byte for byte, extended when mapping stays on, and
// refused with one clear error naming the map file (missing, corrupt, other format version, other camera)
// without any output written. Everything is rendered in the test (a few seconds).
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <nlohmann/json.hpp>

#include "pslam/apps/SlamRunApp.h"
#include "pslam/core/Error.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/EvalApp.h"
#include "pslam/map/MapIO.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";

using test_support::errorOf;
using test_support::readBytes;

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_map_reuse_e2e");
  return root.path;
}

/// The room (seed 3, noise 1) on path `variant`: `frames` frames, optionally another focal length.
fs::path renderRoom(int variant, int frames, double fx = 0) {
  synth::SynthOptions o;
  o.scenario = "room";
  o.frames = frames;
  o.seed = 3;
  o.noiseSigma = 1.0;
  o.pathVariant = variant;
  o.fx = fx;
  o.name = "room_v" + std::to_string(variant) + (fx > 0 ? "_fx" : "");
  o.outDir = tempRoot() / "synth";
  o.progress = false;
  return synth::SynthApp(o).run().rawlog;
}

const fs::path& pathA() {
  static const fs::path p = renderRoom(0, 60);
  return p;
}
const fs::path& pathB() {
  static const fs::path p = renderRoom(1, 30);
  return p;
}
fs::path groundTruthOf(const fs::path& rawlog) {
  return rawlog.parent_path() / (rawlog.stem().string() + "_groundtruth.txt");
}

apps::SlamRunOptions runOptions(const fs::path& rawlog, const fs::path& out) {
  apps::SlamRunOptions o;
  o.config = kConfig;
  o.rawlog = rawlog;
  o.outDir = out;
  o.seed = 1;
  o.progress = false;
  return o;
}

/// The map-building run on path A (once per process).
const fs::path& runA() {
  static const fs::path out = [] {
    const fs::path d = tempRoot() / "runA";
    const apps::SlamRunSummary s = apps::SlamRunApp(runOptions(pathA(), d)).run();
    EXPECT_TRUE(s.initialized());
    return d;
  }();
  return out;
}

std::size_t filesIn(const fs::path& dir) {
  std::size_t n = 0;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  for (const auto& e : fs::directory_iterator(dir)) (void)e, ++n;
  return n;
}
}  // namespace

TEST(MapReuse, SavedLoadedAndSavedAgainIsByteIdentical) {
  const fs::path mapA = runA() / "map.slammap";
  system::System slam(system::loadSlamParams(kConfig.string()));
  slam.loadMap(mapA);
  const fs::path again = tempRoot() / "again.slammap";
  slam.saveMap(again);
  EXPECT_EQ(readBytes(mapA), readBytes(again));
  // Through slam-run: a localization run over one frame writes the input map back unchanged.
  apps::SlamRunOptions o = runOptions(pathA(), tempRoot() / "one_frame");
  o.mapIn = mapA;
  o.localization = true;
  o.first = o.last = 40;
  apps::SlamRunApp(o).run();
  EXPECT_EQ(readBytes(mapA), readBytes(o.outDir / "map.slammap"));
}

TEST(MapReuse, LocalizationInAnotherPathKeepsTheMapAndIsAccurate) {
  const fs::path mapA = runA() / "map.slammap";
  apps::SlamRunOptions o = runOptions(pathB(), tempRoot() / "localizeB");
  o.mapIn = mapA;
  o.localization = true;
  const apps::SlamRunSummary s = apps::SlamRunApp(o).run();
  EXPECT_TRUE(s.mapLoaded);
  EXPECT_EQ(s.framesProcessed, 30u);
  // Measured 30/30 (the room's variant 1 sees the walls the map was built from, from 15 % closer).
  EXPECT_GE(s.framesLocalized, 24u);
  EXPECT_EQ(s.firstLocalizedFrame, 0);
  EXPECT_EQ(readBytes(mapA), readBytes(o.outDir / "map.slammap")) << "localization changed the map";

  // report.json: one `localized` per frame, agreeing with the summary and the trajectory.
  std::ifstream in(o.outDir / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["localization"], true);
  EXPECT_EQ(report["mapping_enabled"], false);
  EXPECT_EQ(report["map_in"], mapA.string());
  ASSERT_EQ(report["frames"].size(), 30u);
  std::size_t localized = 0;
  for (const auto& f : report["frames"]) {
    ASSERT_TRUE(f.contains("localized") && f["localized"].is_boolean()) << f.dump();
    localized += f["localized"].get<bool>();
    EXPECT_FALSE(f["keyframe"].get<bool>());
  }
  EXPECT_EQ(localized, s.framesLocalized);
  EXPECT_EQ(report["summary"]["frames_localized"], s.framesLocalized);
  EXPECT_EQ(report["summary"]["frames_not_localized"], 30u - s.framesLocalized);
  EXPECT_EQ(readTumTrajectory(o.outDir / "trajectory.txt").size(), s.framesLocalized);

  // Position error with the Sim(3) of path A's run (no alignment fitted to path B): measured 0.015 m.
  eval::EvalOptions eo;
  eo.alignFromGt = groundTruthOf(pathA());
  eo.alignFromEst = runA() / "trajectory.txt";
  const eval::EvalResult r = eval::EvalApp(eo).run(groundTruthOf(pathB()), o.outDir / "trajectory.txt");
  EXPECT_TRUE(r.alignmentGiven);
  EXPECT_LT(r.ate.stats.rmse, 0.05) << r.ate.stats.rmse;
}

TEST(MapReuse, MappingGoesOnInALoadedMap) {
  const fs::path mapA = runA() / "map.slammap";
  apps::SlamRunOptions o = runOptions(pathB(), tempRoot() / "extendB");
  o.mapIn = mapA;
  const apps::SlamRunSummary s = apps::SlamRunApp(o).run();
  EXPECT_TRUE(s.mapLoaded);
  EXPECT_FALSE(s.localization);
  EXPECT_GE(s.framesLocalized, 24u);
  EXPECT_EQ(s.resets, 0u);
  // New keyframes (the path leaves the mapped views) extend the loaded map, whose ids continue.
  const map::Map loaded = map::loadMap(mapA), extended = map::loadMap(o.outDir / "map.slammap");
  EXPECT_GT(extended.nextKeyFrameId(), loaded.nextKeyFrameId());
  EXPECT_NE(readBytes(mapA), readBytes(o.outDir / "map.slammap"));
}

TEST(MapReuse, DirectPointsAreSavedWithTheMapAndLocalizeAnotherPath) {
  // map.slammap carries the direct points (extension "direct_points"): a localization run on path B uses them from
  // the loaded map (no host images: photometric factors from the host intensities they carry), keeps the map byte
  // for byte and is as accurate as the keypoints alone; a map whose direct points are damaged is refused naming the
  // file, nothing written.
  const std::vector<std::string> direct = {"DirectFeatures.enabled=true", "PointModel.model=probabilistic"};
  apps::SlamRunOptions a = runOptions(pathA(), tempRoot() / "directA");
  a.overrides = direct;
  ASSERT_TRUE(apps::SlamRunApp(a).run().initialized());
  const fs::path mapA = a.outDir / "map.slammap";
  const map::Map saved = map::loadMap(mapA);
  ASSERT_NE(saved.extension("direct_points"), nullptr);

  apps::SlamRunOptions o = runOptions(pathB(), tempRoot() / "directB");
  o.overrides = direct;
  o.mapIn = mapA;
  o.localization = true;
  const apps::SlamRunSummary s = apps::SlamRunApp(o).run();
  EXPECT_GE(s.framesLocalized, 24u);
  EXPECT_EQ(readBytes(mapA), readBytes(o.outDir / "map.slammap")) << "localization changed the map";
  std::ifstream in(o.outDir / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  long factors = 0, inliers = 0;
  for (const auto& f : report["frames"]) {
    factors += f["direct_factors"].get<long>();
    inliers += f["direct_inliers"].get<long>();
    // The report counts the points in view (read-only): the factors are the active ones among them (thinned).
    const long frameFactors = f["direct_factors"].get<long>(), active = f["direct_active"].get<long>();
    EXPECT_GE(active, frameFactors) << "frame " << f["index"];
    if (frameFactors > 0) {
      EXPECT_GT(active, 0L) << "frame " << f["index"];
    }
    EXPECT_GE(f["direct_inactive"].get<long>(), 0L);
  }
  EXPECT_GT(factors, 100L * static_cast<long>(s.framesLocalized)) << "the loaded direct points join the poses";
  EXPECT_GT(inliers, factors / 2);
  eval::EvalOptions eo;
  eo.alignFromGt = groundTruthOf(pathA());
  eo.alignFromEst = a.outDir / "trajectory.txt";
  const eval::EvalResult r = eval::EvalApp(eo).run(groundTruthOf(pathB()), o.outDir / "trajectory.txt");
  EXPECT_LT(r.ate.stats.rmse, 0.05) << r.ate.stats.rmse;

  map::Map damaged = saved;
  damaged.setExtension("direct_points", saved.extension("direct_points")->substr(0, 200));
  const fs::path bad = tempRoot() / "direct_damaged.slammap";
  map::saveMap(damaged, bad);
  apps::SlamRunOptions refused = runOptions(pathB(), tempRoot() / "direct_refused");
  refused.overrides = direct;
  refused.mapIn = bad;
  const std::string err = errorOf([&] { apps::SlamRunApp(refused).run(); });
  EXPECT_NE(err.find(bad.string() + ": direct points: truncated"), std::string::npos) << err;
  EXPECT_EQ(filesIn(refused.outDir), 0u);
}

TEST(MapReuse, BadMapsAreNamedAndNothingIsWritten) {
  const fs::path mapA = runA() / "map.slammap";
  const auto expectRefused = [&](const fs::path& map, const std::string& what, bool localization = true) {
    const fs::path out = tempRoot() / "refused";
    apps::SlamRunOptions o = runOptions(pathB(), out);
    o.mapIn = map;
    o.localization = localization;
    const std::string err = errorOf([&] { apps::SlamRunApp(o).run(); });
    EXPECT_NE(err.find(map.string()), std::string::npos) << err;
    EXPECT_NE(err.find(what), std::string::npos) << err;
    EXPECT_EQ(filesIn(out), 0u) << "outputs written for " << map;
  };
  expectRefused(tempRoot() / "missing.slammap", "map file not found");

  // Truncated: the gzip stream ends early.
  const std::string bytes = readBytes(mapA);
  const fs::path truncated = tempRoot() / "truncated.slammap";
  std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  expectRefused(truncated, "truncated.slammap");

  // Another format version: the version byte after the class name in MRPT's object header.
  std::string raw;
  {
    mrpt::io::CFileGZInputStream in(mapA.string());
    char buf[65536];
    std::size_t n = 0;
    while ((n = in.Read(buf, sizeof buf)) > 0) raw.append(buf, n);
  }
  const std::string name = map::CSlamMapArchive::className;
  const std::size_t pos = raw.find(name);
  ASSERT_NE(pos, std::string::npos);
  raw[pos + name.size()] = char(map::CSlamMapArchive::kFormatVersion + 1);
  const fs::path newer = tempRoot() / "newer.slammap";
  {
    mrpt::io::CFileGZOutputStream out(newer.string());
    out.Write(raw.data(), raw.size());
  }
  static_assert(map::CSlamMapArchive::kFormatVersion == 2, "the message below names the next version");
  expectRefused(newer, "unsupported .slammap format version 3", false);

  // The rawlog's camera differs from the map's (another focal length).
  const fs::path otherCamera = renderRoom(1, 2, 400.0);
  {
    const fs::path out = tempRoot() / "refused_camera";
    apps::SlamRunOptions o = runOptions(otherCamera, out);
    o.mapIn = mapA;
    const std::string err = errorOf([&] { apps::SlamRunApp(o).run(); });
    EXPECT_NE(err.find(mapA.string() + ": map camera (fx 481.2"), std::string::npos) << err;
    EXPECT_NE(err.find("differs from the camera of " + otherCamera.string() + " (fx 400"), std::string::npos) << err;
    EXPECT_EQ(filesIn(out), 0u);
  }

  // --localization needs a map.
  apps::SlamRunOptions o = runOptions(pathB(), tempRoot() / "no_map");
  o.localization = true;
  EXPECT_NE(errorOf([&] { apps::SlamRunApp(o).run(); }).find("--localization: needs --map-in"), std::string::npos);
  // The map may not be one of the outputs.
  o = runOptions(pathB(), runA());
  o.mapIn = mapA;
  EXPECT_NE(errorOf([&] { apps::SlamRunApp(o).run(); }).find("is the input"), std::string::npos);
  EXPECT_EQ(readBytes(mapA), bytes);
}

TEST(MapReuse, CliPrintsOneErrorLineForABadMap) {
  const fs::path exe = fs::path(PRIORSLAM_BINARY_DIR) / "bin/slam-run";
  if (!fs::exists(exe)) GTEST_SKIP() << "slam-run binary not built in this configuration";
  const fs::path err = tempRoot() / "cli_err.txt";
  const fs::path missing = tempRoot() / "nowhere.slammap";
  const std::string cmd = exe.string() + " --config " + kConfig.string() + " --rawlog " + pathB().string() +
                          " --map-in " + missing.string() + " --localization --out " +
                          (tempRoot() / "cli").string() + " -q 2> " + err.string();
  EXPECT_NE(std::system(cmd.c_str()), 0);
  const std::string text = readBytes(err);
  EXPECT_EQ(text, "slam-run: error: " + missing.string() + ": map file not found\n");
  EXPECT_EQ(filesIn(tempRoot() / "cli"), 0u);
}
