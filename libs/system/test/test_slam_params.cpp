// SlamParams: ini round trip, defaults of the shipped configs, and check() naming section and key.
#include <filesystem>

#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/system/SlamParams.h"

using namespace pslam;

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
}  // namespace

TEST(SlamParams, RoundTripThroughIni) {
  system::SlamParams p;
  p.orb.nFeatures = 1234;
  p.tracking.keyFrames.maxFrames = 17;
  p.initializer.minMatches = 77;
  p.mapping.covisibleKeyFrames = 7;
  p.threaded = true;
  p.localMapper = "mapping";
  p.mapping.fusionDistanceBand = 0.0;
  mrpt::config::CConfigFileMemory mem(p.toIniText());
  system::SlamParams q;
  q.loadFromConfigFile(mem);
  EXPECT_EQ(q.orb.nFeatures, 1234);
  EXPECT_EQ(q.tracking.keyFrames.maxFrames, 17);
  EXPECT_EQ(q.initializer.minMatches, 77);
  EXPECT_EQ(q.mapping.covisibleKeyFrames, 7);
  EXPECT_TRUE(q.threaded);
  EXPECT_EQ(q.localMapper, "mapping");
  EXPECT_EQ(q.mapping.fusionDistanceBand, 0.0);
  EXPECT_EQ(q.toIniText(), p.toIniText());
}

TEST(SlamParams, InvalidValuesNameTheKey) {
  EXPECT_NE(errorFor("[Tracking]\nminLocalMapInliers = 1\n").find("minLocalMapInliers"), std::string::npos);
  EXPECT_NE(errorFor("[Tracking]\nkeyframeRefRatio = 1.5\n").find("keyframeRefRatio"), std::string::npos);
  EXPECT_NE(errorFor("[Initializer]\nminMatches = 3\n").find("minMatches"), std::string::npos);
  EXPECT_NE(errorFor("[LocalMapping]\nmaxParallaxCos = 1\n").find("maxParallaxCos"), std::string::npos);
  EXPECT_NE(errorFor("[System]\nlocalMapper = magic\n").find("localMapper"), std::string::npos);
  // The former builtin mapper: the error says where it went.
  EXPECT_NE(errorFor("[System]\nlocalMapper = builtin\n").find("fusionDistanceBand = 0"), std::string::npos);
  EXPECT_NE(errorFor("[LocalMapping]\nfusionDistanceBand = 1.5\n").find("fusionDistanceBand"), std::string::npos);
  EXPECT_NE(errorFor("[ORB]\nnLevels = 0\n").find("nLevels"), std::string::npos);
  EXPECT_EQ(errorFor(""), "");
}

TEST(SlamParams, ShippedConfigsLoadWithOrbSlamValues) {
  const std::filesystem::path dir = std::filesystem::path(PRIORSLAM_SOURCE_DIR) / "config/slam";
  for (const char* name : {"kitti", "tum_rgbd", "euroc", "icl_nuim", "synthetic"}) {
    SCOPED_TRACE(name);
    const system::SlamParams p = system::loadSlamParams((dir / (std::string(name) + ".ini")).string());
    EXPECT_DOUBLE_EQ(p.poseOptimization.huberDelta, 2.448);  // Table 3.2
    EXPECT_DOUBLE_EQ(p.poseOptimization.chi2Threshold, 5.991);
    EXPECT_EQ(p.bundleAdjustment.maxLocalKeyFrames, 20);
    EXPECT_FALSE(p.threaded);
  }
  EXPECT_EQ(system::loadSlamParams((dir / "kitti.ini").string()).orb.nFeatures, 2000);
  EXPECT_EQ(system::loadSlamParams((dir / "tum_rgbd.ini").string()).orb.nFeatures, 1000);
  EXPECT_THROW(system::loadSlamParams((dir / "missing.ini").string()), Error);
}
