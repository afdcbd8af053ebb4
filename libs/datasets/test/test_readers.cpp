// Unit tests of the dataset readers on small datasets written into temp folders.
#include <gtest/gtest.h>

#include <cstdio>
#include <iomanip>
#include <limits>
#include <sstream>

#include <mrpt/core/Clock.h>

#include "SyntheticDatasets.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/Camera.h"
#include "pslam/datasets/Readers.h"

using namespace pslam;
using namespace pslam::datasets;
using namespace pslam::datasets::testing;

namespace {

/// Runs `f`, expects a pslam::Error whose message contains every one of `parts`.
template <typename F>
void expectError(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    FAIL() << "no exception";
  } catch (const Error& e) {
    const std::string msg = e.what();
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

double rotationAngle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

double poseError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() + rotationAngle(a.linear().transpose() * b.linear());
}

}  // namespace

// ------------------------------------------------------------------------------------------------ stamps
TEST(Stamps, QuantizedStampSurvivesMrptClockAndTumTextExactly) {
  for (double t : {1305031102.175304, 1341841278.8427, 1403636579.763555584, 0.1036896, 12.0 / 30.0, 0.0}) {
    const double q = quantizeStamp(t);
    EXPECT_NEAR(q, t, 5.1e-7);
    EXPECT_EQ(mrpt::Clock::toDouble(mrpt::Clock::fromDouble(q)), q) << t;  // what a RawlogReader returns
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.6f", q);  // what writeTumTrajectory writes
    EXPECT_EQ(std::strtod(buf, nullptr), q) << buf;
    EXPECT_EQ(quantizeStamp(q), q);
  }
}

// ------------------------------------------------------------------------------------------------ interpolation
TEST(Interpolation, MatchesAnalyticMotionBetweenSamples) {
  // Rotation about one fixed axis at constant rate and linear translation: slerp + lerp are exact.
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  auto pose = [&](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.7 * t, axis).toRotationMatrix();
    T.translation() = Eigen::Vector3d(1 + 2 * t, -3 * t, 0.5);
    return T;
  };
  Trajectory gt;
  for (int k = 0; k <= 4; ++k) gt.emplace_back(100.0 + k, pose(k));
  for (double t : {0.0, 0.25, 1.5, 2.0, 3.9, 4.0}) {
    const auto T = interpolatePose(gt, 100.0 + t);
    ASSERT_TRUE(T.has_value()) << t;
    EXPECT_LT(poseError(*T, pose(t)), 1e-12) << t;
  }
  EXPECT_FALSE(interpolatePose(gt, 99.999).has_value());
  EXPECT_FALSE(interpolatePose(gt, 104.001).has_value());
  EXPECT_FALSE(interpolatePose({}, 100.0).has_value());
  // Holes: samples 1 s apart, refused with maxGap 0.5, accepted with 1.5.
  EXPECT_FALSE(interpolatePose(gt, 101.5, 0.5).has_value());
  EXPECT_TRUE(interpolatePose(gt, 101.5, 1.5).has_value());
  EXPECT_TRUE(interpolatePose(gt, 101.0, 0.5).has_value());  // exact sample needs no neighbour
}

TEST(Interpolation, UnsortedGroundTruthIsRefused) {
  Trajectory gt(3);
  gt[0].timestamp = 1;
  gt[1].timestamp = 3;
  gt[2].timestamp = 2;
  expectError([&] { requireSortedStamps(gt, "gt.txt"); }, {"gt.txt", "not strictly increasing"});
}

