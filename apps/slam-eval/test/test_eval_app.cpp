#include <gtest/gtest.h>

#include <fstream>
#include <unistd.h>

#include <mrpt/config/CConfigFileMemory.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "TestUtil.h"
#include "pslam/core/Error.h"
#include "pslam/eval/EvalApp.h"

using namespace pslam;
using namespace pslam::eval;
using pslam::eval::test::makeSpiral;
using pslam::eval::test::TempDir;

namespace {
// Estimate = GT at scale 1/3 in another frame, with every second pose dropped and stamps jittered by 3 ms.
Trajectory monocularEstimate(const Trajectory& gt) {
  Trajectory est;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  for (std::size_t k = 0; k < gt.size(); k += 2) {
    StampedPose p = gt[k];
    p.timestamp += 0.003;
    p.position = R * p.position / 3.0 + Eigen::Vector3d(1, 2, 3);
    p.orientation = Eigen::Quaterniond(R) * p.orientation;
    est.push_back(p);
  }
  return est;
}
}  // namespace

TEST(EvalApp, EvaluatesFilesAndWritesJsonAndPlots) {
  TempDir d("app");
  const Trajectory gt = makeSpiral(200);
  writeTumTrajectory(d.path / "gt.txt", gt);
  writeTumTrajectory(d.path / "est.txt", monocularEstimate(gt));
  const EvalApp app(EvalOptions{});  // defaults: nearest 0.01 s (evo), Sim(3), RPE 1 frame
  EXPECT_EQ(app.options().association.rule, AssociationRule::Nearest);
  EXPECT_EQ(app.options().association.maxTimeDifference, 0.01);
  const EvalResult r = app.run(d.path / "gt.txt", d.path / "est.txt");
  EXPECT_EQ(r.gtAssociated.size(), 100u);
  EXPECT_NEAR(r.alignment.scale, 3.0, 1e-6);  // TUM files keep 9 significant digits
  EXPECT_LT(r.ate.stats.rmse, 1e-6);
  ASSERT_TRUE(r.rpe && r.rotationError);
  EXPECT_LT(r.rotationError->stats.mean, 1e-4);
  const std::string table = app.formatTable(r);
  EXPECT_NE(table.find("ATE [m]"), std::string::npos);
  EXPECT_NE(table.find("scale 3.000000"), std::string::npos) << table;

  app.writeJson(r, d.path / "out" / "res.json");
  std::ifstream jf(d.path / "out" / "res.json");
  const auto j = nlohmann::json::parse(jf);
  EXPECT_EQ(j["poses"]["pairs"].get<int>(), 100);
  EXPECT_NEAR(j["alignment"]["scale"].get<double>(), 3.0, 1e-6);
  EXPECT_EQ(j["options"]["alignment"].get<std::string>(), "sim3");

  const auto pngs = app.writePlots(r, d.path / "plots");
  ASSERT_EQ(pngs.size(), 4u);
  for (const auto& p : pngs) EXPECT_FALSE(cv::imread(p.string()).empty()) << p;
}

