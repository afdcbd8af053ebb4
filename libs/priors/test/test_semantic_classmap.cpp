#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "pslam/core/Error.h"
#include "pslam/priors/SemanticClassMap.h"

using namespace pslam::priors;
namespace fs = std::filesystem;

namespace {
fs::path tempIni(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("pslam_test_semantic_" + name + ".ini");
  std::ofstream(p) << text;
  return p;
}
}  // namespace

TEST(SemanticClassMap, CityscapesIsTable31) {
  const auto m = SemanticClassMap::cityscapes();
  ASSERT_EQ(m.numClasses(), 19);
  int counts[3] = {0, 0, 0};
  for (auto g : m.groups) ++counts[int(g)];
  EXPECT_EQ(counts[0], 10);  // road ... terrain
  EXPECT_EQ(counts[1], 8);   // person ... bicycle
  EXPECT_EQ(counts[2], 1);   // sky
  EXPECT_EQ(m.classNames[10], "sky");
  EXPECT_EQ(m.groupOf(10), SemanticClass::Invalid);
  EXPECT_EQ(m.groupOf(11), SemanticClass::Dynamic);  // person
  EXPECT_EQ(m.groupOf(13), SemanticClass::Dynamic);  // car
  EXPECT_EQ(m.groupOf(0), SemanticClass::Static);    // road
  EXPECT_EQ(m.groupOf(255), SemanticClass::Invalid);  // ignore label
  EXPECT_EQ(m.groupLookupTable().at<uchar>(13), 1);
}

TEST(SemanticClassMap, ShippedIniFilesLoadAndCityscapesIniEqualsBuiltIn) {
  const fs::path dir = fs::path(PRIORSLAM_SOURCE_DIR) / "config" / "semantic";
  const auto builtIn = SemanticClassMap::cityscapes();
  const auto fromIni = SemanticClassMap::loadFromFile(dir / "cityscapes.ini");
  EXPECT_EQ(fromIni.classNames, builtIn.classNames);
  EXPECT_EQ(fromIni.groups, builtIn.groups);
  EXPECT_EQ(fromIni.unlabeled, builtIn.unlabeled);
  struct Expect {
    const char* file;
    int numClasses;
    int dynamicIndex;
  };
  for (const Expect& e : {Expect{"virtual_kitti.ini", 14, 12}, Expect{"synthia.ini", 23, 10},
                          Expect{"ade20k.ini", 150, 12}, Expect{"coco.ini", 81, 1}}) {
    SCOPED_TRACE(e.file);
    const auto m = SemanticClassMap::loadFromFile(dir / e.file);
    EXPECT_EQ(m.numClasses(), e.numClasses);
    EXPECT_EQ(m.groupOf(e.dynamicIndex), SemanticClass::Dynamic);
  }
  EXPECT_EQ(SemanticClassMap::loadFromFile(dir / "ade20k.ini").groupOf(2), SemanticClass::Invalid);  // sky
  EXPECT_EQ(SemanticClassMap::loadFromFile(dir / "ade20k.ini").classNames[20], "car");
}

TEST(SemanticClassMap, DefaultGroupAndMultiWordNames) {
  const auto p = tempIni("default", "[SemanticClassMap]\nname = tiny\nnumClasses = 3\ndefault = static\n"
                                    "class1 = traffic light static\nclass2 = person dynamic\n");
  const auto m = SemanticClassMap::loadFromFile(p);
  EXPECT_EQ(m.classNames[1], "traffic light");
  EXPECT_EQ(m.groupOf(0), SemanticClass::Static);
  EXPECT_EQ(m.groupOf(2), SemanticClass::Dynamic);
  fs::remove(p);
}

TEST(SemanticClassMap, ErrorsNameFileAndKey) {
  auto expectError = [](const std::string& text, const std::string& needle) {
    const auto p = tempIni("bad", text);
    try {
      SemanticClassMap::loadFromFile(p);
      ADD_FAILURE() << "expected an error for: " << text;
    } catch (const pslam::Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
      EXPECT_NE(msg.find(p.string()), std::string::npos) << msg;
    }
    fs::remove(p);
  };
  expectError("[SemanticClassMap]\nnumClasses = 2\nclass0 = road static\n", "class1");
  expectError("[SemanticClassMap]\nnumClasses = 1\nclass0 = road moving\n", "class0");
  expectError("[SemanticClassMap]\nnumClasses = 0\n", "numClasses");
  expectError("[SemanticClassMap]\nnumClasses = 1\nclass0 = road\n", "class0");
  EXPECT_THROW(SemanticClassMap::loadFromFile("/nonexistent/map.ini"), pslam::Error);
}

// The class map is read strictly although its keys are no fixed list (class0 ... class<numClasses-1>).
TEST(SemanticClassMap, ReadStrictly) {
  const auto p = tempIni("strict", "");
  const auto errorFor = [&](const std::string& text) {
    std::ofstream(p) << text;
    try {
      SemanticClassMap::loadFromFile(p);
    } catch (const pslam::Error& e) {
      const std::string what = e.what();
      return what.rfind(p.string(), 0) == 0 ? "F" + what.substr(p.string().size()) : what;
    }
    return std::string();
  };
  const std::string head = "[SemanticClassMap]\nnumClasses = 2\nclass0 = road static\nclass1 = car dynamic\n";
  EXPECT_EQ(errorFor(head), "");
  EXPECT_EQ(errorFor(head + "class2 = sky invalid\n"),
            "F: [SemanticClassMap] class2: unknown key (numClasses = 2: class0 ... class1)");
  EXPECT_EQ(errorFor(head + "unlabled = invalid\n"), "F: [SemanticClassMap] unlabled: unknown key (did you mean unlabeled?)");
  EXPECT_EQ(errorFor(head + "unlabeled = invalid extra\n"),
            "F: [SemanticClassMap] unlabeled = invalid extra: group 'invalid extra' unknown (expected static, dynamic or invalid)");
  EXPECT_EQ(errorFor("[SemanticClassMap]\nnumClasses = 2.5\n"), "F: [SemanticClassMap] numClasses = 2.5: not an integer");
  EXPECT_EQ(errorFor("[SemanticClassMap]\nnumClasses = 2000000000\n"),
            "F: [SemanticClassMap] numClasses = 2000000000: must be in [1, 256]");
  EXPECT_EQ(errorFor("[SemanticClassMap]\nname = x\n"), "F: [SemanticClassMap] numClasses: missing");
  EXPECT_EQ(errorFor(head + "[Other]\nx = 1\n"), "F: [Other]: unknown section (did you mean SemanticClassMap?)");
  EXPECT_EQ(errorFor("numClasses = 2\n"),
            "F:1: numClasses: key outside any section (the file needs a [Section] header before it)");
  fs::remove(p);
}