// ------------------------------------------------------------------------------------------------ cameras
TEST(Camera, IniFilesOfTheRepositoryMatchThePublishedValues) {
  const fs::path dir = fs::path(PRIORSLAM_SOURCE_DIR) / "config" / "cameras";
  for (const char* name : {"fr1", "fr2", "fr3"}) {
    const auto ini = loadCameraIni(dir / ("tum_" + std::string(name) + ".ini"));
    const auto ref = tumCamera(name);
    EXPECT_EQ(ini.ncols, 640u);
    EXPECT_EQ(ini.nrows, 480u);
    EXPECT_DOUBLE_EQ(ini.fx(), ref.fx()) << name;
    EXPECT_DOUBLE_EQ(ini.fy(), ref.fy()) << name;
    EXPECT_DOUBLE_EQ(ini.cx(), ref.cx()) << name;
    EXPECT_DOUBLE_EQ(ini.cy(), ref.cy()) << name;
    EXPECT_EQ(ini.distortion, ref.distortion) << name;
    for (int k = 0; k < 5; ++k) EXPECT_DOUBLE_EQ(ini.dist[k], ref.dist[k]) << name << " dist " << k;
  }
  EXPECT_DOUBLE_EQ(tumCamera("fr1").dist[4], 1.1633);
  EXPECT_DOUBLE_EQ(tumCamera("freiburg2").fx(), 520.9);
  EXPECT_EQ(tumCamera("fr3").distortion, mrpt::img::DistortionModel::none);

  const auto kitti = loadCameraIni(dir / "kitti_00-02.ini");
  EXPECT_EQ(kitti.ncols, 1241u);
  EXPECT_EQ(kitti.nrows, 376u);
  EXPECT_DOUBLE_EQ(kitti.fx(), 718.856);
  EXPECT_DOUBLE_EQ(kitti.fy(), 718.856);
  EXPECT_DOUBLE_EQ(kitti.cx(), 607.1928);
  EXPECT_DOUBLE_EQ(kitti.cy(), 185.2157);
  EXPECT_EQ(loadFrameRateFromIni(dir / "kitti_00-02.ini"), std::optional<double>(10.0));
  EXPECT_EQ(loadFrameRateFromIni(dir / "tum_fr3.ini"), std::optional<double>(30.0));

  const auto icl = loadCameraIni(dir / "icl_nuim.ini");
  const auto iclRef = iclNuimCamera();
  EXPECT_DOUBLE_EQ(icl.fx(), iclRef.fx());
  EXPECT_DOUBLE_EQ(icl.fy(), iclRef.fy());
  // Every ini in the folder loads.
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".ini") {
      EXPECT_NO_THROW(loadCameraIni(e.path())) << e.path();
    }
}

TEST(Camera, FolderNamesGiveTheTumCamera) {
  EXPECT_EQ(tumCameraFromFolderName("rgbd_dataset_freiburg3_cabinet_every20th"), std::optional<std::string>("fr3"));
  EXPECT_EQ(tumCameraFromFolderName("rgbd_dataset_freiburg1_xyz"), std::optional<std::string>("fr1"));
  EXPECT_EQ(tumCameraFromFolderName("fr2_desk"), std::optional<std::string>("fr2"));
  EXPECT_FALSE(tumCameraFromFolderName("office_run").has_value());
  expectError([] { tumCamera("fr4"); }, {"fr4"});
}

