// e2e: the manhattan-eval and normal-priors binaries (exit codes, one-line errors, outputs on disk).
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <Eigen/Geometry>

#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"

namespace fs = std::filesystem;

namespace {

struct CliRun {
  int code;
  std::string err;
};

CliRun run(const std::string& cmd, const fs::path& dir) {
  const fs::path errFile = dir / "stderr.txt";
  const int status = std::system((cmd + " > /dev/null 2> " + errFile.string()).c_str());
  std::ifstream in(errFile);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return {WEXITSTATUS(status), all};
}

/// Two frames looking into the corner of a box room (floor, two walls), with u16 depth and ground truth.
void writeRoomRawlog(const fs::path& rawlog) {
  const int cols = 160, rows = 120;
  const double f = 130.0;
  pslam::datasets::RawlogWriter w(rawlog);
  pslam::Trajectory gt;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.6 + 0.1 * i, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    pslam::datasets::Frame fr;
    fr.timestamp = 1.0 + i;
    fr.image = cv::Mat(rows, cols, CV_8UC1, cv::Scalar(100));
    fr.camera.ncols = cols;
    fr.camera.nrows = rows;
    fr.camera.fx(f);
    fr.camera.fy(f);
    fr.camera.cx(cols / 2.0);
    fr.camera.cy(rows / 2.0);
    fr.depth = cv::Mat(rows, cols, CV_16UC1);
    const Eigen::Vector3d half(2, 1, 2);
    for (int v = 0; v < rows; ++v)
      for (int u = 0; u < cols; ++u) {
        const Eigen::Vector3d r = R * Eigen::Vector3d((u - cols / 2.0) / f, (v - rows / 2.0) / f, 1.0);
        double best = 1e9;
        for (int a = 0; a < 3; ++a)
          if (std::abs(r(a)) > 1e-9) best = std::min(best, ((r(a) > 0 ? half(a) : -half(a))) / r(a));
        fr.depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(best * 5000));
      }
    fr.depthUnits = 1.0 / 5000;
    w.write(fr);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    gt.emplace_back(fr.timestamp, T);
  }
  w.commit();
  pslam::writeTumTrajectory(rawlog.parent_path() / (rawlog.stem().string() + "_groundtruth.txt"), gt);
}

}  // namespace

TEST(ManhattanCli, PipelineAndOneLineErrors) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_manhattan_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  struct Cleanup {
    fs::path p;
    ~Cleanup() { fs::remove_all(p); }
  } cleanup{dir};
  writeRoomRawlog(dir / "room.rawlog");
  const std::string np = NORMAL_PRIORS_EXE, me = MANHATTAN_EVAL_EXE;

  CliRun r = run(np + " " + (dir / "room.rawlog").string() + " " + (dir / "room_n.rawlog").string() + " -q", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "room_n.rawlog"));
  EXPECT_TRUE(fs::exists(dir / "room_n_groundtruth.txt"));

  r = run(me + " " + (dir / "room_n.rawlog").string() + " --normals rawlog --json " + (dir / "r.json").string() +
              " -q",
          dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "r.json"));

  r = run(me + " " + (dir / "missing.rawlog").string(), dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("manhattan-eval: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("missing.rawlog"), std::string::npos);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);

  r = run(np + " " + (dir / "room.rawlog").string() + " " + (dir / "x.rawlog").string() + " --source nope -q", dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err.rfind("normal-priors: error: ", 0), 0u) << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.rawlog"));  // nothing half-written
}
