#include <gtest/gtest.h>

#include <unistd.h>

#include "TestUtil.h"
#include "pslam/core/Error.h"
#include "pslam/eval/TrajectoryIO.h"

using namespace pslam::eval;
using pslam::eval::test::TempDir;

namespace {
// Expects `fn` to throw pslam::Error whose message contains every string of `parts`.
template <typename Fn>
void expectErrorContaining(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception";
  } catch (const pslam::Error& e) {
    for (const auto& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(TrajectoryIO, DetectsTheThreeFormats) {
  TempDir d("detect");
  const auto tum = d.write("a.txt", "# c\n1.0 0 0 0 0 0 0 1\n");
  const auto kitti = d.write("b.txt", "1 0 0 1 0 1 0 2 0 0 1 3\n");
  const auto euroc = d.write("c.csv", "#timestamp, x\n1403715524907143168,0.5,2.0,0.9,0.16,0.79,-0.2,0.55,0,0,0\n");
  EXPECT_EQ(detectTrajectoryFormat(tum), TrajectoryFormat::Tum);
  EXPECT_EQ(detectTrajectoryFormat(kitti), TrajectoryFormat::Kitti);
  EXPECT_EQ(detectTrajectoryFormat(euroc), TrajectoryFormat::Euroc);
  expectErrorContaining([&] { detectTrajectoryFormat(d.write("e.txt", "# only comments\n")); }, {"e.txt", "no data"});
  expectErrorContaining([&] { detectTrajectoryFormat(d.write("f.txt", "1 2 3\n")); }, {"f.txt:1", "3 values"});
  expectErrorContaining([&] { detectTrajectoryFormat(d.path / "missing.txt"); }, {"missing.txt", "cannot open"});
}

TEST(TrajectoryIO, ReadsKittiWithAndWithoutTimes) {
  TempDir d("kitti");
  // Rotation of 90 deg about z: rows (0 -1 0), (1 0 0), (0 0 1).
  const auto f = d.write("k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n0 -1 0 1 1 0 0 2 0 0 1 3\n");
  auto t = readKittiTrajectory(f);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_DOUBLE_EQ(t[1].timestamp, 1.0);  // index-based
  EXPECT_TRUE(t[1].position.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE((t[1].orientation * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  const auto times = d.write("times.txt", "0.0\n0.1\n");
  t = readKittiTrajectory(f, times);
  EXPECT_DOUBLE_EQ(t[1].timestamp, 0.1);
  expectErrorContaining([&] { readKittiTrajectory(f, d.write("t3.txt", "0\n0.1\n0.2\n")); }, {"t3.txt", "more times"});
  expectErrorContaining([&] { readKittiTrajectory(f, d.write("t1.txt", "0\n")); }, {"t1.txt", "1 times for 2 poses"});
  expectErrorContaining([&] { readKittiTrajectory(d.write("bad.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0\n")); },
                        {"bad.txt:2", "12 numbers"});
  expectErrorContaining([&] { readKittiTrajectory(d.write("nan.txt", "1 0 0 nan 0 1 0 0 0 0 1 0\n")); },
                        {"nan.txt:1", "NaN"});
  expectErrorContaining([&] { readKittiTrajectory(d.write("rot.txt", "2 0 0 0 0 1 0 0 0 0 1 0\n")); },
                        {"rot.txt:1", "not a rotation"});
}

TEST(TrajectoryIO, ReadsEurocNanosecondsAndWxyz) {
  TempDir d("euroc");
  const auto f = d.write("gt.csv",
                         "#timestamp, p_x, p_y, p_z, q_w, q_x, q_y, q_z, v...\n"
                         "1403715524907143168,0.5,2.0,0.9,0.7071067811865476,0,0,0.7071067811865476,1,2,3\n");
  const auto t = readEurocTrajectory(f);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_NEAR(t[0].timestamp, 1403715524.907143168, 1e-6);
  EXPECT_TRUE(t[0].position.isApprox(Eigen::Vector3d(0.5, 2.0, 0.9)));
  // w x y z order: a 90 deg rotation about z maps x to y.
  EXPECT_TRUE((t[0].orientation * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  expectErrorContaining([&] { readEurocTrajectory(d.write("b.csv", "1403715524907143168,0.5,2.0\n")); },
                        {"b.csv:1", "malformed"});
  expectErrorContaining([&] { readEurocTrajectory(d.write("c.csv", "14037.5,0.5,2.0,0.9,1,0,0,0\n")); },
                        {"c.csv:1", "nanoseconds"});
  expectErrorContaining([&] { readEurocTrajectory(d.write("z.csv", "1,0.5,2.0,0.9,0,0,0,0\n")); },
                        {"z.csv:1", "zero quaternion"});
}

TEST(TrajectoryIO, ReadTrajectoryDispatchesAndTumErrorsNameTheLine) {
  TempDir d("dispatch");
  const auto tum = d.write("a.txt", "1.0 1 2 3 0 0 0 1\n2.0 1 2 3 0 0 0 1\n");
  EXPECT_EQ(readTrajectory(tum).size(), 2u);
  expectErrorContaining([&] { readTrajectory(d.write("m.txt", "1.0 1 2 3 0 0 0 1\n2.0 1 2 x 0 0 0 1\n"), TrajectoryFormat::Tum); },
                        {"m.txt:2"});
  expectErrorContaining([&] { readTrajectory(d.write("n.txt", "1.0 1 2 nan 0 0 0 1\n"), TrajectoryFormat::Tum); },
                        {"n.txt:1"});
  EXPECT_THROW(parseTrajectoryFormat("csv"), pslam::Error);
}

// Reliability (doc/reliability.md): stamps must be in time order; one before the previous names the file and
// line (TUM, EuRoC, and the times file of KITTI). Duplicates are kept (published ground truth has them) and noted.
TEST(TrajectoryIO, StampsGoingBackNameTheFileAndLine) {
  TempDir d("order");
  expectErrorContaining([&] { readTrajectory(d.write("back.txt", "# c\n2.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n")); },
                        {"back.txt:3", "timestamp 1.000000 is before the previous one (line 2)"});
  expectErrorContaining(
      [&] {
        readTrajectory(d.write("e.csv", "#t\n1403715524907143168,0,0,0,1,0,0,0\n1403715524907143167,0,0,0,1,0,0,0\n"));
      },
      {"e.csv:3", "is before the previous one (line 2)"});
  const auto kitti = d.write("k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n");
  expectErrorContaining([&] { readTrajectory(kitti, TrajectoryFormat::Kitti, d.write("kt.txt", "0.5\n0.4\n")); },
                        {"kt.txt:2", "is before the previous one (line 1)"});
  EXPECT_EQ(readTrajectory(kitti, TrajectoryFormat::Kitti).size(), 2u);  // index stamps

  const auto dup = d.write("dup.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n3.0 0 0 0 0 0 0 1\n");
  const auto t = readTrajectory(dup);
  EXPECT_EQ(t.size(), 4u);
  EXPECT_EQ(pslam::duplicateStampNote(t, dup), dup.string() + ": 1 pose has the timestamp of the previous one (first: pose 2, 2.000000)");
  EXPECT_EQ(pslam::duplicateStampNote(readTrajectory(kitti, TrajectoryFormat::Kitti), kitti), "");
}