TEST(Camera, BrokenIniNamesFileAndSection) {
  const fs::path d = freshDir("badini");
  writeText(d / "cam.ini", "[CAMERA]\nresolution = [640 480]\nfx = 500\nfy = 500\ncx = 320\n");
  expectError([&] { loadCameraIni(d / "cam.ini"); }, {"cam.ini", "[CAMERA]"});
  expectError([&] { loadCameraIni(d / "cam.ini", "OTHER"); }, {"cam.ini", "no section [OTHER]"});
  expectError([&] { loadCameraIni(d / "missing.ini"); }, {"missing.ini", "not found"});
  // Read strictly before MRPT reads the block (MRPT ignores unknown keys and reads 'abc' as 0).
  const std::string good = "[CAMERA]\nresolution = [640 480]\nfx = 500\nfy = 500\ncx = 320\ncy = 240\n"
                           "distortion_model = none\ndist = [0 0 0 0 0]\n";
  const auto errorFor = [&](const std::string& extra) {
    writeText(d / "cam.ini", good + extra);
    try {
      loadCameraIni(d / "cam.ini");
    } catch (const pslam::Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string f = (d / "cam.ini").string();
  EXPECT_EQ(errorFor(""), "");
  EXPECT_EQ(errorFor("distortion = plumb_bob\n"), f + ": [CAMERA] distortion: unknown key (did you mean distortion_model?)");
  EXPECT_EQ(errorFor("frame_rate_hz = abc\n"), f + ": [CAMERA] frame_rate_hz = abc: not a number");
  EXPECT_EQ(errorFor("frame_rate_hz = 30 fps\n"), f + ": [CAMERA] frame_rate_hz = 30 fps: not a number");
  writeText(d / "cam.ini", "[CAMERA]\nresolution = [640 480 3]\nfx = 500\nfy = 500\ncx = 320\ncy = 240\ndist = [0 0 0 0 0]\n");
  expectError([&] { loadCameraIni(d / "cam.ini"); }, {f + ": [CAMERA] resolution = 640 480 3: expected [width height]"});
  writeText(d / "cam.ini", "[CAMERA]\nresolution = [640 480]\nfx = abc\nfy = 500\ncx = 320\ncy = 240\ndist = [0 0 0 0 0]\n");
  expectError([&] { loadCameraIni(d / "cam.ini"); }, {f + ": [CAMERA] fx = abc: not a number"});
  writeText(d / "cam.ini", "[CAMERA]\n");
  expectError([&] { loadCameraIni(d / "cam.ini"); }, {f + ": [CAMERA] resolution: missing"});
  writeText(d / "cam.ini", "resolution = [640 480]\n");
  expectError([&] { loadFrameRateFromIni(d / "cam.ini"); }, {f + ":1: resolution: key outside any section"});
  // Other sections may hold other cameras: --camera-section picks one.
  writeText(d / "cam.ini", good + "[CAMERA_RIGHT]\nresolution = [640 480]\n");
  EXPECT_NO_THROW(loadCameraIni(d / "cam.ini"));
}

// Reliability (doc/reliability.md): a camera ini with only its section header names the missing key in one
// line, without MRPT's exception banner.
TEST(Camera, IniWithOnlyTheSectionHeaderNamesTheMissingKey) {
  const fs::path d = freshDir("emptycamini");
  writeText(d / "cam.ini", "[CAMERA]\n");
  try {
    loadCameraIni(d / "cam.ini");
    FAIL() << "no exception";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cam.ini"), std::string::npos) << msg;
    EXPECT_NE(msg.find("[CAMERA] resolution: missing"), std::string::npos) << msg;
    EXPECT_EQ(msg.find("MRPT exception"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

// ------------------------------------------------------------------------------------------------ TUM
TEST(TumReader, AssociatesDepthLikeAssociatePyAndInterpolatesGroundTruth) {
  const fs::path root = freshDir("tum_assoc") / "rgbd_dataset_freiburg1_test";
  TumSpec spec;
  writeTumDataset(root, spec);
  // One extra depth frame closer to rgb frame 2 than its own: the greedy smallest-difference rule takes it,
  // and one rgb frame whose depth is too far away.
  {
    std::ofstream(root / "depth.txt", std::ios::app) << std::fixed << std::setprecision(6)
                                                     << spec.t0 + 2 * spec.dt + 0.001 << " depth/extra.png\n";
    writeImage(root / "depth" / "extra.png", depthImage(spec.width, spec.height, 99));
  }
  // depth.txt must stay sorted: rewrite it sorted.
  {
    std::vector<std::pair<double, std::string>> rows;
    std::ifstream in(root / "depth.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      double t;
      std::string f;
      ss >> t >> f;
      rows.emplace_back(t, f);
    }
    std::sort(rows.begin(), rows.end());
    std::ostringstream out;
    out << std::fixed << std::setprecision(6);
    for (const auto& [t, f] : rows) out << t << " " << f << "\n";
    writeText(root / "depth.txt", out.str());
  }
  const DatasetIndex idx = indexTumRgbd(root, TumOptions{});
  ASSERT_EQ(idx.frames.size(), 5u);
  EXPECT_EQ(idx.format, "tum");
  EXPECT_DOUBLE_EQ(idx.camera.fx(), 517.3);  // fr1 from the folder name
  EXPECT_DOUBLE_EQ(idx.depthUnits, 1.0 / 5000.0);
  EXPECT_EQ(idx.frames[2].depth.filename(), "extra.png");
  char name[64];
  std::snprintf(name, sizeof(name), "%.6f.png", spec.t0 + 3 * spec.dt + spec.depthOffset);
  EXPECT_EQ(idx.frames[3].depth.filename(), name);
  for (std::size_t i = 0; i < idx.frames.size(); ++i) {
    EXPECT_EQ(idx.frames[i].timestamp, quantizeStamp(tumStamp(spec.t0 + i * spec.dt)));
    // Ground truth starts 0.05 s after the first frame: frames 0 and 1 have none.
    EXPECT_EQ(idx.frames[i].T_world_cam.has_value(), i >= 2) << i;
    if (idx.frames[i].T_world_cam) {  // interpolation of 100 Hz samples of a smooth motion
      EXPECT_LT(poseError(*idx.frames[i].T_world_cam, motion(idx.frames[i].timestamp - spec.t0)), 1e-4) << i;
    }
  }

  // A tighter window leaves frames without depth (kept, reported).
  TumOptions tight;
  tight.maxDepthDiff = 0.002;
  const DatasetIndex idx2 = indexTumRgbd(root, tight);
  EXPECT_TRUE(idx2.frames[0].depth.empty());
  EXPECT_FALSE(idx2.frames[2].depth.empty());
}

TEST(TumReader, ErrorsNameTheFileAndLine) {
  const fs::path root = freshDir("tum_err") / "rgbd_dataset_freiburg3_x";
  writeTumDataset(root, TumSpec{});
  writeText(root / "rgb.txt", "# header\n1305031102.175304 rgb/a.png\nnot_a_number rgb/b.png\n");
  expectError([&] { indexTumRgbd(root, TumOptions{}); }, {"rgb.txt:3", "timestamp 'not_a_number'"});
  writeText(root / "rgb.txt", "1305031102.175304\n");
  expectError([&] { indexTumRgbd(root, TumOptions{}); }, {"rgb.txt:1", "malformed line"});
  writeText(root / "rgb.txt", "# nothing\n");
  expectError([&] { indexTumRgbd(root, TumOptions{}); }, {"rgb.txt", "empty dataset"});
  writeText(root / "rgb.txt", "1305031102.175304 rgb/nope.png\n");
  expectError([&] { indexTumRgbd(root, TumOptions{}); }, {"nope.png", "not found"});
  writeText(root / "groundtruth.txt", "1305031102.1 1 2 3 0 0 0\n");
  writeText(root / "rgb.txt", "");
  expectError([&] { indexTumRgbd(root / "missing", TumOptions{}); }, {"missing", "not found"});
  const fs::path noName = freshDir("tum_noname") / "sequence";
  writeTumDataset(noName, TumSpec{});
  expectError([&] { indexTumRgbd(noName, TumOptions{}); }, {"--tum-camera"});
}

TEST(TumReader, MalformedGroundTruthLineIsNamed) {
  const fs::path root = freshDir("tum_badgt") / "rgbd_dataset_freiburg3_x";
  writeTumDataset(root, TumSpec{});
  writeText(root / "groundtruth.txt", "# gt\n1305031102.1 1 2 3 0 0 0 1\n1305031102.2 1 2 3 0 0 0\n");
  expectError([&] { indexTumRgbd(root, TumOptions{}); }, {"groundtruth.txt:3"});
}

// ------------------------------------------------------------------------------------------------ format
TEST(Format, DetectsEachLayoutAndRefusesUnknown) {
  const fs::path base = freshDir("detect");
  writeText(base / "tum" / "rgb.txt", "");
  writeText(base / "icl" / "associations.txt", "");
  writeText(base / "icl" / "lr0.gt.freiburg", "");
  writeText(base / "icl_rgb_only" / "rgb.txt", "");  // ICL-NUIM without depth: rgb.txt beside the .gt.freiburg
  writeText(base / "icl_rgb_only" / "livingRoom3n.gt.freiburg", "");
  fs::create_directories(base / "kitti" / "image_0");
  writeText(base / "euroc" / "mav0" / "cam0" / "data.csv", "");
  writeImage(base / "folder" / "a.png", patternImage(8, 8, 0));
  fs::create_directories(base / "nothing");
  writeText(base / "nothing" / "readme.txt", "hi");
  EXPECT_EQ(detectFormat(base / "tum"), DatasetFormat::Tum);
  EXPECT_EQ(detectFormat(base / "icl"), DatasetFormat::IclNuim);
  EXPECT_EQ(detectFormat(base / "icl_rgb_only"), DatasetFormat::IclNuim);
  EXPECT_EQ(detectFormat(base / "kitti"), DatasetFormat::Kitti);
  EXPECT_EQ(detectFormat(base / "euroc"), DatasetFormat::Euroc);
  EXPECT_EQ(detectFormat(base / "folder"), DatasetFormat::ImageFolder);
  expectError([&] { detectFormat(base / "nothing"); }, {"nothing", "unknown dataset format"});
  expectError([&] { detectFormat(base / "absent"); }, {"absent", "not found"});
  expectError([] { parseFormatName("rosbag"); }, {"unknown dataset format 'rosbag'"});
}

// ------------------------------------------------------------------------------------------------ ICL-NUIM
TEST(IclReader, MatchesIdsAndReflectsPosesToAProperTopDownCamera) {
  const fs::path root = freshDir("icl");
  std::string assoc, gt;
  for (int id = 0; id < 4; ++id) {
    writeImage(root / "rgb" / (std::to_string(id) + ".png"), patternImage(64, 48, id));
    writeImage(root / "depth" / (std::to_string(id) + ".png"), depthImage(64, 48, id));
    assoc += std::to_string(id) + " depth/" + std::to_string(id) + ".png " + std::to_string(id) + " rgb/" +
             std::to_string(id) + ".png\n";
    if (id >= 1) gt += std::to_string(id) + tumLine(0, motion(id)).substr(8);  // ids 1..3, like the release
  }
  writeText(root / "associations.txt", assoc);
  writeText(root / "traj.gt.freiburg", gt);
  IclOptions opt;
  opt.override.camera = makePinholeCamera(64, 48, 48.12, 48.0, 31.5, 23.5);
  opt.override.source = "test";
  const DatasetIndex idx = indexIclNuim(root, opt);
  ASSERT_EQ(idx.frames.size(), 4u);
  EXPECT_FALSE(idx.frames[0].T_world_cam.has_value());  // id 0 has no pose in the release
  Eigen::Matrix3d S = Eigen::Vector3d(1, -1, 1).asDiagonal();
  for (int id = 1; id < 4; ++id) {
    const auto& e = idx.frames[static_cast<std::size_t>(id)];
    EXPECT_EQ(e.timestamp, quantizeStamp(id / 30.0));
    ASSERT_TRUE(e.T_world_cam.has_value());
    const Eigen::Isometry3d published = motion(id);
    EXPECT_NEAR(e.T_world_cam->linear().determinant(), 1.0, 1e-9);
    EXPECT_LT((e.T_world_cam->linear() - S * published.linear() * S).norm(), 1e-7);
    EXPECT_LT((e.T_world_cam->translation() - S * published.translation()).norm(), 1e-7);
    // A world point seen by the published (y-up) camera appears with y negated in the top-down camera.
    const Eigen::Vector3d pWorld(0.3, -1.2, 2.5);
    const Eigen::Vector3d pCamPublished = published.inverse() * pWorld;
    const Eigen::Vector3d pCamTopDown = e.T_world_cam->inverse() * (S * pWorld);
    EXPECT_LT((pCamTopDown - S * pCamPublished).norm(), 1e-6);
  }
  EXPECT_EQ(idx.frames[2].depth.filename(), "2.png");
  opt.reflectPoses = false;
  const DatasetIndex raw = indexIclNuim(root, opt);
  EXPECT_LT(poseError(*raw.frames[2].T_world_cam, motion(2)), 1e-7);

  writeText(root / "associations.txt", "0 depth/0.png 0\n");
  expectError([&] { indexIclNuim(root, opt); }, {"associations.txt:1", "malformed line"});
}

TEST(IclReader, AFolderWithoutDepthReadsRgbTxtAndAGroundTruthOfFrameIds) {
  // As the shared lr-kt3 subset: rgb.txt ("id rgb/id.png"), no depth, the poses in groundtruth.txt (TUM lines of
  // frame ids) and/or the release's <name>.gt.freiburg, which wins.
  const fs::path root = freshDir("icl_rgb");
  std::string rgb = "# id file\n", gt, other;
  for (int id = 0; id < 3; ++id) {
    writeImage(root / "rgb" / (std::to_string(id) + ".png"), patternImage(64, 48, id));
    rgb += std::to_string(id) + " rgb/" + std::to_string(id) + ".png\n";
    if (id >= 1) gt += std::to_string(id) + tumLine(0, motion(id)).substr(8);
    other += std::to_string(id) + tumLine(0, motion(id + 5)).substr(8);
  }
  writeText(root / "rgb.txt", rgb);
  writeText(root / "groundtruth.txt", gt);
  IclOptions opt;
  opt.override.camera = makePinholeCamera(64, 48, 48.12, 48.0, 31.5, 23.5);
  opt.override.source = "test";
  DatasetIndex idx = indexIclNuim(root, opt);
  ASSERT_EQ(idx.frames.size(), 3u);
  EXPECT_TRUE(idx.frames[1].depth.empty());
  EXPECT_FALSE(idx.frames[0].T_world_cam.has_value());
  Eigen::Matrix3d S = Eigen::Vector3d(1, -1, 1).asDiagonal();
  ASSERT_TRUE(idx.frames[2].T_world_cam.has_value());
  EXPECT_LT((idx.frames[2].T_world_cam->translation() - S * motion(2).translation()).norm(), 1e-7);
  // The converter says which convention it applied.
  const std::string said = [&] {
    std::string all;
    for (const std::string& a : idx.assumptions) all += a + "\n";
    return all;
  }();
  EXPECT_NE(said.find("reflected about the XZ plane"), std::string::npos) << said;
  EXPECT_NE(said.find("groundtruth.txt"), std::string::npos) << said;
  EXPECT_NE(said.find("no depth"), std::string::npos) << said;
  // The release's .gt.freiburg is preferred to a groundtruth.txt.
  writeText(root / "traj.gt.freiburg", other);
  idx = indexIclNuim(root, opt);
  ASSERT_TRUE(idx.frames[0].T_world_cam.has_value());
  EXPECT_LT((idx.frames[0].T_world_cam->translation() - S * motion(5).translation()).norm(), 1e-7);
  EXPECT_EQ(detectFormat(root), DatasetFormat::IclNuim);
  // A malformed rgb.txt line is named.
  writeText(root / "rgb.txt", "0\n");
  expectError([&] { indexIclNuim(root, opt); }, {"rgb.txt:1", "malformed line"});
}

// ------------------------------------------------------------------------------------------------ KITTI
namespace {
struct KittiSpec {
  int frames = 4;
  bool calib = true, times = true;
  int poses = 6;  // more poses than images, as in the shared subset
  int camera = 0;
};
fs::path writeKitti(const std::string& name, const KittiSpec& s) {
  const fs::path base = freshDir(name);
  const fs::path seq = base / "sequences" / "05";
  char file[32];
  for (int i = 0; i < s.frames; ++i) {
    std::snprintf(file, sizeof(file), "%06d.png", i);
    writeImage(seq / ("image_" + std::to_string(s.camera)) / file,
               patternImage(40, 12, i, s.camera == 0 ? CV_8UC1 : CV_8UC3));
  }
  if (s.calib)
    writeText(seq / "calib.txt",
              "P0: 7.0e+01 0 2.0e+01 0 0 7.0e+01 6.0e+00 0 0 0 1 0\n"
              "P1: 7.0e+01 0 2.0e+01 -3.8e+01 0 7.0e+01 6.0e+00 0 0 0 1 0\n"
              "P2: 7.0e+01 0 2.0e+01 4.2e+00 0 7.0e+01 6.0e+00 -1.4e-01 0 0 1 3.0e-03\n"
              "P3: 7.0e+01 0 2.0e+01 -3.4e+01 0 7.0e+01 6.0e+00 0 0 0 1 0\n");
  if (s.times) {
    std::string t;
    for (int i = 0; i < s.frames; ++i) t += std::to_string(0.1036896 * i) + "\n";
    writeText(seq / "times.txt", t);
  }
  std::string p;
  for (int i = 0; i < s.poses; ++i) p += kittiLine(motion(0.1 * i));
  writeText(base / "poses" / "05.txt", p);
  return seq;
}
}  // namespace

TEST(KittiReader, ReadsCalibTimesAndCam0Poses) {
  const fs::path seq = writeKitti("kitti_ok", KittiSpec{});
  const DatasetIndex idx = indexKitti(seq, KittiOptions{});
  ASSERT_EQ(idx.frames.size(), 4u);
  EXPECT_DOUBLE_EQ(idx.camera.fx(), 70.0);
  EXPECT_DOUBLE_EQ(idx.camera.cy(), 6.0);
  EXPECT_EQ(idx.camera.ncols, 40u);
  EXPECT_EQ(idx.groundTruthSamples, 6u);
  for (int i = 0; i < 4; ++i) {
    const auto& e = idx.frames[static_cast<std::size_t>(i)];
    EXPECT_EQ(e.timestamp, quantizeStamp(std::stod(std::to_string(0.1036896 * i))));
    ASSERT_TRUE(e.T_world_cam);
    EXPECT_LT(poseError(*e.T_world_cam, motion(0.1 * i)), 1e-9);
  }
}

TEST(KittiReader, ColourCameraIsOffsetFromCam0ByTheCalibration) {
  KittiSpec s;
  s.camera = 2;
  const fs::path seq = writeKitti("kitti_cam2", s);
  const DatasetIndex idx = indexKitti(seq, KittiOptions{});
  // P2 = K [I | t2]: t2 = K^-1 (4.2, -0.14, 0.003) = ((4.2 - 20*0.003)/70, (-0.14 - 6*0.003)/70, 0.003).
  const Eigen::Vector3d t2((4.2 - 20 * 0.003) / 70.0, (-0.14 - 6 * 0.003) / 70.0, 0.003);
  EXPECT_NEAR(idx.sensorPoseOnBody.x(), -t2.x(), 1e-12);
  EXPECT_NEAR(idx.sensorPoseOnBody.y(), -t2.y(), 1e-12);
  EXPECT_NEAR(idx.sensorPoseOnBody.z(), -t2.z(), 1e-12);
  const Eigen::Isometry3d T0 = motion(0.1);
  const Eigen::Vector3d expectedCentre = T0 * (-t2);
  EXPECT_LT((idx.frames[1].T_world_cam->translation() - expectedCentre).norm(), 1e-9);
}

TEST(KittiReader, MissingCalibOrTimesNeedsExplicitValues) {
  KittiSpec s;
  s.calib = false;
  s.times = false;
  const fs::path seq = writeKitti("kitti_missing", s);
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"calib.txt", "--camera-ini"});
  KittiOptions o;
  o.override.intrinsics = {70.0, 70.0, 20.0, 6.0};
  o.override.source = "--intrinsics";
  expectError([&] { indexKitti(seq, o); }, {"times.txt", "--rate"});
  o.rate = 10.0;
  const DatasetIndex idx = indexKitti(seq, o);
  EXPECT_EQ(idx.camera.ncols, 40u);  // resolution from the first image
  EXPECT_EQ(idx.frames[3].timestamp, quantizeStamp(0.3));
  bool saidRate = false, saidCalib = false;
  for (const auto& a : idx.assumptions) {
    saidRate = saidRate || a.find("i / 10 Hz") != std::string::npos;
    saidCalib = saidCalib || a.find("calib.txt missing") != std::string::npos;
  }
  EXPECT_TRUE(saidRate);
  EXPECT_TRUE(saidCalib);
}

TEST(KittiReader, MismatchedCountsAndMalformedPosesAreErrors) {
  KittiSpec s;
  s.poses = 3;  // fewer poses than the 4 images
  fs::path seq = writeKitti("kitti_counts", s);
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"05.txt", "mismatched counts", "3 poses for 4 images"});
  writeText(seq / "times.txt", "0\n0.1\n");
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"times.txt", "mismatched counts"});
  seq = writeKitti("kitti_malformed", KittiSpec{});
  writeText(seq / ".." / ".." / "poses" / "05.txt", kittiLine(motion(0)) + "1 0 0 0 0 1 0 0 0 0 1\n");
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"05.txt:2", "expected 12 numbers"});
  writeText(seq / ".." / ".." / "poses" / "05.txt", "1 0 0 nan 0 1 0 0 0 0 1 0\n");
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"05.txt:1", "not a finite number"});
  // A gap in the image numbering.
  seq = writeKitti("kitti_gap", KittiSpec{});
  fs::remove(seq / "image_0" / "000001.png");
  expectError([&] { indexKitti(seq, KittiOptions{}); }, {"000002.png", "expected frame number 1"});
}

