#include "pslam/system/SlamParams.h"

#include <mrpt/config/CConfigFileMemory.h>

namespace pslam::system {

PSLAM_DEFINE_PARAMS(SystemParams)

void SlamParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg) {
  params::loadSections(*this, cfg);
  mapping.ba = bundleAdjustment;
  mapping.pointModel = pointModel;
}

void SlamParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg) const { params::saveSections(*this, cfg); }

void SlamParams::check() const { params::checkSections(*this); }

std::string SlamParams::toIniText() const {
  return params::iniText([this](mrpt::config::CConfigFileBase& cfg) { saveToConfigFile(cfg); });
}

SlamParams loadSlamParams(const std::string& iniPath, const std::vector<std::string>& overrides) {
  mrpt::config::CConfigFileMemory cfg(params::readConfigText(iniPath));
  params::applyOverrides(cfg, overrides);
  SlamParams p;
  params::withSource(iniPath, overrides, [&] { p.loadFromConfigFile(cfg); });
  return p;
}

}  // namespace pslam::system