TEST(EvalApp, SegmentsShowWhereTheScaleDrifts) {
  // The estimate's scale is 1/3 on the first half of the path and 1/4 on the second (a map whose scale drifted):
  // one Sim(3) leaves an ATE, each half aligned on its own none, at its own scale.
  const Trajectory gt = makeSpiral(200);
  Trajectory est = monocularEstimate(gt);
  const Eigen::Vector3d join = est[50].position;
  for (std::size_t k = 50; k < est.size(); ++k) est[k].position = join + (est[k].position - join) * 0.75;
  EvalOptions o;
  o.rpe = false;
  o.segments = 2;
  const EvalApp app(o);
  const EvalResult r = app.evaluate(gt, est);
  EXPECT_GT(r.ate.stats.rmse, 0.01);
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_NEAR(r.segments[0].alignment.scale, 3.0, 1e-9);
  EXPECT_NEAR(r.segments[1].alignment.scale, 4.0, 1e-9);
  EXPECT_LT(r.segments[0].ate.rmse, 1e-9);
  EXPECT_LT(r.segments[1].ate.rmse, 1e-9);
  const std::string table = app.formatTable(r);
  EXPECT_NE(table.find("segments, each aligned on its own (sim3)"), std::string::npos) << table;
  EXPECT_NE(table.find("largest / smallest - 1 = 33.33 %"), std::string::npos) << table;
  const nlohmann::json j = app.toJson(r);
  ASSERT_EQ(j["segments"].size(), 2u);
  EXPECT_EQ(j["segments"][1]["first_pair"].get<int>(), 50);
  EXPECT_EQ(j["segments"][1]["last_pair"].get<int>(), 99);
  EXPECT_NEAR(j["segments"][1]["alignment"]["scale"].get<double>(), 4.0, 1e-9);
  EXPECT_EQ(j["options"]["segments"].get<int>(), 2);
  TempDir d("segments");
  const auto pngs = app.writePlots(r, d.path);
  ASSERT_EQ(pngs.size(), 3u);  // top view, ATE over time, segments (no RPE)
  EXPECT_EQ(pngs.back().filename(), "eval_segments.png");
  EXPECT_FALSE(cv::imread(pngs.back().string()).empty());
  EXPECT_EQ(app.plotFileNames().back(), "eval_segments.png");
  // Without the option: no segments in the table or the JSON.
  const EvalApp plain(EvalOptions{});
  const EvalResult p = plain.evaluate(gt, est);
  EXPECT_TRUE(p.segments.empty());
  EXPECT_EQ(plain.formatTable(p).find("segments"), std::string::npos);
  EXPECT_FALSE(plain.toJson(p).contains("segments"));
}

TEST(EvalApp, SE3LeavesTheScaleErrorAndKittiFilesAreIndexed) {
  TempDir d("app_se3");
  const Trajectory gt = makeSpiral(50);
  // KITTI files (no stamps): association falls back to the index.
  const auto writeKitti = [&](const std::filesystem::path& p, const Trajectory& t, double scale) {
    std::ofstream f(p);
    f.precision(12);
    for (const auto& s : t) {
      const Eigen::Matrix3d R = s.orientation.toRotationMatrix();
      const Eigen::Vector3d x = s.position * scale;
      for (int r = 0; r < 3; ++r) f << R(r, 0) << " " << R(r, 1) << " " << R(r, 2) << " " << x(r) << (r < 2 ? " " : "\n");
    }
  };
  writeKitti(d.path / "gt.txt", gt, 1.0);
  writeKitti(d.path / "est.txt", gt, 0.5);
  EvalOptions o;
  o.alignment = AlignmentMode::SE3;
  const EvalResult r = EvalApp(o).run(d.path / "gt.txt", d.path / "est.txt");
  EXPECT_EQ(r.ruleUsed, AssociationRule::ByIndex);
  EXPECT_EQ(r.gtAssociated.size(), 50u);
  EXPECT_GT(r.ate.stats.rmse, 0.1);
  o.alignment = AlignmentMode::Sim3;
  EXPECT_LT(EvalApp(o).run(d.path / "gt.txt", d.path / "est.txt").ate.stats.rmse, 1e-9);
}

TEST(EvalApp, OptionsFromConfigAndTheirChecksNameTheKey) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("slam_eval", "association", "tum");
  cfg.write("slam_eval", "alignment", "se3");
  cfg.write("slam_eval", "rpe_delta", 2.0);
  cfg.write("slam_eval", "rpe_delta_unit", "m");
  EvalOptions o;
  o.loadFromConfigFile(cfg, "slam_eval");
  EXPECT_EQ(o.association.rule, AssociationRule::OneToOneGreedy);
  EXPECT_EQ(o.alignment, AlignmentMode::SE3);
  EXPECT_EQ(o.rpeOptions.unit, DeltaUnit::Meters);
  // Round trip.
  mrpt::config::CConfigFileMemory saved;
  o.saveToConfigFile(saved, "s");
  EvalOptions back;
  back.loadFromConfigFile(saved, "s");
  EXPECT_EQ(back.toJson(), o.toJson());

  const auto expectKey = [](const std::string& key, const std::string& value) {
    mrpt::config::CConfigFileMemory c;
    c.write("s", key, value);
    EvalOptions x;
    try {
      x.loadFromConfigFile(c, "s");
      ADD_FAILURE() << key;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(key == "alignment" ? "alignment" : key), std::string::npos) << e.what();
    }
  };
  expectKey("max_time_difference", "-1");
  expectKey("rpe_delta", "0");
  expectKey("rpe_delta", "1.5");  // frames must be an integer
  expectKey("align_first_n", "-3");
  expectKey("alignment", "affine");
  expectKey("dr_tau", "0");
}