// ------------------------------------------------------------------------------------------------ EuRoC
namespace {
const char* kEurocSensorYaml = R"(%YAML:1.0
# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [40, 30]
camera_model: pinhole
intrinsics: [45.8654, 45.7296, 19.7215, 14.8375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";
}  // namespace

TEST(EurocReader, CameraPoseIsBodyPoseTimesTbsAtTheCameraStamps) {
  const fs::path root = freshDir("euroc") / "MH_01_easy";
  const fs::path cam = root / "mav0" / "cam0";
  const long long t0 = 1403636579763555584LL;
  std::string csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < 3; ++i) {
    const long long ns = t0 + i * 50000000LL;
    writeImage(cam / "data" / (std::to_string(ns) + ".png"), patternImage(40, 30, i, CV_8UC1));
    csv += std::to_string(ns) + "," + std::to_string(ns) + ".png\n";
  }
  writeText(cam / "data.csv", csv);
  writeText(cam / "sensor.yaml", kEurocSensorYaml);
  // Body ground truth at 200 Hz starting 2 ms before the first image.
  std::string gt = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
  for (int k = 0; k < 30; ++k) {
    const long long ns = t0 - 2000000LL + k * 5000000LL;
    const Eigen::Isometry3d T = motion(k * 0.005);
    const Eigen::Quaterniond q(T.linear());
    char line[256];
    std::snprintf(line, sizeof(line), "%lld,%.9f,%.9f,%.9f,%.12f,%.12f,%.12f,%.12f,0,0,0,0,0,0,0,0,0\n", ns,
                  T.translation().x(), T.translation().y(), T.translation().z(), q.w(), q.x(), q.y(), q.z());
    gt += line;
  }
  writeText(root / "mav0" / "state_groundtruth_estimate0" / "data.csv", gt);

