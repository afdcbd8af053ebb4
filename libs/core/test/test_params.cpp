// The declarative parameter mechanism (pslam/core/Params.h): round trip, strict parsing, rules, unknown keys
// and sections, overrides, the one error format.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Params.h"

using namespace pslam;

namespace demo {

enum class Model { Heuristic, Masking, Probabilistic };
constexpr std::array<std::pair<Model, const char*>, 3> enumNames(Model) {
  return {{{Model::Heuristic, "heuristic"}, {Model::Masking, "masking"}, {Model::Probabilistic, "probabilistic"}}};
}

struct Inner {
  int minInliers = 15;
  double ratio = 0.9;
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minInliers, atLeast(0), "inliers");
    PSLAM_FIELD(v, ratio, inLeftOpen(0, 1), "ratio");
  }
};

struct Other {
  int minInliers = 4;
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minInliers, atLeast(4), "PnP inliers");
  }
};

struct Flat {
  std::string name = "x";
  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, name, nonEmpty, "a name");
  }
};

struct Demo {
  int count = 10;
  unsigned seed = 42;
  std::size_t maxNormals = 20000;
  std::int64_t window = 2;
  double sigma = 1.0;
  double prior = std::numeric_limits<double>::infinity();
  float radius = 0.7f;
  bool parallel = true;
  std::string solver = "sparse_schur";
  Model model = Model::Heuristic;
  int minThreshold = 7;
  Inner keyFrames;
  Other pnp;
  Flat flat;
  Inner external;  ///< set by the caller from [External]

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, count, inClosed(3, 100), "a small count");
    PSLAM_FIELD(v, seed, anyValue, "seed");
    PSLAM_FIELD(v, maxNormals, atLeast(10), "normals per frame");
    PSLAM_FIELD(v, window, anyValue, "keyframes, may be negative");
    PSLAM_FIELD(v, sigma, greaterThan(0), "pixels");
    PSLAM_FIELD(v, prior, atLeast(0).orInfinite(), "count, may be inf");
    PSLAM_FIELD(v, radius, greaterThan(0), "factor");
    PSLAM_FIELD(v, parallel, anyValue, "two threads");
    PSLAM_FIELD(v, solver, oneOf({"sparse_schur", "dense_schur"}), "Ceres solver");
    PSLAM_FIELD(v, model, anyValue, "map-point model");
    PSLAM_FIELD(v, minThreshold, satisfies([this](int x) { return x > 0 && x <= count; }, "must be in (0, count]"),
                "fallback threshold");
    PSLAM_NESTED(v, keyFrames);
    PSLAM_NESTED(v, pnp);
    v.flat(flat);
    v.fromSection("External", external);
  }
  PSLAM_PARAMS("Demo")
};

struct Duplicate {
  Inner a;
  Other b;
  template <class V>
  void visitFields(V& v) {
    v.flat(a);
    v.flat(b);
  }
  PSLAM_PARAMS("Duplicate")
};

struct Config {
  Demo demo;
  Flat other;
  template <class V>
  void visitSections(V& v) {
    v.section("Demo", demo);
    v.section("Other", other);
  }
};

}  // namespace demo

PSLAM_DEFINE_PARAMS(demo::Demo)
PSLAM_DEFINE_PARAMS(demo::Duplicate)

namespace {

std::string loadError(const std::string& ini, const std::string& section = "Demo") {
  mrpt::config::CConfigFileMemory cfg(ini);
  demo::Demo d;
  try {
    d.loadFromConfigFile(cfg, section);
  } catch (const params::ParamError& e) {
    return e.what();
  }
  return "";
}

std::string valueError(const std::string& key, const std::string& value) {
  return loadError("[Demo]\n" + key + " = " + value + "\n");
}

}  // namespace

