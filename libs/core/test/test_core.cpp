#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {
/// A fresh folder for one test in this process's temporary folder (removed when the process ends).
fs::path tempDir(const std::string& name) {
  static const pslam::test_support::TempDir root("pslam_test_core");
  return pslam::test_support::freshSubDir(root, name);
}
}  // namespace

TEST(Trajectory, TumRoundTripIsExactToPrintedPrecision) {
  const fs::path d = tempDir("roundtrip");
  Trajectory traj;
  for (int i = 0; i < 10; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.5 * i, -1.25 * i, 3.0);
    traj.emplace_back(1341846313.553 + 0.033 * i, T);
  }
  writeTumTrajectory(d / "t.txt", traj, "test");
  const Trajectory back = readTumTrajectory(d / "t.txt");
  ASSERT_EQ(back.size(), traj.size());
  for (std::size_t i = 0; i < traj.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp, traj[i].timestamp, 1e-6);
    EXPECT_LT((back[i].position - traj[i].position).norm(), 1e-7);
    EXPECT_LT(back[i].orientation.angularDistance(traj[i].orientation), 1e-7);
  }
}

TEST(Trajectory, MalformedLineNamesFileAndLine) {
  const fs::path d = tempDir("malformed");
  {
    std::ofstream f(d / "bad.txt");
    f << "# comment\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0\n";
  }
  try {
    readTumTrajectory(d / "bad.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:3"), std::string::npos) << e.what();
  }
  {
    std::ofstream f(d / "nan.txt");
    f << "1.0 nan 0 0 0 0 0 1\n";
  }
  EXPECT_THROW(readTumTrajectory(d / "nan.txt"), Error);
  {
    std::ofstream f(d / "zeroq.txt");
    f << "1.0 0 0 0 0 0 0 0\n";
  }
  EXPECT_THROW(readTumTrajectory(d / "zeroq.txt"), Error);
  EXPECT_THROW(readTumTrajectory(d / "missing.txt"), Error);
}

// Reliability (doc/reliability.md): NaN, inf and 1e999 were a "malformed TUM line"; the message says which value.
TEST(Trajectory, NonFiniteValuesAreNamed) {
  const fs::path d = tempDir("nonfinite");
  struct Case {
    std::string line, expected;
  };
  for (const Case& c : {Case{"1.0 nan 0 0 0 0 0 1", "bad.txt:1: tx = 'nan': not a finite number"},
                        Case{"1.0 0 0 inf 0 0 0 1", "bad.txt:1: tz = 'inf': not a finite number"},
                        Case{"1.0 0 0 0 0 0 0 1e999", "bad.txt:1: qw = '1e999': out of the range of a double"},
                        Case{"1e999 0 0 0 0 0 0 1", "bad.txt:1: timestamp = '1e999': out of the range of a double"},
                        Case{"1.0 0 0 0x 0 0 0 1", "bad.txt:1: tz = '0x': not a number"}}) {
    std::ofstream(d / "bad.txt") << c.line << "\n";
    try {
      readTumTrajectory(d / "bad.txt");
      ADD_FAILURE() << c.line;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
}

TEST(Trajectory, NearestPoseWithinTheWindowAgainstBruteForce) {
  Trajectory gt;
  for (double t : {1.00, 1.01, 1.03, 1.06, 1.10}) gt.emplace_back(t, Eigen::Isometry3d::Identity());
  EXPECT_EQ(nearestPose({}, 1.0, 1.0), nullptr);
  // Against the nearest by a scan (distances compared: which of two equally near is taken is not checked).
  for (double t = 0.95; t <= 1.16; t += 0.0017) {
    for (double maxDt : {0.0, 0.004, 0.02, 1.0}) {
      const StampedPose* brute = nullptr;
      for (const StampedPose& p : gt) {
        if (std::abs(p.timestamp - t) <= maxDt &&
            (!brute || std::abs(p.timestamp - t) < std::abs(brute->timestamp - t)))
          brute = &p;
      }
      const StampedPose* got = nearestPose(gt, t, maxDt);
      ASSERT_EQ(got == nullptr, brute == nullptr) << "t " << t << " maxDt " << maxDt;
      if (got) {
        EXPECT_DOUBLE_EQ(std::abs(got->timestamp - t), std::abs(brute->timestamp - t)) << t;
      }
    }
  }
  EXPECT_EQ(nearestPose(gt, 1.03, 0.0), &gt[2]);
  EXPECT_EQ(nearestPose(gt, 0.5, 0.2), nullptr);
  EXPECT_EQ(nearestPose(gt, 1.5, 0.2), nullptr);
}

TEST(Trajectory, CPose3DConversionRoundTrip) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.2, 0.9).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, 2, 3);
  const StampedPose p(5.0, T);
  const StampedPose q = StampedPose::fromCPose3D(5.0, p.toCPose3D());
  EXPECT_LT((q.T_world_cam().matrix() - T.matrix()).norm(), 1e-12);
}

TEST(AtomicOutput, UncommittedOutputLeavesNothing) {
  const fs::path d = tempDir("atomic");
  {
    AtomicOutput out(d / "result.txt");
    std::ofstream(out.tempPath()) << "partial";
    // destroyed without commit, as when an exception unwinds
  }
  EXPECT_TRUE(fs::is_empty(d));
  EXPECT_THROW(writeFileAtomically(d / "x.txt", [](std::ostream&) { throw Error("boom"); }), Error);
  EXPECT_TRUE(fs::is_empty(d));
  writeFileAtomically(d / "sub" / "ok.txt", [](std::ostream& os) { os << "ok"; });
  EXPECT_TRUE(fs::exists(d / "sub" / "ok.txt"));
}

// Reliability (doc/reliability.md): an output never replaces a folder, whatever that folder holds.
TEST(AtomicOutput, NeverReplacesAFolderWithAFile) {
  const fs::path d = tempDir("folder_target");
  fs::create_directories(d / "map.slammap");
  std::ofstream(d / "map.slammap" / "notes.txt") << "precious";
  try {
    writeFileAtomically(d / "map.slammap", [](std::ostream& os) { os << "new"; });
    ADD_FAILURE() << "a folder was replaced by a file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("map.slammap: is a folder; refusing to replace it with a file"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(fs::exists(d / "map.slammap" / "notes.txt"));
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST(StageTimings, PercentilesAndSummary) {
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 50), 3.0);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5}, 90), 4.6);
  EXPECT_TRUE(std::isnan(percentile({}, 50)));
  StageTimings t;
  t.add("a", 1.0);
  t.add("a", 3.0);
  const auto s = t.summary();
  EXPECT_EQ(s["a"]["count"].get<int>(), 2);
  EXPECT_DOUBLE_EQ(s["a"]["median_ms"].get<double>(), 2.0);
}

TEST(StageTimings, ScopedStageLeavesOutWhatItIsToldToExclude) {
  // A scope of about 100 ms of which all but 5 ms are excluded (a wait timed on its own) records about 5 ms; a
  // sleep only runs at least as long as asked, so the bounds are one-sided where they must be.
  StageTimings t;
  double outer = 0.0;
  {
    ScopedStage stage(t, "outer");
    const auto start = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    outer = msSince(start);
    stage.exclude(outer - 5.0);
  }
  const double recorded = t.samples().at("outer").front();
  EXPECT_GE(recorded, 5.0);
  EXPECT_LT(recorded, outer);  // without the exclusion it would be at least `outer`
}