  const DatasetIndex idx = indexEuroc(root, EurocOptions{});
  ASSERT_EQ(idx.frames.size(), 3u);
  EXPECT_DOUBLE_EQ(idx.camera.fx(), 45.8654);
  EXPECT_DOUBLE_EQ(idx.camera.cy(), 14.8375);
  EXPECT_EQ(idx.camera.ncols, 40u);
  EXPECT_EQ(idx.camera.distortion, mrpt::img::DistortionModel::plumb_bob);
  EXPECT_DOUBLE_EQ(idx.camera.dist[0], -0.28340811);
  EXPECT_DOUBLE_EQ(idx.camera.dist[3], 1.76187114e-05);
  EXPECT_NEAR(idx.sensorPoseOnBody.x(), -0.0216401454975, 1e-12);
  EXPECT_EQ(idx.frames[0].timestamp, quantizeStamp(1403636579.763556));
  mrpt::math::CMatrixDouble44 Mbs = idx.sensorPoseOnBody.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  Eigen::Isometry3d Tbs = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) Tbs.matrix()(r, c) = Mbs(r, c);
  for (int i = 0; i < 3; ++i) {
    // Camera i at 50 ms * i after t0 = 2 ms + 50 ms * i after the first body sample.
    const double tBody = 0.002 + 0.05 * i;
    ASSERT_TRUE(idx.frames[static_cast<std::size_t>(i)].T_world_cam);
    EXPECT_LT(poseError(*idx.frames[static_cast<std::size_t>(i)].T_world_cam, motion(tBody) * Tbs), 1e-4) << i;
  }
  writeText(cam / "sensor.yaml", std::string(kEurocSensorYaml).replace(
                                     std::string(kEurocSensorYaml).find("radial-tangential"), 17, "equidistant"));
  expectError([&] { indexEuroc(root, EurocOptions{}); }, {"sensor.yaml", "equidistant"});
  writeText(cam / "data.csv", "#timestamp [ns],filename\n1403636579763555584\n");
  expectError([&] { indexEuroc(root, EurocOptions{}); }, {"data.csv:2", "malformed line"});
}