TEST(Params, RoundTripThroughIniKeepsEveryValue) {
  demo::Demo d;
  d.count = 55;
  d.seed = 4000000000u;
  d.maxNormals = 123456789012ull;
  d.window = -3;
  d.sigma = 1.0 / 3.0;
  d.prior = 0.1;
  d.radius = 0.1f;
  d.parallel = false;
  d.solver = "dense_schur";
  d.model = demo::Model::Probabilistic;
  d.minThreshold = 50;
  d.keyFrames.minInliers = 3;
  d.keyFrames.ratio = 1.0 / 7.0;
  d.pnp.minInliers = 9;
  d.flat.name = "a name with spaces";
  d.check();
  const std::string text = params::toIniText(d, "Demo");
  mrpt::config::CConfigFileMemory cfg(text);
  demo::Demo e;
  e.loadFromConfigFile(cfg);
  EXPECT_EQ(e.count, 55);
  EXPECT_EQ(e.seed, 4000000000u);
  EXPECT_EQ(e.maxNormals, 123456789012ull);
  EXPECT_EQ(e.window, -3);
  EXPECT_EQ(e.sigma, 1.0 / 3.0);  // bit-exact
  EXPECT_EQ(e.prior, 0.1);
  EXPECT_EQ(e.radius, 0.1f);
  EXPECT_FALSE(e.parallel);
  EXPECT_EQ(e.solver, "dense_schur");
  EXPECT_EQ(e.model, demo::Model::Probabilistic);
  EXPECT_EQ(e.minThreshold, 50);
  EXPECT_EQ(e.keyFrames.minInliers, 3);
  EXPECT_EQ(e.keyFrames.ratio, 1.0 / 7.0);
  EXPECT_EQ(e.pnp.minInliers, 9);
  EXPECT_EQ(e.flat.name, "a name with spaces");
  EXPECT_EQ(params::toIniText(e, "Demo"), text);
  // Keys: field names, nested ones prefixed, flat ones plain, fromSection ones absent.
  EXPECT_NE(text.find("keyFrames.minInliers = 3"), std::string::npos) << text;
  EXPECT_NE(text.find("pnp.minInliers = 9"), std::string::npos);
  EXPECT_NE(text.find("name = a name with spaces"), std::string::npos);
  EXPECT_NE(text.find("model = probabilistic"), std::string::npos);
  EXPECT_NE(text.find("sigma = 0.3333333333333333"), std::string::npos);
  EXPECT_NE(text.find("radius = 0.1\n"), std::string::npos);
  EXPECT_EQ(text.find("external"), std::string::npos);
}

TEST(Params, AbsentKeysKeepTheirValuesAndInfRoundTrips) {
  mrpt::config::CConfigFileMemory cfg("[Demo]\ncount = 12\n");
  demo::Demo d;
  d.loadFromConfigFile(cfg);
  EXPECT_EQ(d.count, 12);
  EXPECT_EQ(d.sigma, 1.0);
  EXPECT_TRUE(std::isinf(d.prior));
  EXPECT_NE(params::toIniText(d, "Demo").find("prior = inf"), std::string::npos);
  mrpt::config::CConfigFileMemory empty("");
  demo::Demo e;
  e.loadFromConfigFile(empty);  // no section: defaults
  EXPECT_EQ(e.count, 10);
}

