// The [SemanticNetwork] ini (semantic-priors --network) is read strictly: unknown keys, values of the wrong
// type or range, an unknown framework are errors naming the file, section and key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "pslam/core/Error.h"
#include "pslam/priors/SemanticNetwork.h"

using namespace pslam::priors;
namespace fs = std::filesystem;

TEST(SemanticNetworkParams, ReadStrictly) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_semantic_network_params_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "w.caffemodel") << "weights";
  const fs::path ini = dir / "net.ini";
  const auto errorFor = [&](const std::string& extra) {
    std::ofstream(ini) << "[SemanticNetwork]\nmodel = w.caffemodel\n" << extra;
    try {
      SemanticNetworkParams::loadFromFile(ini);
    } catch (const pslam::Error& e) {
      const std::string what = e.what();
      return what.rfind(ini.string(), 0) == 0 ? "F" + what.substr(ini.string().size()) : what;
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("framework = caffe\nmean = 0 0 0\ninputWidth = 1024\n"), "");
  EXPECT_EQ(errorFor("framework = bogus\n"),
            "F: [SemanticNetwork] framework = bogus: must be empty (from the model's file extension) or one of caffe, "
            "tensorflow, torch, darknet, dldt, onnx");
  EXPECT_EQ(errorFor("mean = 0 0\n"), "F: [SemanticNetwork] mean = 0 0: expected 3 numbers, got 2");
  EXPECT_EQ(errorFor("mean = 0 0 abc\n"),
            "F: [SemanticNetwork] mean = 0 0 abc: 'abc': not a number (expected numbers separated by commas or spaces)");
  EXPECT_EQ(errorFor("inputWidth = 1024.5\n"), "F: [SemanticNetwork] inputWidth = 1024.5: not an integer");
  EXPECT_EQ(errorFor("inputWidth = 2000000000\n"), "F: [SemanticNetwork] inputWidth = 2000000000: must be in [1, 16384]");
  EXPECT_EQ(errorFor("softmax = maybe\n"), "F: [SemanticNetwork] softmax = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("scale = nan\n"), "F: [SemanticNetwork] scale = nan: not a number");
  EXPECT_EQ(errorFor("classmap = cityscapes\n"), "F: [SemanticNetwork] classmap: unknown key (did you mean classMap?)");
  EXPECT_EQ(errorFor("config = missing.prototxt\n"),
            "F: [SemanticNetwork] config = " + (dir / "missing.prototxt").string() + ": file not found");
  std::ofstream(ini) << "[SemanticNetwork]\nmodel = absent.caffemodel\n";
  try {
    SemanticNetworkParams::loadFromFile(ini);
    FAIL();
  } catch (const pslam::Error& e) {
    EXPECT_EQ(std::string(e.what()),
              ini.string() + ": [SemanticNetwork] model = " + (dir / "absent.caffemodel").string() + ": file not found");
  }
  const SemanticNetworkParams p = [&] {
    std::ofstream(ini) << "[SemanticNetwork]\nmodel = w.caffemodel\nmean = 1, 2, 3\n";
    return SemanticNetworkParams::loadFromFile(ini);
  }();
  EXPECT_EQ(p.mean, (std::array<double, 3>{1, 2, 3}));
  EXPECT_EQ(p.model, dir / "w.caffemodel");
  fs::remove_all(dir);
}

namespace {
std::string networkError(const SemanticNetworkParams& p) {
  try {
    SemanticNetwork net(p);
  } catch (const pslam::Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// Reliability (doc/reliability.md): a truncated prototxt was blamed on the caffemodel, an empty caffemodel failed
// only at frame 0 (with OpenCV's log lines), an empty ONNX file said `model_proto.has_graph()`. Each file is named
// with what is wrong with it, when the network is made.
TEST(SemanticNetwork, BadModelFilesAreNamedWithTheReason) {
  const fs::path dir = fs::temp_directory_path() / ("pslam_semantic_network_files_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "empty.caffemodel");
  std::ofstream(dir / "empty.onnx");
  std::ofstream(dir / "some.caffemodel") << "not really weights, but not empty either";
  std::ofstream(dir / "cut.prototxt") << "name: \"ENet\"\nlayer {\n  name: \"data\"\n  type: \"Inp";
  std::ofstream(dir / "ok.prototxt") << "name: \"tiny\"\ninput: \"data\"\ninput_dim: 1\ninput_dim: 3\ninput_dim: 8\n"
                                        "input_dim: 8\n";
  SemanticNetworkParams p;
  p.framework = "caffe";
  p.model = dir / "empty.caffemodel";
  p.config = dir / "ok.prototxt";
  std::string e = networkError(p);
  EXPECT_NE(e.find((dir / "empty.caffemodel").string() + ": empty file (0 bytes): not a network model (framework caffe)"), std::string::npos) << e;
  p.model = dir / "some.caffemodel";
  p.config = dir / "cut.prototxt";
  e = networkError(p);
  EXPECT_EQ(e.rfind((dir / "cut.prototxt").string() + ": OpenCV DNN cannot read the network description", 0), 0u) << e;
  p.framework = "onnx";
  p.model = dir / "empty.onnx";
  p.config.clear();
  e = networkError(p);
  EXPECT_NE(e.find((dir / "empty.onnx").string() + ": empty file (0 bytes): not a network model (framework onnx)"), std::string::npos) << e;
  EXPECT_EQ(e.find("has_graph"), std::string::npos) << e;
  fs::remove_all(dir);
}