// ------------------------------------------------------------------------------------------------ folder
TEST(FolderReader, NaturalOrderRateAndPosesByIndex) {
  const fs::path root = freshDir("folder");
  for (int i : {0, 1, 2, 10}) writeImage(root / ("img" + std::to_string(i) + ".png"), patternImage(16, 12, i));
  FolderOptions o;
  o.override.intrinsics = {20.0, 21.0, 8.0, 6.0};
  o.override.source = "--intrinsics";
  expectError([&] { indexImageFolder(root, o); }, {"--rate"});
  o.rate = 4.0;
  o.firstStamp = 100.0;
  DatasetIndex idx = indexImageFolder(root, o);
  ASSERT_EQ(idx.frames.size(), 4u);
  EXPECT_EQ(idx.frames[3].image.filename(), "img10.png");
  EXPECT_EQ(idx.frames[3].timestamp, quantizeStamp(100.75));
  std::string poses;
  for (int i = 0; i < 3; ++i) poses += tumLine(i, motion(i));
  writeText(root / "poses.txt", poses);
  o.posesFile = root / "poses.txt";
  expectError([&] { indexImageFolder(root, o); }, {"poses.txt", "mismatched counts", "3 poses for 4 images"});
  writeText(root / "poses.txt", poses + tumLine(3, motion(3)));
  idx = indexImageFolder(root, o);
  EXPECT_LT(poseError(*idx.frames[3].T_world_cam, motion(3)), 1e-7);
  FolderOptions noCam;
  noCam.rate = 1;
  expectError([&] { indexImageFolder(root, noCam); }, {"no intrinsics"});
}

