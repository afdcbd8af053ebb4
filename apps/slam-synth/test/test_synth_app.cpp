// SynthApp: outputs follow the rawlog contract, are reproducible from the seed, and the ground truth is
// consistent with the rendered depth (checked by reprojection between frames).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <mrpt/config/CConfigFileMemory.h>
#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/synth/SynthApp.h"

#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;
using namespace pslam::synth;

namespace {

/// A fresh folder for one test in this process's temporary folder (removed when the process ends).
fs::path tempDir(const std::string& name) {
  static const pslam::test_support::TempDir root("pslam_test_synth");
  return pslam::test_support::freshSubDir(root, name);
}

SynthOptions small(const std::string& scenario, const fs::path& out, std::uint32_t seed, int frames = 3) {
  SynthOptions o;
  o.scenario = scenario;
  o.frames = frames;
  o.width = 64;
  o.height = 48;
  o.seed = seed;
  o.outDir = out;
  o.progress = false;
  return o;
}

std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::string checkError(SynthOptions o) {
  try {
    o.check();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SynthOptions, CheckNamesTheBadKey) {
  const SynthOptions good = small("room", "/tmp/x", 1);
  EXPECT_EQ(checkError(good), "");
  SynthOptions o = good;
  o.scenario = "moon";
  EXPECT_NE(checkError(o).find("scenario"), std::string::npos);
  EXPECT_NE(checkError(o).find("street"), std::string::npos);  // lists the known presets
  o = good;
  o.frames = -2;
  EXPECT_NE(checkError(o).find("frames"), std::string::npos);
  o = good;
  o.noiseSigma = std::nan("");
  EXPECT_NE(checkError(o).find("noise_sigma"), std::string::npos);
  o = good;
  o.outDir.clear();
  EXPECT_NE(checkError(o).find("out_dir"), std::string::npos);
  o = good;
  o.name = "a/b";
  EXPECT_NE(checkError(o).find("name"), std::string::npos);
  o = good;
  o.antiAliasing = "best";
  EXPECT_NE(checkError(o).find("anti_aliasing"), std::string::npos);
  // Path variants exist per scenario: the error names the key and what the scenario has.
  o = good;
  o.pathVariant = 2;
  EXPECT_EQ(checkError(o), "");
  o.scenario = "street";
  EXPECT_NE(checkError(o).find("[synth] path_variant = 2: scenario 'street' has no path variant 2 (it has only 0)"),
            std::string::npos)
      << checkError(o);
  o = good;
  o.pathVariant = -1;
  EXPECT_NE(checkError(o).find("path_variant"), std::string::npos);
}

TEST(SynthApp, PathVariantIsAnotherPathThroughTheSameWorld) {
  const fs::path d = tempDir("path_variant");
  SynthOptions a = small("corridor", d / "a", 4, 2), b = a;
  b.outDir = d / "b";
  b.pathVariant = 1;
  const SynthSummary sa = SynthApp(a).run(), sb = SynthApp(b).run();
  const Trajectory ga = readTumTrajectory(sa.groundTruth), gb = readTumTrajectory(sb.groundTruth);
  ASSERT_EQ(ga.size(), 2u);
  ASSERT_EQ(gb.size(), 2u);
  EXPECT_EQ(ga[0].timestamp, gb[0].timestamp);  // same stamps: trajectories of one world, side by side
  EXPECT_GT((ga[0].position - gb[0].position).norm(), 0.5);
  EXPECT_NE(readBytes(sb.groundTruth).find("seed 4 path variant 1"), std::string::npos);
  EXPECT_EQ(readBytes(sa.groundTruth).find("path variant"), std::string::npos);  // variant 0: header as before
  // The ini key sets the same option.
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("synth", "scenario", "room");
  cfg.write("synth", "path_variant", 2);
  SynthOptions o;
  o.loadFromConfigFile(cfg, "synth");
  EXPECT_EQ(o.pathVariant, 2);
  fs::remove_all(d);
}

TEST(SynthOptions, LoadsFromAnIniSectionAndRoundTrips) {
  mrpt::config::CConfigFileMemory cfg;
  cfg.write("synth", "scenario", "street");
  cfg.write("synth", "frames", 12);
  cfg.write("synth", "texture", false);
  cfg.write("synth", "noise_sigma", 1.5);
  cfg.write("synth", "out_dir", "/tmp/out");
  SynthOptions o;
  o.loadFromConfigFile(cfg, "synth");
  EXPECT_EQ(o.scenario, "street");
  EXPECT_EQ(o.frames, 12);
  EXPECT_FALSE(o.textured);
  EXPECT_DOUBLE_EQ(o.noiseSigma, 1.5);
  mrpt::config::CConfigFileMemory saved;
  o.saveToConfigFile(saved, "s");
  SynthOptions back;
  back.loadFromConfigFile(saved, "s");
  EXPECT_EQ(back.toJson(), o.toJson());
}

// slam-synth --config (params::loadSectionFromFile): every bad value is one error naming file, section and key.
TEST(SynthOptions, ConfigFileIsReadStrictly) {
  const fs::path dir = tempDir("cfg");
  const auto errorFor = [&](const std::string& text) {
    const std::string path = (dir / "synth.ini").string();
    std::ofstream(path) << text;
    SynthOptions o;
    try {
      params::loadSectionFromFile(o, path, "synth");
    } catch (const Error& e) {
      const std::string what = e.what();
      return what.rfind(path, 0) == 0 ? "F" + what.substr(path.size()) : what;
    }
    return std::string();
  };
  for (const auto& e : fs::directory_iterator(fs::path(PRIORSLAM_SOURCE_DIR) / "config/synth")) {
    SynthOptions o;
    EXPECT_NO_THROW(params::loadSectionFromFile(o, e.path().string(), "synth")) << e.path();
  }
  EXPECT_EQ(errorFor("[synth]\nframes = 2000.7\n"), "F: [synth] frames = 2000.7: not an integer");
  EXPECT_EQ(errorFor("[synth]\nframes = 2000000000\n"), "F: [synth] frames = 2000000000: must be in [0, 1000000]");
  EXPECT_EQ(errorFor("[synth]\nwidth = abc\n"), "F: [synth] width = abc: not an integer");
  EXPECT_EQ(errorFor("[synth]\nwidth = 640 extra\n"), "F: [synth] width = 640 extra: not an integer");
  EXPECT_EQ(errorFor("[synth]\ntexture = maybe\n"), "F: [synth] texture = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("[synth]\nseed = -1\n"), "F: [synth] seed = -1: integer out of range [0, 4294967295]");
  EXPECT_EQ(errorFor("[synth]\nnoise_sigma = nan\n"), "F: [synth] noise_sigma = nan: not a number");
  EXPECT_EQ(errorFor("[synth]\nscenario = moon\n"),
            "F: [synth] scenario = moon: must be one of room, lowtexture, street, corridor, jam, jam-static");
  EXPECT_EQ(errorFor("[synth]\nnoise = 1\n"), "F: [synth] noise: unknown key (did you mean noise_sigma?)");
  EXPECT_EQ(errorFor("[Synth]\nframes = 5\n"), "F: [Synth]: unknown section (did you mean synth?)");
  EXPECT_EQ(errorFor("frames = 5\n"),
            "F:1: frames: key outside any section (the file needs a [Section] header before it)");
  EXPECT_EQ(errorFor("[synth]\nframes = 5\n"), "");  // out_dir may come from the command line
  fs::remove_all(dir);
}

TEST(Sensor, ExposureIsAffineAndNoiseIsSeeded) {
  const cv::Mat radiance(32, 32, CV_32FC1, cv::Scalar(100.0f));
  Exposure e;
  e.gain = 1.2;
  e.offset = -7.0;
  const cv::Mat img = applySensor(radiance, e, 0.0, 1);
  EXPECT_EQ(cv::countNonZero(img != 113), 0);
  const cv::Mat n1 = applySensor(radiance, Exposure{}, 3.0, 42), n2 = applySensor(radiance, Exposure{}, 3.0, 42);
  const cv::Mat n3 = applySensor(radiance, Exposure{}, 3.0, 43);
  EXPECT_EQ(cv::countNonZero(n1 != n2), 0);
  EXPECT_GT(cv::countNonZero(n1 != n3), 100);
  cv::Scalar mean, sd;
  cv::meanStdDev(n1, mean, sd);
  EXPECT_NEAR(mean[0], 100.0, 0.5);
  EXPECT_NEAR(sd[0], 3.0, 0.4);
  // The exposure drifts smoothly: neighbouring frames (1/30 s) differ little, seconds apart noticeably.
  const Exposure a = Exposure::at(1.0, 5), b = Exposure::at(1.0 + 1.0 / 30, 5);
  EXPECT_LT(std::abs(a.gain - b.gain), 0.02);
  double spread = 0;
  for (int k = 0; k < 20; ++k) spread = std::max(spread, std::abs(Exposure::at(k * 1.7, 5).gain - 1.0));
  EXPECT_GT(spread, 0.05);
}

TEST(SynthApp, SameSeedSameBytesOtherSeedDiffers) {
  const fs::path d = tempDir("seed");
  for (const std::string& scenario : scenarioNames()) {
    SynthOptions a = small(scenario, d / "a", 11), b = small(scenario, d / "b", 11), c = small(scenario, d / "c", 12);
    a.noiseSigma = b.noiseSigma = c.noiseSigma = 2.0;
    a.exposure = b.exposure = c.exposure = true;
    SynthApp(a).run();
    SynthApp(b).run();
    SynthApp(c).run();
    int compared = 0, differing = 0;
    for (const std::string& folder : {scenario + "_Images", scenario + "_Labels"})
      for (const auto& e : fs::directory_iterator(d / "a" / folder)) {
        const fs::path rel = fs::path(folder) / e.path().filename();
        EXPECT_EQ(readBytes(d / "a" / rel), readBytes(d / "b" / rel)) << scenario << ": " << rel;
        ++compared;
        if (rel.filename().string().rfind("CAMERA", 0) == 0) differing += readBytes(d / "a" / rel) != readBytes(d / "c" / rel);
      }
    EXPECT_EQ(compared, 3 * 4) << scenario;  // CAMERA, SEMANTIC, NORMALS, LABEL per frame (depth is in the rawlog)
    EXPECT_EQ(differing, 3) << scenario << ": another seed must change every image";
    EXPECT_EQ(readBytes(d / "a" / (scenario + "_groundtruth.txt")), readBytes(d / "b" / (scenario + "_groundtruth.txt")));
  }
}

TEST(SynthApp, SequenceLengthDoesNotChangeTheScene) {
  // The first frames of a street sequence must not depend on how many frames are requested.
  const Scenario a = makeScenario("street", 9, 2 / 10.0), b = makeScenario("street", 9, 120.0);
  EXPECT_EQ(b.scene.objects.size(), a.scene.objects.size());
  SynthOptions o = small("street", "/tmp/unused", 9);
  const Renderer r(o.camera(), RenderOptions{});
  for (double t : {0.0, 15.0}) {
    const RenderedView va = r.render(a.scene, a.T_world_cam(t), t), vb = r.render(b.scene, b.T_world_cam(t), t);
    EXPECT_EQ(cv::countNonZero(va.radiance != vb.radiance), 0) << "t=" << t;
    EXPECT_EQ(cv::countNonZero(va.trainId != vb.trainId), 0) << "t=" << t;
  }
}

TEST(SynthApp, OutputsFollowTheRawlogContract) {
  const fs::path d = tempDir("contract");
  SynthOptions o = small("street", d, 3, 4);
  o.name = "seq";
  const SynthSummary s = SynthApp(o).run();
  EXPECT_EQ(s.frames, 4u);
  const Trajectory gt = readTumTrajectory(d / "seq_groundtruth.txt");
  ASSERT_EQ(gt.size(), 4u);
  datasets::RawlogReader reader(d / "seq.rawlog");
  datasets::Frame f;
  std::size_t i = 0;
  while (reader.next(f)) {
    ASSERT_LT(i, gt.size());
    EXPECT_EQ(f.timestamp, gt[i].timestamp) << "frame " << i;  // exact: whole microseconds
    EXPECT_EQ(f.image.type(), CV_8UC1);
    ASSERT_TRUE(f.hasDepth() && f.hasSemantic() && f.hasNormals());
    EXPECT_DOUBLE_EQ(f.depthUnits, static_cast<double>(static_cast<float>(1.0 / 1000.0)));
    EXPECT_NEAR(f.camera.fx(), 400.0 * 64 / 640, 1e-9);
    const cv::Mat labels = cv::imread((d / "seq_Labels" / cv::format("LABEL_%06zu.png", i)).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(labels.type(), CV_8UC1);
    ASSERT_EQ(labels.size(), f.image.size());
    int sky = 0;
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x) {
        const auto id = labels.at<std::uint8_t>(y, x);
        const cv::Vec3b sem = f.semantic.at<cv::Vec3b>(y, x);
        const int group = semanticGroupOfTrainId(id);
        for (int k = 0; k < 3; ++k) ASSERT_EQ(sem[k], k == group ? 255 : 0) << "one-hot at " << x << "," << y;
        cv::Vec3d n;
        const bool hasNormal = datasets::decodeNormal(f.normals.at<cv::Vec3b>(y, x), n);
        if (id == static_cast<int>(TrainId::Sky)) {
          ++sky;
          EXPECT_EQ(f.depth.at<std::uint16_t>(y, x), 0);
          EXPECT_FALSE(hasNormal);
        } else {
          EXPECT_TRUE(hasNormal);
          // Camera-frame normal faces the camera: it points against the viewing ray.
          const cv::Vec3d ray((x - f.camera.cx()) / f.camera.fx(), (y - f.camera.cy()) / f.camera.fy(), 1.0);
          EXPECT_LT(n.dot(ray), 0.02) << x << "," << y;
        }
      }
    EXPECT_GT(sky, 0) << "the street shows sky";
    ++i;
  }
  EXPECT_EQ(i, 4u);
  EXPECT_TRUE(fs::exists(d / "seq_synth.json"));
}

TEST(SynthApp, JamVehiclesAreDynamicInTheSemanticChannel) {
  // Moving and parked vehicles alike carry Cityscapes car/truck/bus labels, hence SEMANTIC "dynamic"
  // (Table 3.1): the chapter-3 models and masking see them as potentially dynamic.
  const fs::path d = tempDir("jam");
  SynthOptions o = small("jam", d, 2, 3);
  o.width = 96;
  o.height = 72;
  SynthApp(o).run();
  datasets::RawlogReader reader(d / "jam.rawlog");
  datasets::Frame f;
  while (reader.next(f)) {
    const cv::Mat labels = cv::imread((d / "jam_Labels" / cv::format("LABEL_%06zu.png", f.index)).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(labels.size(), f.semantic.size());
    int vehicles = 0, dynamic = 0;
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x) {
        const int id = labels.at<std::uint8_t>(y, x);
        const bool vehicle = id == int(TrainId::Car) || id == int(TrainId::Truck) || id == int(TrainId::Bus);
        vehicles += vehicle;
        dynamic += f.semantic.at<cv::Vec3b>(y, x)[1] == 255;
        if (vehicle) {
          ASSERT_EQ(f.semantic.at<cv::Vec3b>(y, x), cv::Vec3b(0, 255, 0)) << x << "," << y;
        }
      }
    EXPECT_EQ(dynamic, vehicles) << "frame " << f.index << ": only vehicles are dynamic";
    EXPECT_GT(vehicles, labels.total() / 10) << "frame " << f.index << ": dense traffic";
  }
}

TEST(SynthApp, GroundTruthReprojectsDepthBetweenFrames) {
  // Back-project frame 0 with its depth and ground-truth pose, project into frame 6: the predicted depth must
  // match frame 6's depth on static surfaces. This checks the pose convention (camera-to-world) end to end.
  const fs::path d = tempDir("reproject");
  SynthOptions o = small("room", d, 5, 7);
  o.width = 96;
  o.height = 72;
  SynthApp(o).run();
  const Trajectory gt = readTumTrajectory(d / "room_groundtruth.txt");
  datasets::RawlogReader reader(d / "room.rawlog");
  std::vector<datasets::Frame> frames;
  datasets::Frame f;
  while (reader.next(f)) frames.push_back(f);
  ASSERT_EQ(frames.size(), 7u);
  const auto& f0 = frames[0];
  const auto& f1 = frames[6];
  const Eigen::Isometry3d T_c1_c0 = gt[6].T_world_cam().inverse() * gt[0].T_world_cam();
  EXPECT_GT(T_c1_c0.translation().norm(), 0.02) << "the camera moves at the start (parallax)";
  const auto& K = f0.camera;
  int checked = 0, agree = 0;
  for (int y = 0; y < f0.depth.rows; ++y)
    for (int x = 0; x < f0.depth.cols; ++x) {
      const double z = f0.depth.at<std::uint16_t>(y, x) * f0.depthUnits;
      if (z <= 0) continue;
      const Eigen::Vector3d p0(z * (x - K.cx()) / K.fx(), z * (y - K.cy()) / K.fy(), z);
      const Eigen::Vector3d p1 = T_c1_c0 * p0;
      const int u = static_cast<int>(std::lround(K.fx() * p1.x() / p1.z() + K.cx()));
      const int v = static_cast<int>(std::lround(K.fy() * p1.y() / p1.z() + K.cy()));
      if (u < 0 || v < 0 || u >= f1.depth.cols || v >= f1.depth.rows) continue;
      const double z1 = f1.depth.at<std::uint16_t>(v, u) * f1.depthUnits;
      ++checked;
      agree += std::abs(z1 - p1.z()) < 0.03 * p1.z();
    }
  ASSERT_GT(checked, 2000);
  EXPECT_GT(agree, 0.9 * checked) << agree << " of " << checked;
}

// Reliability (doc/reliability.md): a run commits all of its outputs or none; an impossible preview path is
// found before anything is written.
TEST(SynthApp, ImpossiblePreviewPathFailsBeforeAnythingIsCommitted) {
  const fs::path d = tempDir("preview_impossible");
  std::ofstream(d / "file.txt") << "a file, not a folder";
  SynthOptions o = small("room", d / "out", 1);
  o.preview = d / "file.txt" / "preview.png";
  try {
    SynthApp(o).run();
    ADD_FAILURE() << "expected pslam::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("file.txt: cannot create output folder"), std::string::npos) << e.what();
  }
  for (const char* name : {"room.rawlog", "room_Images", "room_Labels", "room_groundtruth.txt", "room_synth.json"})
    EXPECT_FALSE(fs::exists(d / "out" / name)) << name;
  if (fs::exists(d / "out"))
    for (const auto& e : fs::directory_iterator(d / "out")) ADD_FAILURE() << "left behind: " << e.path();
}