TEST(Params, ParsingIsStrict) {
  EXPECT_EQ(valueError("count", "2000 extra"), "[Demo] count = 2000 extra: not an integer");
  EXPECT_EQ(valueError("count", "20.7"), "[Demo] count = 20.7: not an integer");
  EXPECT_EQ(valueError("count", ""), "[Demo] count = : not an integer");
  EXPECT_EQ(valueError("count", "99999999999"), "[Demo] count = 99999999999: integer out of range [-2147483648, 2147483647]");
  EXPECT_EQ(valueError("seed", "-1"), "[Demo] seed = -1: integer out of range [0, 4294967295]");
  EXPECT_EQ(valueError("seed", "4294967296"), "[Demo] seed = 4294967296: integer out of range [0, 4294967295]");
  EXPECT_EQ(valueError("sigma", "abc"), "[Demo] sigma = abc: not a number");
  EXPECT_EQ(valueError("sigma", "1.5x"), "[Demo] sigma = 1.5x: not a number");
  EXPECT_EQ(valueError("sigma", "nan"), "[Demo] sigma = nan: not a number");
  EXPECT_EQ(valueError("sigma", "1e999"), "[Demo] sigma = 1e999: number out of the range of double");
  EXPECT_EQ(valueError("radius", "1e39"), "[Demo] radius = 1e39: number out of the range of float");
  EXPECT_EQ(valueError("parallel", "maybe"), "[Demo] parallel = maybe: not a bool (true or false)");
  EXPECT_EQ(valueError("model", "bogus"), "[Demo] model = bogus: must be one of heuristic, masking, probabilistic");
  // A large value that fits the type is a range-check matter, not a parse error.
  EXPECT_EQ(valueError("count", "2000000000"), "[Demo] count = 2000000000: must be in [3, 100]");
  // Accepted spellings.
  EXPECT_EQ(valueError("count", "+12"), "");
  EXPECT_EQ(valueError("count", "12   ; a comment"), "");
  EXPECT_EQ(valueError("count", "12 # a comment"), "");
  EXPECT_EQ(valueError("sigma", "2.5e-1 // a comment"), "");
  EXPECT_EQ(valueError("prior", "inf"), "");
  EXPECT_EQ(valueError("parallel", "No"), "");
  EXPECT_EQ(valueError("model", "Masking"), "");
  EXPECT_EQ(valueError("seed", "-0"), "");
}

TEST(Params, ChecksUseTheOneErrorFormat) {
  EXPECT_EQ(valueError("count", "1"), "[Demo] count = 1: must be in [3, 100]");
  EXPECT_EQ(valueError("sigma", "0"), "[Demo] sigma = 0: must be > 0");
  EXPECT_EQ(valueError("sigma", "inf"), "[Demo] sigma = inf: must be finite");
  EXPECT_EQ(valueError("prior", "-inf"), "[Demo] prior = -inf: must be >= 0 (inf allowed)");
  EXPECT_EQ(valueError("maxNormals", "3"), "[Demo] maxNormals = 3: must be >= 10");
  EXPECT_EQ(valueError("solver", "qr"), "[Demo] solver = qr: must be one of sparse_schur, dense_schur");
  EXPECT_EQ(valueError("name", ""), "[Demo] name = : must not be empty");
  EXPECT_EQ(valueError("minThreshold", "11"), "[Demo] minThreshold = 11: must be in (0, count]");
  EXPECT_EQ(valueError("keyFrames.ratio", "0"), "[Demo] keyFrames.ratio = 0: must be in (0, 1]");
  EXPECT_EQ(valueError("pnp.minInliers", "3"), "[Demo] pnp.minInliers = 3: must be >= 4");
  // The section in the message is the one loaded from; check() names the default section.
  EXPECT_EQ(loadError("[Other]\ncount = 0\n", "Other"), "[Other] count = 0: must be in [3, 100]");
  demo::Demo d;
  d.count = 0;
  try {
    d.check();
    FAIL();
  } catch (const params::ParamError& e) {
    EXPECT_STREQ(e.what(), "[Demo] count = 0: must be in [3, 100]");
    EXPECT_EQ(e.section(), "Demo");
    EXPECT_EQ(e.key(), "count");
  }
  // A struct owned by another section is checked under that section's name.
  demo::Demo f;
  f.external.ratio = 2;
  EXPECT_THROW(f.check(), params::ParamError);
  try {
    f.check();
  } catch (const params::ParamError& e) {
    EXPECT_STREQ(e.what(), "[External] ratio = 2: must be in (0, 1]");
  }
}