// ------------------------------------------------------------------------------------------------ loading
TEST(LoadFrame, UnreadableImagesAndWrongDepthAreNamed) {
  const fs::path root = freshDir("load") / "rgbd_dataset_freiburg3_x";
  TumSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.frames = 2;
  writeTumDataset(root, spec);
  DatasetIndex idx = indexTumRgbd(root, TumOptions{});
  const Frame f = loadFrame(idx, 1, ColorMode::Grey);
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(f.depth != depthImage(640, 480, 1)), 0);
  writeText(idx.frames[0].image, "this is not a png");
  expectError([&] { loadFrame(idx, 0, ColorMode::Keep); }, {idx.frames[0].image.string(), "cannot read image"});
  writeImage(idx.frames[1].depth, patternImage(640, 480, 3, CV_8UC1));
  expectError([&] { loadFrame(idx, 1, ColorMode::Keep); }, {idx.frames[1].depth.string(), "16-bit"});
  // Image size different from the intrinsics.
  writeImage(idx.frames[1].image, patternImage(320, 240, 3));
  idx.frames[1].depth.clear();
  expectError([&] { loadFrame(idx, 1, ColorMode::Keep); }, {idx.frames[1].image.string(), "intrinsics are for 640x480"});
}

TEST(SelectFrames, RangeAndStride) {
  DatasetIndex idx;
  idx.root = "x";
  for (int i = 0; i < 10; ++i) {
    FrameEntry e;
    e.timestamp = i;
    idx.frames.push_back(e);
  }
  DatasetIndex a = idx;
  selectFrames(a, 2, 7, 2);
  ASSERT_EQ(a.frames.size(), 3u);
  EXPECT_EQ(a.frames[2].timestamp, 6.0);
  DatasetIndex b = idx;
  selectFrames(b, 8, std::numeric_limits<std::size_t>::max(), 1);
  EXPECT_EQ(b.frames.size(), 2u);
  DatasetIndex c = idx;
  expectError([&] { selectFrames(c, 10, 20, 1); }, {"beyond the 10 frames"});
  DatasetIndex empty;
  empty.root = "nothing";
  expectError([&] { selectFrames(empty, 0, 5, 1); }, {"nothing", "empty dataset"});
}
