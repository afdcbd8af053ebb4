#include "pslam/system/SlamParams.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <mrpt/config/CConfigFile.h>
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"

namespace pslam::system {

void SlamParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg) {
  orb.loadFromConfigFile(cfg, "ORB");
  initializer.loadFromConfigFile(cfg, "Initializer");
  tracking.loadFromConfigFile(cfg, "Tracking");
  poseOptimization.loadFromConfigFile(cfg, "PoseOptimization");
  bundleAdjustment.loadFromConfigFile(cfg, "BundleAdjustment");
  mapping.loadFromConfigFile(cfg, "LocalMapping");
  mapping.ba = bundleAdjustment;
  threaded = cfg.read_bool("System", "threaded", threaded);
  localMapper = cfg.read_string("System", "localMapper", localMapper);
  poseSolver = cfg.read_string("System", "poseSolver", poseSolver);
  mapInitializer = cfg.read_string("System", "mapInitializer", mapInitializer);
  // Keep the text so that components configured outside this struct (libs/mapping) read the same keys.
  if (auto* mem = dynamic_cast<const mrpt::config::CConfigFileMemory*>(&cfg)) mem->getContent(sourceIni);
}

void SlamParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg) const {
  orb.saveToConfigFile(cfg, "ORB");
  initializer.saveToConfigFile(cfg, "Initializer");
  tracking.saveToConfigFile(cfg, "Tracking");
  poseOptimization.saveToConfigFile(cfg, "PoseOptimization");
  bundleAdjustment.saveToConfigFile(cfg, "BundleAdjustment");
  mapping.saveToConfigFile(cfg, "LocalMapping");
  cfg.write("System", "threaded", threaded);
  cfg.write("System", "localMapper", localMapper);
  cfg.write("System", "poseSolver", poseSolver);
  cfg.write("System", "mapInitializer", mapInitializer);
}

void SlamParams::check() const {
  // Each component names its own key; the section is added here where the component does not know it.
  auto withSection = [](const std::string& section, auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      throw Error("[" + section + "] " + e.what());
    }
  };
  withSection("ORB", [&] { orb.check(); });
  initializer.check();
  tracking.check();
  withSection("PoseOptimization", [&] { poseOptimization.check(); });
  withSection("BundleAdjustment", [&] { bundleAdjustment.check(); });
  mapping.check();
  require(localMapper != "builtin", "[System] localMapper",
          "'builtin' was merged into libs/mapping; use mapping (with [LocalMapping] fusionDistanceBand = 0 for its "
          "fusion gate)");
  require(localMapper == "auto" || localMapper == "mapping", "[System] localMapper",
          "must be auto or mapping (got '" + localMapper + "')");
}

std::string SlamParams::toIniText() const {
  mrpt::config::CConfigFileMemory mem;
  saveToConfigFile(mem);
  std::string text;
  mem.getContent(text);
  return text;
}

SlamParams loadSlamParams(const std::string& iniPath, const std::vector<std::string>& overrides) {
  require(std::filesystem::is_regular_file(iniPath), iniPath, "config file not found");
  std::ifstream in(iniPath);
  std::stringstream text;
  text << in.rdbuf();
  require(static_cast<bool>(in) || in.eof(), iniPath, "cannot read config file");
  mrpt::config::CConfigFileMemory cfg(text.str());
  for (const std::string& o : overrides) {
    const auto dot = o.find('.'), eq = o.find('=');
    require(dot != std::string::npos && eq != std::string::npos && dot > 0 && eq > dot + 1, "--set " + o,
            "expected Section.key=value");
    cfg.write(o.substr(0, dot), o.substr(dot + 1, eq - dot - 1), o.substr(eq + 1));
  }
  SlamParams p;
  try {
    p.loadFromConfigFile(cfg);
    p.check();
  } catch (const std::exception& e) {
    throw Error(iniPath + ": " + e.what());
  }
  return p;
}

}  // namespace pslam::system
