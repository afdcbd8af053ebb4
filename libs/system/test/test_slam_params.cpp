// SlamParams: ini round trip, the shipped configs, one error format, unknown keys and sections, overrides.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>

#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/system/SlamParams.h"

using namespace pslam;
namespace fs = std::filesystem;

namespace {

std::string errorFor(const std::string& ini) {
  mrpt::config::CConfigFileMemory cfg(ini);
  try {
    system::SlamParams p;
    p.loadFromConfigFile(cfg);
    p.check();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string loadError(const std::string& path, const std::vector<std::string>& overrides) {
  try {
    system::loadSlamParams(path, overrides);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

const fs::path kSlamConfigs = fs::path(PRIORSLAM_SOURCE_DIR) / "config/slam";

std::vector<fs::path> shippedSlamConfigs() {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(kSlamConfigs))
    if (e.path().extension() == ".ini") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

TEST(SlamParams, RoundTripThroughIni) {
  system::SlamParams p;
  p.orb.nFeatures = 1234;
  p.tracking.keyFrames.maxFrames = 17;
  p.tracking.pnp.minInliers = 21;
  p.initializer.minMatches = 77;
  p.initializer.twoView.sigma = 1.0 / 3.0;
  p.mapping.covisibleKeyFrames = 7;
  p.mapping.fusionDistanceBand = 0.0;
  p.pointModel.policy.model = landmarks::MapPointModel::Probabilistic;
  p.pointModel.keypoint.probabilityFloor = 1.0 / 510.0;
  p.system.threaded = true;
  p.system.threadedTracking = "afterNewPoints";
  p.system.poseSolver = "manhattan3dof";
  mrpt::config::CConfigFileMemory mem(p.toIniText());
  system::SlamParams q;
  q.loadFromConfigFile(mem);
  EXPECT_EQ(q.orb.nFeatures, 1234);
  EXPECT_EQ(q.tracking.keyFrames.maxFrames, 17);
  EXPECT_EQ(q.tracking.pnp.minInliers, 21);
  EXPECT_EQ(q.initializer.minMatches, 77);
  EXPECT_EQ(q.initializer.twoView.sigma, 1.0 / 3.0);
  EXPECT_EQ(q.mapping.covisibleKeyFrames, 7);
  EXPECT_EQ(q.mapping.fusionDistanceBand, 0.0);
  EXPECT_EQ(q.pointModel.policy.model, landmarks::MapPointModel::Probabilistic);
  EXPECT_EQ(q.pointModel.keypoint.probabilityFloor, 1.0 / 510.0);
  // The mapper's copies follow the sections they come from.
  EXPECT_EQ(q.localMapping().pointModel.policy.model, landmarks::MapPointModel::Probabilistic);
  EXPECT_EQ(q.localMapping().ba.maxLocalKeyFrames, q.bundleAdjustment.maxLocalKeyFrames);
  EXPECT_TRUE(q.system.threaded);
  EXPECT_EQ(q.system.threadedTracking, "afterNewPoints");
  EXPECT_EQ(q.system.poseSolver, "manhattan3dof");
  EXPECT_EQ(q.system.initializer, "twoView");
  EXPECT_EQ(q.toIniText(), p.toIniText());
}

TEST(SlamParams, DefaultsOfTheNewKeys) {
  const system::SlamParams p;
  EXPECT_EQ(p.system.poseSolver, "full6dof");
  EXPECT_EQ(p.system.initializer, "twoView");
  EXPECT_FALSE(p.system.threaded);
  EXPECT_EQ(p.system.threadedTracking, "live");
  EXPECT_EQ(p.pointModel.policy.model, landmarks::MapPointModel::Heuristic);
  EXPECT_EQ(p.localMapping().pointModel.policy.model, landmarks::MapPointModel::Heuristic);
  const std::string text = p.toIniText();
  for (const char* section : {"[ORB]", "[Initializer]", "[Tracking]", "[PoseOptimization]", "[BundleAdjustment]",
                              "[LocalMapping]", "[PointModel]", "[System]"})
    EXPECT_NE(text.find(section), std::string::npos) << section;
  EXPECT_EQ(text.find("localMapper"), std::string::npos);
}

TEST(SlamParams, InvalidValuesUseTheOneErrorFormat) {
  EXPECT_EQ(errorFor("[Tracking]\nminPoseInliers = 1\n"), "[Tracking] minPoseInliers = 1: must be >= 3");
  EXPECT_EQ(errorFor("[Tracking]\nminLocalMapInliers = 1\n"), "[Tracking] minLocalMapInliers = 1: must be >= 3");
  EXPECT_EQ(errorFor("[Tracking]\nkeyFrames.refRatio = 1.5\n"), "[Tracking] keyFrames.refRatio = 1.5: must be in (0, 1]");
  EXPECT_EQ(errorFor("[Tracking]\nminInliersAfterReloc = 20\n"),
            "[Tracking] minInliersAfterReloc = 20: must be >= minLocalMapInliers");
  EXPECT_EQ(errorFor("[Initializer]\nminMatches = 3\n"), "[Initializer] minMatches = 3: must be >= 8");
  EXPECT_EQ(errorFor("[Initializer]\nminParallaxDeg = 90\n"), "[Initializer] minParallaxDeg = 90: must be in [0, 90)");
  EXPECT_EQ(errorFor("[LocalMapping]\nmaxParallaxCos = 1\n"), "[LocalMapping] maxParallaxCos = 1: must be in (0, 1)");
  EXPECT_EQ(errorFor("[LocalMapping]\nfusionDistanceBand = 1.5\n"),
            "[LocalMapping] fusionDistanceBand = 1.5: must be in [0, 1)");
  EXPECT_EQ(errorFor("[ORB]\nnLevels = 0\n"), "[ORB] nLevels = 0: must be in [1, 32]");
  EXPECT_EQ(errorFor("[ORB]\nminThFAST = 30\n"), "[ORB] minThFAST = 30: must be in (0, iniThFAST]");
  EXPECT_EQ(errorFor("[BundleAdjustment]\nlinearSolver = qr\n"),
            "[BundleAdjustment] linearSolver = qr: must be one of sparse_schur, dense_schur");
  EXPECT_EQ(errorFor("[PoseOptimization]\nhuberDelta = -1\n"), "[PoseOptimization] huberDelta = -1: must be > 0");
  EXPECT_EQ(errorFor("[PointModel]\nmodel = orb\n"),
            "[PointModel] model = orb: must be one of heuristic, masking, probabilistic");
  EXPECT_EQ(errorFor("[System]\nposeSolver =\n"), "[System] poseSolver = : must not be empty");
  EXPECT_EQ(errorFor("[System]\nthreaded = maybe\n"), "[System] threaded = maybe: not a bool (true or false)");
  EXPECT_EQ(errorFor("[System]\nthreadedTracking = paced\n"),
            "[System] threadedTracking = paced: must be one of live, afterNewPoints");
  EXPECT_EQ(errorFor("[ORB]\nnFeatures = 2000 extra\n"), "[ORB] nFeatures = 2000 extra: not an integer");
  EXPECT_EQ(errorFor("[ORB]\nnFeatures = 2000.7\n"), "[ORB] nFeatures = 2000.7: not an integer");
  EXPECT_EQ(errorFor("[ORB]\nscaleFactor = abc\n"), "[ORB] scaleFactor = abc: not a number");
  EXPECT_EQ(errorFor(""), "");
  // check() on parameters built in code names the same section and key.
  system::SlamParams p;
  p.tracking.pnp.minInliers = 3;
  try {
    p.check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "[Tracking] pnp.minInliers = 3: must be >= 4");
  }
}

// The keys used before the one parameter mechanism are rejected, naming the key that replaced them.
TEST(SlamParams, FormerKeysAreUnknownAndNameTheirReplacement) {
  const std::vector<std::pair<std::string, std::string>> renamed{
      {"[Tracking]\nmaxLocalKeyframes = 80\n", "[Tracking] maxLocalKeyframes: unknown key (did you mean maxLocalKeyFrames?)"},
      {"[Tracking]\nresetKeyframes = 5\n", "[Tracking] resetKeyframes: unknown key (did you mean resetKeyFrames?)"},
      {"[Tracking]\nkeyframeMinFrames = 0\n", "[Tracking] keyframeMinFrames: unknown key (did you mean keyFrames.minFrames?)"},
      {"[Tracking]\nkeyframeMaxFrames = 9\n", "[Tracking] keyframeMaxFrames: unknown key (did you mean keyFrames.maxFrames?)"},
      {"[Tracking]\nkeyframeRefRatio = 0.9\n", "[Tracking] keyframeRefRatio: unknown key (did you mean keyFrames.refRatio?)"},
      {"[Tracking]\nkeyframeMinInliers = 15\n",
       "[Tracking] keyframeMinInliers: unknown key (did you mean keyFrames.minInliers?)"},
      {"[Tracking]\nransacIterations = 300\n", "[Tracking] ransacIterations: unknown key (did you mean pnp.ransacIterations?); [Initializer] has a key of this name"},
      {"[LocalMapping]\ncovisibleKeyframes = 20\n",
       "[LocalMapping] covisibleKeyframes: unknown key (did you mean covisibleKeyFrames?)"},
      {"[LocalMapping]\nepipolarMinDistance = 10\n",
       "[LocalMapping] epipolarMinDistance: unknown key (did you mean epipolarMinDistancePixels?)"},
      {"[LocalMapping]\nfusionRadius = 3\n", "[LocalMapping] fusionRadius: unknown key (did you mean fusionRadiusPixels?)"},
      // A key that moved to another section says where it belongs.
      {"[LocalMapping]\nmodel = heuristic\n", "[LocalMapping] model: unknown key (did you mean nnRatio?); [PointModel] has a key of this name"},
      {"[System]\nlocalMapper = mapping\n", "[System] localMapper: unknown key (did you mean poseSolver?)"},
  };
  for (const auto& [ini, error] : renamed) EXPECT_EQ(errorFor(ini), error) << ini;
}

TEST(SlamParams, UnknownSectionNamesTheClosest) {
  EXPECT_EQ(errorFor("[Trackng]\nminPoseInliers = 10\n"), "[Trackng]: unknown section (did you mean Tracking?)");
  EXPECT_EQ(errorFor("[PointModle]\nmodel = masking\n"), "[PointModle]: unknown section (did you mean PointModel?)");
  EXPECT_EQ(errorFor("[tracking]\nminPoseInliers = 10\n"), "[tracking]: unknown section (did you mean Tracking?)");
}

TEST(SlamParams, EveryShippedConfigLoads) {
  const auto files = shippedSlamConfigs();
  ASSERT_GE(files.size(), 5u);
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    const system::SlamParams p = system::loadSlamParams(f.string());
    EXPECT_DOUBLE_EQ(p.poseOptimization.huberDelta, 2.448);  // Table 3.2
    EXPECT_DOUBLE_EQ(p.poseOptimization.chi2Threshold, 5.991);
    EXPECT_EQ(p.bundleAdjustment.maxLocalKeyFrames, 20);
    EXPECT_EQ(p.pointModel.policy.model, landmarks::MapPointModel::Heuristic);
    EXPECT_EQ(p.mapping.fusionDistanceBand, 0.0);
    EXPECT_EQ(p.system.poseSolver, "full6dof");
    // The chapter-4 configurations (structure.ini and structure_network.ini, which includes it) initialize from
    // the Manhattan frames (§4.4.1); every other one with H/F.
    const bool structure = f.filename().string().rfind("structure", 0) == 0;
    EXPECT_EQ(p.system.initializer, structure ? "manhattan" : "twoView");
    EXPECT_EQ(p.manhattan.enabled, structure);
    EXPECT_FALSE(p.system.threaded);
    // The effective configuration reloads to the same parameters.
    mrpt::config::CConfigFileMemory mem(p.toIniText());
    system::SlamParams q;
    q.loadFromConfigFile(mem);
    EXPECT_EQ(q.toIniText(), p.toIniText());
  }
  const auto kitti = system::loadSlamParams((kSlamConfigs / "kitti.ini").string());
  EXPECT_EQ(kitti.orb.nFeatures, 2000);
  EXPECT_EQ(kitti.tracking.keyFrames.maxFrames, 10);
  EXPECT_EQ(kitti.initializer.maxReferenceAge, 10);
  EXPECT_EQ(system::loadSlamParams((kSlamConfigs / "tum_rgbd.ini").string()).orb.nFeatures, 1000);
  EXPECT_EQ(loadError((kSlamConfigs / "missing.ini").string(), {}),
            (kSlamConfigs / "missing.ini").string() + ": config file not found");
}

TEST(SlamParams, ErrorsFromAFileNameTheFile) {
  const fs::path path = fs::temp_directory_path() / "pslam_test_slam_params_bad.ini";
  std::ofstream(path) << "[Tracking]\nmaxLocalKeyframes = 80\n";
  EXPECT_EQ(loadError(path.string(), {}),
            path.string() + ": [Tracking] maxLocalKeyframes: unknown key (did you mean maxLocalKeyFrames?)");
  std::ofstream(path) << "[Tracking]\nminPoseInliers = 1\n";
  EXPECT_EQ(loadError(path.string(), {}), path.string() + ": [Tracking] minPoseInliers = 1: must be >= 3");
  // Out of range: 2e9 fits an int, but featureFactor x nFeatures (the initializer's budget) did not.
  std::ofstream(path) << "[ORB]\nnFeatures = 2000000000\n";
  EXPECT_EQ(loadError(path.string(), {}), path.string() + ": [ORB] nFeatures = 2000000000: must be in [1, 1000000]");
  // A file without section headers.
  std::ofstream(path) << "# no header\nnFeatures = 2000\n";
  EXPECT_EQ(loadError(path.string(), {}),
            path.string() + ":2: nFeatures: key outside any section (the file needs a [Section] header before it)");
  std::ofstream(path) << "[ORB]\nnFeatures = 1000\n[Tracking]\nminPoseInliers = 10\n[ORB]\nnLevels = 4\n";
  EXPECT_EQ(loadError(path.string(), {}), path.string() + ":5: [ORB]: section appears twice (first as [ORB] on line 1)");
  fs::remove(path);
}

TEST(SlamParams, OverridesApplyBeforeLoading) {
  const std::string kitti = (kSlamConfigs / "kitti.ini").string();
  const auto p = system::loadSlamParams(kitti, {"PointModel.model=probabilistic", "Tracking.keyFrames.maxFrames=12",
                                                "ORB.nFeatures=1500", "ORB.nFeatures=1600", "System.threaded=true",
                                                "PointModel.psiMin=0.7"});
  EXPECT_EQ(p.pointModel.policy.model, landmarks::MapPointModel::Probabilistic);
  EXPECT_EQ(p.localMapping().pointModel.policy.model, landmarks::MapPointModel::Probabilistic);
  EXPECT_EQ(p.localMapping().pointModel.keypoint.psiMin, 0.7);
  EXPECT_EQ(p.tracking.keyFrames.maxFrames, 12);
  EXPECT_EQ(p.orb.nFeatures, 1600);  // the later override wins
  EXPECT_TRUE(p.system.threaded);
  // Untouched keys keep the file's values.
  EXPECT_EQ(p.initializer.maxReferenceAge, 10);
  EXPECT_EQ(p.mapping.fusionDistanceBand, 0.0);
}

TEST(SlamParams, MalformedOrUnknownOverridesAreRejected) {
  const std::string kitti = (kSlamConfigs / "kitti.ini").string();
  EXPECT_EQ(loadError(kitti, {"Tracking.minPoseInliers"}),
            "override 'Tracking.minPoseInliers': expected Section.key=value (no '=')");
  EXPECT_EQ(loadError(kitti, {"minPoseInliers=5"}),
            "override 'minPoseInliers=5': expected Section.key=value (no '.' between section and key)");
  EXPECT_EQ(loadError(kitti, {"Tracking.=5"}), "override 'Tracking.=5': empty key");
  EXPECT_EQ(loadError(kitti, {".x=5"}), "override '.x=5': empty section");
  EXPECT_EQ(loadError(kitti, {"Tracking.maxLocalKeyframes=60"}),
            "override 'Tracking.maxLocalKeyframes=60': [Tracking] maxLocalKeyframes: unknown key (did you mean "
            "maxLocalKeyFrames?)");
  EXPECT_EQ(loadError(kitti, {"Trackng.minPoseInliers=5"}),
            "override 'Trackng.minPoseInliers=5': [Trackng]: unknown section (did you mean Tracking?)");
  EXPECT_EQ(loadError(kitti, {"Tracking.minPoseInliers=1"}),
            "override 'Tracking.minPoseInliers=1': [Tracking] minPoseInliers = 1: must be >= 3");
  EXPECT_EQ(loadError(kitti, {"PointModel.model=orb"}),
            "override 'PointModel.model=orb': [PointModel] model = orb: must be one of heuristic, masking, "
            "probabilistic");
  EXPECT_EQ(loadError(kitti, {"ORB.NFEATURES=10"}),
            "override 'ORB.NFEATURES=10': key differs only in case from nFeatures in [ORB]");
}

namespace {
std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Every key of every section, from the field lists.
struct KeyLister {
  std::vector<std::pair<std::string, std::string>> keys;
  template <class P>
  void section(const char* name, P& p) {
    for (const auto& row : params::describe(p)) keys.emplace_back(name, row.key);
  }
};
}  // namespace

// The key tables of the docs (doc/slam.md, doc/mapping.md) and the [PointModel] reference config name every key.
TEST(SlamParams, EveryKeyIsDocumented) {
  const fs::path root(PRIORSLAM_SOURCE_DIR);
  const std::string docs = readText(root / "doc/slam.md") + readText(root / "doc/mapping.md") +
                           readText(root / "config/semantic/keypoint_model.ini");
  system::SlamParams p;
  KeyLister lister;
  p.visitSections(lister);
  ASSERT_GT(lister.keys.size(), 100u);
  for (const auto& [section, key] : lister.keys) {
    const std::regex word("(^|[^A-Za-z0-9_.])" + std::regex_replace(key, std::regex("\\."), "\\.") + "($|[^A-Za-z0-9_])");
    EXPECT_TRUE(std::regex_search(docs, word)) << "[" << section << "] " << key << " is in no key table";
  }
}
