// Every shipped config/manhattan/*.ini loads through the loaders that read it: manhattan-eval's tracker
// section and priors::makeNormalSource's normal sections (here, beside the app that reads them: the manhattan
// library itself does not depend on the normal sources).
#include <gtest/gtest.h>

#include <filesystem>

#include <mrpt/config/CConfigFile.h>

#include "pslam/manhattan/ManhattanEvalApp.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/priors/NormalSource.h"
#include "pslam/priors/NormalsFromNetwork.h"

using namespace pslam::manhattan;

TEST(ManhattanParams, ShippedConfigsLoad) {
  namespace fs = std::filesystem;
  int files = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(PRIORSLAM_SOURCE_DIR) / "config/manhattan")) {
    if (entry.path().extension() != ".ini") continue;
    SCOPED_TRACE(entry.path().string());
    ++files;
    mrpt::config::CConfigFile cfg(entry.path().string());
    std::vector<std::string> sections;
    cfg.getAllSections(sections);
    for (const auto& s : sections) {
      if (s == kTrackerSection) {
        ManhattanParams p;
        EXPECT_NO_THROW(p.loadFromConfigFile(cfg, s));
      } else if (s == pslam::priors::kDepthNormalsSection) {
        EXPECT_NO_THROW(pslam::priors::makeNormalSource("depth", entry.path()));
      } else if (s == pslam::priors::kNetworkNormalsSection) {
        // Its model file is not shipped: load the section only.
        pslam::priors::NetworkNormalParams p;
        EXPECT_NO_THROW(p.loadFromConfigFile(cfg, s, entry.path().parent_path().string()));
      } else {
        ADD_FAILURE() << "section [" << s << "] has no reader";
      }
    }
  }
  EXPECT_GE(files, 2);
}
