// End-to-end: line segments in the running system ([Lines] enabled, eq. 2.59) on a short rendered corridor clip:
// the run initializes and tracks, line factors take part in the frames' pose optimizations with inliers, lines
// are created at keyframes, the per-frame extraction is timed, and the run repeats byte for byte.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "pslam/apps/SlamRunApp.h"
#include "pslam/map/MapIO.h"
#include "pslam/synth/SynthApp.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
const fs::path kConfig = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam/synthetic.ini";
constexpr int kFrames = 60;

const fs::path& tempRoot() {
  static const test_support::TempDir root("pslam_lines_e2e");
  return root.path;
}

const fs::path& corridorRawlog() {
  static const fs::path rawlog = [] {
    synth::SynthOptions o;
    o.scenario = "corridor";
    o.frames = kFrames;
    o.seed = 1;
    o.outDir = tempRoot() / "synth";
    o.progress = false;
    return synth::SynthApp(o).run().rawlog;
  }();
  return rawlog;
}

apps::SlamRunSummary runSlam(const fs::path& out, const std::vector<std::string>& overrides,
                             const fs::path& mapIn = {}, bool localization = false) {
  apps::SlamRunOptions o;
  o.mapIn = mapIn;
  o.localization = localization;
  o.overrides = overrides;
  o.config = kConfig;
  o.rawlog = corridorRawlog();
  o.outDir = out;
  o.seed = 1;
  o.progress = false;
  return apps::SlamRunApp(o).run();
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(LinesE2E, CorridorTracksWithLineFactorsAndRepeatsBitForBit) {
  const fs::path a = tempRoot() / "lines_a", b = tempRoot() / "lines_b";
  const auto s = runSlam(a, {"Lines.enabled=true"});
  runSlam(b, {"Lines.enabled=true"});
  ASSERT_TRUE(s.initialized());
  EXPECT_GE(s.framesTracked, static_cast<std::size_t>(kFrames / 2));
  EXPECT_EQ(readText(a / "trajectory.txt"), readText(b / "trajectory.txt"));

  const auto report = nlohmann::json::parse(readText(a / "report.json"));
  int tracked = 0, withLines = 0;
  long detected = 0, factors = 0, inliers = 0;
  for (const auto& f : report["frames"]) {
    if (f["status"] != "tracking" || f["method"] == "initializer") continue;
    ++tracked;
    detected += f["lines_detected"].get<long>();
    factors += f["lines_factors"].get<long>();
    inliers += f["lines_inliers"].get<long>();
    withLines += f["lines_factors"].get<long>() > 0 ? 1 : 0;
  }
  ASSERT_GT(tracked, 10);
  EXPECT_EQ(detected, 40L * tracked) << "Table 4.1: 40 segments per frame";
  EXPECT_GT(withLines, tracked / 2) << "line factors should join most frames' poses";
  EXPECT_GT(inliers, 0);
  EXPECT_GT(inliers, factors / 2);
  long created = 0;
  for (const auto& m : report["mapping"]) created += m.value("lines_created", 0L);
  EXPECT_GT(created, 0);
  EXPECT_TRUE(report["timings"].contains("line_extraction"));
  EXPECT_TRUE(report["timings"].contains("line_factors"));
  ASSERT_FALSE(report["mapping"].empty());
  EXPECT_GT(report["mapping"].back().value("lines", 0L), 0) << "no line left in the store";
}

TEST(LinesE2E, TheLinesAreSavedWithTheMapAndALoadedMapTracksWithThem) {
  // map.slammap carries the line store (map extension "lines"): a localization run in the saved map tracks with
  // line factors from its first frames (no line is created: the map is fixed) and saves the same bytes; a map whose
  // line store is damaged is refused naming the file.
  const fs::path a = tempRoot() / "lines_map", loc = tempRoot() / "lines_loc";
  runSlam(a, {"Lines.enabled=true"});
  const auto report = nlohmann::json::parse(readText(a / "report.json"));
  const long lines = report["summary"].value("lines", 0L);
  ASSERT_GT(lines, 0);
  const auto s = runSlam(loc, {"Lines.enabled=true"}, a / "map.slammap", true);
  EXPECT_EQ(readText(loc / "map.slammap"), readText(a / "map.slammap")) << "localization keeps the map, lines too";
  const auto locReport = nlohmann::json::parse(readText(loc / "report.json"));
  EXPECT_EQ(locReport["summary"].value("lines", -1L), lines) << locReport["summary"].dump();
  long factors = 0, inliers = 0;
  for (const auto& f : locReport["frames"]) {
    factors += f["lines_factors"].get<long>();
    inliers += f["lines_inliers"].get<long>();
  }
  EXPECT_GT(s.framesLocalized, static_cast<std::size_t>(kFrames / 2));
  EXPECT_GT(inliers, 0) << "the loaded lines take part in tracking";
  EXPECT_GT(inliers, factors / 2);

  map::Map damaged = map::loadMap(a / "map.slammap");
  ASSERT_NE(damaged.extension("lines"), nullptr);
  damaged.setExtension("lines", damaged.extension("lines")->substr(0, 100));
  const fs::path bad = tempRoot() / "lines_damaged.slammap";
  map::saveMap(damaged, bad);
  const std::string e = test_support::errorOf([&] { runSlam(tempRoot() / "lines_bad", {"Lines.enabled=true"}, bad); });
  EXPECT_NE(e.find(bad.string()), std::string::npos) << e;
  EXPECT_NE(e.find("lines: truncated"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(tempRoot() / "lines_bad" / "map.slammap")) << "nothing written";
}
