#include "pslam/system/SlamParams.h"

#include <filesystem>

#include <mrpt/config/CConfigFileMemory.h>

namespace pslam::system {

PSLAM_DEFINE_PARAMS(SystemParams)

void SlamParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg) { params::loadSections(*this, cfg); }

mapping::LocalMappingParams SlamParams::localMapping() const {
  mapping::LocalMappingParams m = mapping;
  m.ba = bundleAdjustment;
  m.pointModel = pointModel;
  if (directFeatures.enabled && m.minTriangulationNeighbours == 0) m.minTriangulationNeighbours = 2;
  return m;
}

void SlamParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg) const { params::saveSections(*this, cfg); }

void SlamParams::check() const { params::checkSections(*this); }

std::string SlamParams::toIniText() const {
  return params::iniText([this](mrpt::config::CConfigFileBase& cfg) { saveToConfigFile(cfg); });
}

SlamParams loadSlamParams(const std::string& iniPath, const std::vector<std::string>& overrides) {
  SlamParams p;
  params::loadConfigFile(iniPath, params::sectionsOf(p),
                         [&](const mrpt::config::CConfigFileBase& cfg) { p.loadFromConfigFile(cfg); }, overrides);
  // Files named by the config are relative to its folder (as the model paths of the priors' configs).
  if (!p.places.vocabulary.empty() && std::filesystem::path(p.places.vocabulary).is_relative())
    p.places.vocabulary =
        (std::filesystem::path(iniPath).parent_path() / p.places.vocabulary).lexically_normal().string();
  return p;
}

}  // namespace pslam::system
