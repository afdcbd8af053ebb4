// Every shipped config/manhattan/*.ini loads through the reader of manhattan-eval (its tracker section and the
// normal sources' sections, strictly: an unknown section or key, a bad value are errors naming file, section
// and key).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "pslam/core/Error.h"
#include "pslam/manhattan/ManhattanEvalApp.h"

using namespace pslam::manhattan;
namespace fs = std::filesystem;

TEST(ManhattanEvalConfig, ShippedConfigsLoad) {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan")) {
    if (entry.path().extension() != ".ini") continue;
    SCOPED_TRACE(entry.path().string());
    ++files;
    EXPECT_NO_THROW(ManhattanEvalConfig::loadFromFile(entry.path()));
  }
  EXPECT_GE(files, 2);
  const auto c = ManhattanEvalConfig::loadFromFile(fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan/tum_fr3_depth.ini");
  EXPECT_EQ(c.normals.depth.minDepth, 0.3);
  EXPECT_EQ(c.tracker.kernelWidth, 2.0);
  // Relative model paths of the network section: against the ini's folder.
  const auto n =
      ManhattanEvalConfig::loadFromFile(fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan/network_normals_example.ini");
  EXPECT_EQ(fs::path(n.normals.network.model).filename(), "plane_normals.onnx");
  EXPECT_TRUE(fs::path(n.normals.network.model).is_absolute());
}

TEST(ManhattanEvalConfig, BadValuesNameFileSectionAndKey) {
  const fs::path path = fs::temp_directory_path() / "pslam_test_manhattan_config.ini";
  const auto errorFor = [&](const std::string& text) {
    std::ofstream(path) << text;
    try {
      ManhattanEvalConfig::loadFromFile(path);
    } catch (const pslam::Error& e) {
      const std::string what = e.what();
      return what.rfind(path.string(), 0) == 0 ? "F" + what.substr(path.string().size()) : what;
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("[ManhattanTracker]\nkernelWidth = abc\n"), "F: [ManhattanTracker] kernelWidth = abc: not a number");
  EXPECT_EQ(errorFor("[NormalsFromDepth]\nwindowRadius = 5.5\n"),
            "F: [NormalsFromDepth] windowRadius = 5.5: not an integer");
  EXPECT_EQ(errorFor("[NormalsFromDepth]\nusePlaneNormals = maybe\n"),
            "F: [NormalsFromDepth] usePlaneNormals = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\nframework = bogus\n"),
            "F: [NormalsFromNetwork] framework = bogus: must be empty (from the model's file extension) or one of "
            "caffe, tensorflow, torch, darknet, dldt, onnx");
  EXPECT_EQ(errorFor("[NormalsFromNetwork]\naxisMapping = x,y\n"),
            "F: [NormalsFromNetwork] axisMapping = x,y: must have exactly three entries");
  EXPECT_EQ(errorFor("[ManhattanTracker]\nconeAngle = 10\n"),
            "F: [ManhattanTracker] coneAngle: unknown key (did you mean coneAngleDeg?)");
  EXPECT_EQ(errorFor("[NormalsFromDepht]\nminDepth = 0.3\n"),
            "F: [NormalsFromDepht]: unknown section (did you mean NormalsFromDepth?)");
  EXPECT_EQ(errorFor("kernelWidth = 2\n"),
            "F:1: kernelWidth: key outside any section (the file needs a [Section] header before it)");
  fs::remove(path);
}