TEST(Params, UnknownKeyNamesTheClosestKey) {
  EXPECT_EQ(loadError("[Demo]\nsigam = 1\n"), "[Demo] sigam: unknown key (did you mean sigma?)");
  // MRPT matches keys without regard to case; the mechanism does not.
  EXPECT_EQ(loadError("[Demo]\nmaxnormals = 100\n"), "[Demo] maxnormals: unknown key (did you mean maxNormals?)");
  EXPECT_EQ(loadError("[Demo]\nminInliers = 5\n"),
            "[Demo] minInliers: unknown key (did you mean pnp.minInliers?)");
  EXPECT_EQ(loadError("[Demo]\nexternal.ratio = 0.5\n"),
            "[Demo] external.ratio: unknown key (did you mean keyFrames.ratio?)");
  EXPECT_EQ(loadError("[demo]\ncount = 5\n"), "[demo]: unknown section (did you mean Demo?)");
  // Sections other than the one loaded are not this struct's business.
  EXPECT_EQ(loadError("[Elsewhere]\nwhatever = 1\n"), "");
}

TEST(Params, DuplicateKeysAreAProgrammingError) {
  mrpt::config::CConfigFileMemory cfg("");
  demo::Duplicate d;
  EXPECT_THROW(d.loadFromConfigFile(cfg), std::logic_error);
}

TEST(Params, DescribeListsKeysRulesAndDocs) {
  const auto rows = params::describe(demo::Demo{});
  ASSERT_EQ(rows.size(), 15u);
  EXPECT_EQ(rows[0].key, "count");
  EXPECT_EQ(rows[0].value, "10");
  EXPECT_EQ(rows[0].rule, "must be in [3, 100]");
  EXPECT_EQ(rows[0].doc, "a small count");
  EXPECT_EQ(rows[11].key, "keyFrames.minInliers");
  EXPECT_EQ(rows[14].key, "name");
}

TEST(Params, SectionsUnknownSectionNamesTheClosest) {
  demo::Config c;
  mrpt::config::CConfigFileMemory ok("[Demo]\ncount = 8\n[Other]\nname = y\n");
  params::loadSections(c, ok);
  EXPECT_EQ(c.demo.count, 8);
  EXPECT_EQ(c.other.name, "y");
  mrpt::config::CConfigFileMemory bad("[Demo]\ncount = 5\n[Othre]\nname = y\n");
  try {
    params::loadSections(c, bad);
    FAIL();
  } catch (const params::ParamError& e) {
    EXPECT_STREQ(e.what(), "[Othre]: unknown section (did you mean Other?)");
  }
  mrpt::config::CConfigFileMemory saved(params::iniText([&](auto& cfg) { params::saveSections(c, cfg); }));
  demo::Config d;
  params::loadSections(d, saved);
  EXPECT_EQ(d.demo.count, 8);
  c.other.name = "";
  EXPECT_THROW(params::checkSections(c), params::ParamError);
}

TEST(Params, OverridesApplyInOrder) {
  mrpt::config::CConfigFileMemory cfg("[Demo]\ncount = 5\n");
  params::applyOverrides(cfg, {"Demo.count=6", "Demo.keyFrames.ratio = 0.5", "Demo.name=a=b", "Demo.count=7",
                               "Extra.key=1"});
  demo::Demo d;
  d.loadFromConfigFile(cfg);
  EXPECT_EQ(d.count, 7);
  EXPECT_EQ(d.keyFrames.ratio, 0.5);
  EXPECT_EQ(d.flat.name, "a=b");
  EXPECT_EQ(cfg.read_int("Extra", "key", 0), 1);
}