// The slam-eval ini (main: params::loadSectionFromFile): every bad value is one error naming file, section, key.
TEST(EvalApp, ConfigFileIsReadStrictly) {
  TempDir d("app_cfg");
  const auto errorFor = [&](const std::string& text, const std::string& section = "slam_eval") {
    const std::string path = (d.path / "eval.ini").string();
    std::ofstream(path) << text;
    EvalOptions o;
    try {
      params::loadSectionFromFile(o, path, section);
    } catch (const Error& e) {
      const std::string what = e.what();
      return what.rfind(path, 0) == 0 ? "F" + what.substr(path.size()) : what;
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("[slam_eval]\nassociation = tum\nmax_time_difference = 0.02\nrpe_delta_unit = m\nrpe_delta = 0.5\n"),
            "");
  EXPECT_EQ(errorFor("[slam_eval]\nassociation = one-to-one\nrpe_delta_unit = f\n"), "");  // the former aliases
  EXPECT_EQ(errorFor("[slam_eval]\nmax_time_difference = abc\n"),
            "F: [slam_eval] max_time_difference = abc: not a number");
  EXPECT_EQ(errorFor("[slam_eval]\nmax_time_difference = nan\n"),
            "F: [slam_eval] max_time_difference = nan: not a number");
  EXPECT_EQ(errorFor("[slam_eval]\nmax_time_difference = inf\n"),
            "F: [slam_eval] max_time_difference = inf: must be finite");
  EXPECT_EQ(errorFor("[slam_eval]\nmax_time_difference = 0.02 extra\n"),
            "F: [slam_eval] max_time_difference = 0.02 extra: not a number");
  EXPECT_EQ(errorFor("[slam_eval]\nalign_first_n = 2.5\n"), "F: [slam_eval] align_first_n = 2.5: not an integer");
  EXPECT_EQ(errorFor("[slam_eval]\nalign_first_n = 99999999999999999999\n"),
            "F: [slam_eval] align_first_n = 99999999999999999999: integer out of range [0, 18446744073709551615]");
  EXPECT_EQ(errorFor("[slam_eval]\nrpe = maybe\n"), "F: [slam_eval] rpe = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("[slam_eval]\nassociation = bogus\n"),
            "F: [slam_eval] association = bogus: must be one of nearest, evo, tum, one-to-one, index");
  EXPECT_EQ(errorFor("[slam_eval]\nmax_time_diference = 0.02\n"),
            "F: [slam_eval] max_time_diference: unknown key (did you mean max_time_difference?)");
  EXPECT_EQ(errorFor("[slam_eval]\nrpe = true\n[slam_evall]\nrpe = false\n"),
            "F: [slam_evall]: unknown section (did you mean slam_eval?)");
  EXPECT_EQ(errorFor("max_time_difference = 0.02\n"),
            "F:1: max_time_difference: key outside any section (the file needs a [Section] header before it)");
  EXPECT_EQ(errorFor("[slam_eval]\nrpe_delta = 2\n", "other"), "F: [slam_eval]: unknown section (did you mean other?)");
  EXPECT_EQ(errorFor("[slam_eval]\ndr_use_alignment_scale = true\nalignment = se3\n"),
            "F: [slam_eval] dr_use_alignment_scale = true: needs alignment = sim3");
  EXPECT_EQ(errorFor("[slam_eval]\ndr_tau = -1\n"), "F: [slam_eval] dr_tau = -1: must be > 0");
}

TEST(EvalApp, BadInputsGiveClearErrors) {
  TempDir d("app_bad");
  const Trajectory gt = makeSpiral(20);
  writeTumTrajectory(d.path / "gt.txt", gt);
  const EvalApp app(EvalOptions{});
  EXPECT_THROW(app.run(d.path / "missing.txt", d.path / "gt.txt"), Error);
  // Too few pairs for an alignment.
  writeTumTrajectory(d.path / "two.txt", Trajectory(gt.begin(), gt.begin() + 2));
  try {
    app.run(d.path / "gt.txt", d.path / "two.txt");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at least 3"), std::string::npos) << e.what();
  }
  // No overlap in time.
  Trajectory late = gt;
  for (auto& p : late) p.timestamp += 1000.0;
  writeTumTrajectory(d.path / "late.txt", late);
  EXPECT_THROW(app.run(d.path / "gt.txt", d.path / "late.txt"), Error);
  // Empty estimate.
  std::ofstream(d.path / "empty.txt") << "# nothing\n";
  EXPECT_THROW(app.run(d.path / "gt.txt", d.path / "empty.txt"), Error);
  // DR needs both inputs.
  EvalOptions o;
  o.depthSamples = d.path / "depths.txt";
  EXPECT_THROW(EvalApp{o}, Error);
}

TEST(EvalApp, AlignFromAppliesAnotherPairsAlignment) {
  TempDir d("align_from");
  // Path A and path B of one world; both estimates in one run frame (monocularEstimate's Sim(3)), B with a 5 cm
  // offset in that frame (= 15 cm in the world at scale 1/3).
  const Trajectory gtA = makeSpiral(200);
  Trajectory gtB = makeSpiral(120);
  for (auto& p : gtB) p.position += Eigen::Vector3d(0.5, -0.2, 0.1);
  const Trajectory estA = monocularEstimate(gtA);
  Trajectory estB = monocularEstimate(gtB);
  writeTumTrajectory(d.path / "gtA.txt", gtA);
  writeTumTrajectory(d.path / "estA.txt", estA);
  writeTumTrajectory(d.path / "gtB.txt", gtB);
  writeTumTrajectory(d.path / "estB.txt", estB);
  for (auto& p : estB) p.position += Eigen::Vector3d(0.05, 0, 0);
  writeTumTrajectory(d.path / "estB_off.txt", estB);

  EvalOptions o;
  o.alignFromGt = d.path / "gtA.txt";
  o.alignFromEst = d.path / "estA.txt";
  const EvalApp app(o);
  const EvalResult r = app.run(d.path / "gtB.txt", d.path / "estB.txt");
  EXPECT_TRUE(r.alignmentGiven);
  EXPECT_EQ(r.alignmentPairs, 100u);
  EXPECT_NEAR(r.alignment.scale, 3.0, 1e-6);
  EXPECT_LT(r.ate.stats.rmse, 1e-5);
  // The offset is not aligned away (a fitted alignment would absorb it entirely).
  const EvalResult off = app.run(d.path / "gtB.txt", d.path / "estB_off.txt");
  EXPECT_NEAR(off.ate.stats.rmse, 0.15, 1e-4);
  EXPECT_LT(EvalApp(EvalOptions{}).run(d.path / "gtB.txt", d.path / "estB_off.txt").ate.stats.rmse, 1e-5);
  // Reported in the table and the JSON.
  EXPECT_NE(app.formatTable(off).find("estA.txt vs " + (d.path / "gtA.txt").string() + " (100 pairs; not fitted"),
            std::string::npos)
      << app.formatTable(off);
  const nlohmann::json j = app.toJson(off);
  EXPECT_EQ(j["alignment_from"]["pairs"], 100);
  EXPECT_EQ(j["options"]["align_from_estimate"], (d.path / "estA.txt").string());
  // Errors: only one file, no alignment mode, a missing file named.
  EvalOptions half;
  half.alignFromGt = d.path / "gtA.txt";
  EXPECT_THROW(EvalApp{half}, Error);
  EvalOptions none = o;
  none.alignment = AlignmentMode::None;
  EXPECT_THROW(EvalApp{none}, Error);
  EvalOptions missing = o;
  missing.alignFromEst = d.path / "nope.txt";
  try {
    EvalApp(missing).run(d.path / "gtB.txt", d.path / "estB.txt");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nope.txt"), std::string::npos) << e.what();
  }
  // The pair may not be replaced by an output of the run.
  EXPECT_THROW(EvalOutputFiles(app, d.path / "estA.txt", {}, {}), Error);
}