TEST(Params, MalformedOverridesNameTheText) {
  auto error = [](const std::string& text) {
    mrpt::config::CConfigFileMemory cfg("[Demo]\ncount = 5\n");
    try {
      params::applyOverrides(cfg, {text});
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("Demo.count"), "override 'Demo.count': expected Section.key=value (no '=')");
  EXPECT_EQ(error("count=5"), "override 'count=5': expected Section.key=value (no '.' between section and key)");
  EXPECT_EQ(error(".count=5"), "override '.count=5': empty section");
  EXPECT_EQ(error("Demo.=5"), "override 'Demo.=5': empty key");
  EXPECT_EQ(error("Demo.COUNT=5"), "override 'Demo.COUNT=5': key differs only in case from count in [Demo]");
  EXPECT_EQ(error("demo.count=5"), "override 'demo.count=5': section differs only in case from [Demo]");
  EXPECT_EQ(error("Demo.count="), "");  // an empty value is the loader's business
}

TEST(Params, WithSourceNamesTheFileOrTheOverride) {
  const std::vector<std::string> overrides{"Demo.sigam=2", "Demo.count=1"};
  auto errorFor = [&](const std::string& ini, const std::vector<std::string>& ov) {
    mrpt::config::CConfigFileMemory cfg(ini);
    params::applyOverrides(cfg, ov);
    demo::Demo d;
    try {
      params::withSource("dir/demo.ini", ov, [&] { d.loadFromConfigFile(cfg); });
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorFor("[Demo]\ncount = 1\n", {}), "dir/demo.ini: [Demo] count = 1: must be in [3, 100]");
  EXPECT_EQ(errorFor("[Demo]\n", {"Demo.count=1"}), "override 'Demo.count=1': [Demo] count = 1: must be in [3, 100]");
  EXPECT_EQ(errorFor("[Demo]\n", {"Demo.sigam=2"}),
            "override 'Demo.sigam=2': [Demo] sigam: unknown key (did you mean sigma?)");
  EXPECT_EQ(errorFor("[Demo]\nsigam = 2\n", {"Demo.count=5"}),
            "dir/demo.ini: [Demo] sigam: unknown key (did you mean sigma?)");
}

TEST(Params, ReadConfigTextNamesAMissingFile) {
  try {
    params::readConfigText("/nonexistent/x.ini");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/x.ini: config file not found");
  }
  const auto path = std::filesystem::temp_directory_path() / "pslam_test_params.ini";
  std::ofstream(path) << "[Demo]\ncount = 8\n";
  EXPECT_EQ(params::readConfigText(path.string()), "[Demo]\ncount = 8\n");
  std::filesystem::remove(path);
}

TEST(Params, AnIncludedFileIsReadFirstAndTheIncludingOneReplacesItsKeys) {
  // config/slam/structure_network.ini: "include = structure.ini" and only what differs.
  const auto dir = std::filesystem::temp_directory_path() / "pslam_test_params_include";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "sub");
  std::ofstream(dir / "base.ini") << "[Demo]\ncount = 8\nsigma = 1.5\nname = base\n";
  std::ofstream(dir / "sub" / "derived.ini") << "# only what differs\ninclude = ../base.ini\n[Demo]\ncount = 9\n";
  demo::Demo d;
  params::loadConfigFile((dir / "sub" / "derived.ini").string(), {"Demo"},
                         [&](const mrpt::config::CConfigFileBase& cfg) { d.loadFromConfigFile(cfg, "Demo"); });
  EXPECT_EQ(d.count, 9);           // the including file's value
  EXPECT_EQ(d.sigma, 1.5);         // the base's, kept
  EXPECT_EQ(d.flat.name, "base");  // a key only the base has
  auto errorOf = [&](const std::string& file) {
    try {
      params::readConfigText((dir / file).string());
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // A missing base, a cycle and a second include are named with the file that includes.
  std::ofstream(dir / "missing.ini") << "include = nothere.ini\n[Demo]\n";
  EXPECT_NE(errorOf("missing.ini").find("missing.ini: include = nothere.ini: "), std::string::npos) << errorOf("missing.ini");
  EXPECT_NE(errorOf("missing.ini").find("config file not found"), std::string::npos);
  std::ofstream(dir / "a.ini") << "include = b.ini\n[Demo]\n";
  std::ofstream(dir / "b.ini") << "include = a.ini\n[Demo]\n";
  EXPECT_NE(errorOf("a.ini").find("the files include each other"), std::string::npos) << errorOf("a.ini");
  std::ofstream(dir / "twice.ini") << "include = base.ini\ninclude = base.ini\n[Demo]\n";
  EXPECT_NE(errorOf("twice.ini").find("twice.ini:2: include: key outside any section"), std::string::npos)
      << errorOf("twice.ini");
  std::filesystem::remove_all(dir);
}

TEST(Params, ClosestPrefersAKeyTheWordBegins) {
  EXPECT_EQ(params::closest("distortion", {"resolution", "fx", "distortion_model"}), "distortion_model");
  EXPECT_EQ(params::closest("noise", {"name", "noise_sigma", "noise_sigma_extra"}), "noise_sigma");
  EXPECT_EQ(params::closest("Noise", {"name", "noise_sigma"}), "noise_sigma");
}

TEST(Params, ClosestPrefersCaseOnlyDifferences) {
  EXPECT_EQ(params::closest("maxLocalKeyframes", {"maxLocalKeyFrames", "minLocalMapInliers", "localMapRatio"}),
            "maxLocalKeyFrames");
  EXPECT_EQ(params::closest("keyframeMinFrames", {"keyFrames.minFrames", "keyFrames.maxFrames", "minPoseInliers"}),
            "keyFrames.minFrames");
  EXPECT_EQ(params::closest("x", {}), "");
  EXPECT_EQ(params::valueText("  5  ; Table 3.1"), "5");
  EXPECT_EQ(params::valueText("a;b"), "a;b");
  EXPECT_EQ(params::valueText("models/x.onnx"), "models/x.onnx");
}

// ------------------------------------------------------------------------------------------ files, tools
namespace {

std::string syntaxError(const std::string& text) {
  try {
    params::checkIniSyntax(text, "f.ini");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

struct TempIni {
  std::filesystem::path path;
  explicit TempIni(const std::string& text, const std::string& name = "pslam_test_params_file.ini")
      : path(std::filesystem::temp_directory_path() / name) {
    std::ofstream(path) << text;
  }
  ~TempIni() { std::filesystem::remove(path); }
};

std::string fileError(const std::string& text, const std::vector<std::string>& overrides = {}) {
  TempIni f(text);
  demo::Config c;
  try {
    params::loadSectionsFromFile(c, f.path.string(), overrides);
  } catch (const Error& e) {
    const std::string what = e.what();
    const std::string prefix = f.path.string();
    return what.rfind(prefix, 0) == 0 ? "F" + what.substr(prefix.size()) : what;
  }
  return "";
}

}  // namespace

TEST(Params, IniSyntaxIsChecked) {
  EXPECT_EQ(syntaxError("; comment\n# comment\n// comment\n\n[Demo] ; c\ncount = 5 ; c\n  sigma=1\n[Other]\n"), "");
  EXPECT_EQ(syntaxError("[Demo]\ndist = [0.1 0.2]\nname = a # b\n"), "");  // brackets in a value are no header
  // An ini without section headers (MRPT would put the keys in a nameless section, which no one reads).
  EXPECT_EQ(syntaxError("# a file\nnFeatures = 2000\n"),
            "f.ini:2: nFeatures: key outside any section (the file needs a [Section] header before it)");
  EXPECT_EQ(syntaxError("[Demo]\ncount 5\n"), "f.ini:2: 'count 5': expected key = value in [Demo]");
  EXPECT_EQ(syntaxError("garbage\n"), "f.ini:1: 'garbage': expected key = value");
  EXPECT_EQ(syntaxError("[Demo]\n= 5\n"), "f.ini:2: '= 5': empty key in [Demo]");
  EXPECT_EQ(syntaxError("[Demo\ncount = 5\n"), "f.ini:1: '[Demo': malformed section header (expected [Section])");
  EXPECT_EQ(syntaxError("[]\n"), "f.ini:1: '[]': malformed section header (expected [Section])");
  EXPECT_EQ(syntaxError("[Demo]\ncount = 5\nsigma = 1\ncount = 6\n"),
            "f.ini:4: [Demo] count: key appears twice in the section (first as count on line 2)");
  EXPECT_EQ(syntaxError("[Demo]\ncount = 5\nCOUNT = 6\n"),
            "f.ini:3: [Demo] COUNT: key appears twice in the section (first as count on line 2)");
  EXPECT_EQ(syntaxError("[Demo]\ncount = 5\n[Other]\ncount = 6\n"), "");  // same key, other section
  EXPECT_EQ(syntaxError("[Demo]\n[Other]\n[demo]\n"),
            "f.ini:3: [demo]: section appears twice (first as [Demo] on line 1)");
  EXPECT_EQ(syntaxError("@define X 1\n"),
            "f.ini:1: '@define X 1': MRPT preprocessor lines (@define, @include) are not supported");
  EXPECT_EQ(syntaxError("[Demo]\nname = ${HOME}\n"),
            "f.ini:2: [Demo] name: variable expansion ($...{...}) is not supported");
  EXPECT_EQ(syntaxError(std::string("[Demo]\ncount = 1\0", 18)), "f.ini:2: NUL byte (not a text file?)");
  EXPECT_EQ(syntaxError("[Demo]\r\ncount = 5\r\n"), "");
}

TEST(Params, LoadConfigFileNamesTheFileSectionAndKey) {
  EXPECT_EQ(fileError("[Demo]\ncount = 8\n[Other]\nname = y\n"), "");
  EXPECT_EQ(fileError(""), "");
  EXPECT_EQ(fileError("[Demo]\ncount = 2000 extra\n"), "F: [Demo] count = 2000 extra: not an integer");
  EXPECT_EQ(fileError("[Demo]\nparallel = maybe\n"), "F: [Demo] parallel = maybe: not a bool (true or false)");
  EXPECT_EQ(fileError("[Demo]\ncount = 8\n[Othre]\nname = y\n"), "F: [Othre]: unknown section (did you mean Other?)");
  EXPECT_EQ(fileError("count = 8\n"),
            "F:1: count: key outside any section (the file needs a [Section] header before it)");
  EXPECT_EQ(fileError("[Demo]\ncount = 8\n", {"Demo.count=1"}),
            "override 'Demo.count=1': [Demo] count = 1: must be in [3, 100]");
  // One section of a file that may hold only that one.
  TempIni f("[Demo]\ncount = 9\n[Other]\nname = y\n");
  demo::Demo d;
  try {
    params::loadSectionFromFile(d, f.path.string(), "Demo");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), f.path.string() + ": [Other]: unknown section (did you mean Demo?)");
  }
  TempIni g("[Demo]\ncount = 9\n");
  params::loadSectionFromFile(d, g.path.string(), "Demo");
  EXPECT_EQ(d.count, 9);
}

TEST(Params, ListsPathsAndArraysParseStrictly) {
  std::vector<double> v;
  EXPECT_FALSE(params::Codec<std::vector<double>>::parse("1, 2.5,3", v));
  EXPECT_EQ(v, (std::vector<double>{1, 2.5, 3}));
  EXPECT_FALSE(params::Codec<std::vector<double>>::parse("[0.1 -0.2  3e-3]", v));
  EXPECT_EQ(v, (std::vector<double>{0.1, -0.2, 3e-3}));
  EXPECT_FALSE(params::Codec<std::vector<double>>::parse("", v));
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(*params::Codec<std::vector<double>>::parse("1, x", v),
            "'x': not a number (expected numbers separated by commas or spaces)");
  EXPECT_EQ(*params::Codec<std::vector<double>>::parse("[1 2", v),
            "unbalanced '[' (expected numbers separated by commas or spaces)");
  EXPECT_TRUE(params::Codec<std::vector<double>>::parse("1 nan", v));
  EXPECT_EQ(params::Codec<std::vector<double>>::format({0.1, -2}), "0.1 -2");
  using Array3 = std::array<double, 3>;
  Array3 a{};
  EXPECT_FALSE(params::Codec<Array3>::parse("1 2 3", a));
  EXPECT_EQ(a, (Array3{1, 2, 3}));
  EXPECT_EQ(*params::Codec<Array3>::parse("1 2", a), "expected 3 numbers, got 2");
  std::filesystem::path p;
  EXPECT_FALSE(params::Codec<std::filesystem::path>::parse("a b/c.ini", p));
  EXPECT_EQ(p, "a b/c.ini");
}

TEST(Params, ValuesOfKeysThatAreNoFixedList) {
  mrpt::config::CConfigFileMemory cfg("[Map]\nnumClasses = 2\nclass0 = road static\nclass3 = car dynamic\n");
  const std::vector<std::string> known{"numClasses", "class0", "class1"};
  try {
    params::sectionValues(cfg, "Map", known);
    FAIL();
  } catch (const params::ParamError& e) {
    EXPECT_STREQ(e.what(), "[Map] class3: unknown key (did you mean class0?)");
  }
  mrpt::config::CConfigFileMemory ok("[Map]\nnumClasses = 2 ; two\n");
  const auto values = params::sectionValues(ok, "Map", known);
  ASSERT_EQ(values.size(), 1u);
  EXPECT_EQ(values.at("numClasses"), "2");
  EXPECT_EQ(params::parseValue<int>("Map", "numClasses", "2", params::inClosed(1, 256)), 2);
  try {
    params::parseValue<int>("Map", "numClasses", "2000000000", params::inClosed(1, 256));
    FAIL();
  } catch (const params::ParamError& e) {
    EXPECT_STREQ(e.what(), "[Map] numClasses = 2000000000: must be in [1, 256]");
  }
}

TEST(Params, CommandLineNumbersUseTheSameParsingAndRules) {
  const auto nonNegative = params::cliCheck<double>(params::atLeast(0));
  EXPECT_EQ(nonNegative("0.02"), "");
  EXPECT_EQ(nonNegative("nan"), "nan: not a number");
  EXPECT_EQ(nonNegative("inf"), "inf: must be finite");
  EXPECT_EQ(nonNegative("-1"), "-1: must be >= 0");
  EXPECT_EQ(nonNegative("0.5s"), "0.5s: not a number");
  EXPECT_EQ(params::cliCheck<double>(params::finite())("-inf"), "-inf: must be finite");
  EXPECT_EQ(params::cliCheck<int>()("2000.7"), "2000.7: not an integer");
  EXPECT_EQ(params::cliCheck<int>()("2000000000000"), "2000000000000: integer out of range [-2147483648, 2147483647]");
  EXPECT_EQ(params::cliCheck<std::size_t>()("-1"), "-1: integer out of range [0, 18446744073709551615]");
  EXPECT_EQ(params::cliCheck<int>(params::inClosed(1, 64))("0"), "0: must be in [1, 64]");
  try {
    params::checkOption("--max-diff", std::nan(""), params::atLeast(0));
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--max-diff = nan: must be a number");
  }
}

TEST(Params, RangeBoundsReadAsWritten) {
  EXPECT_EQ(params::inClosed(1, 1000000).text(), "must be in [1, 1000000]");
  EXPECT_EQ(params::inLeftOpen(0, 0.5).text(), "must be in (0, 0.5]");
  EXPECT_EQ(params::finite().text(), "must be finite");
}

TEST(Params, CommandLineOptionOfAKeyUsesItsParsingAndRule) {
  const auto count = params::cliCheckKey<demo::Demo>("count");
  EXPECT_EQ(count("50"), "");
  EXPECT_EQ(count("2000.7"), "2000.7: not an integer");
  EXPECT_EQ(count("2000000000"), "2000000000: must be in [3, 100]");
  EXPECT_EQ(params::cliCheckKey<demo::Demo>("sigma")("nan"), "nan: not a number");
  EXPECT_EQ(params::cliCheckKey<demo::Demo>("keyFrames.ratio")("1.5"), "1.5: must be in (0, 1]");
  EXPECT_EQ(params::cliCheckKey<demo::Demo>("minThreshold")("11"), "11: must be in (0, count]");  // count = 10
  EXPECT_THROW(params::cliCheckKey<demo::Demo>("nope")("1"), std::logic_error);
}
