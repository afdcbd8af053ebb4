// Chooses the local mapper. The libs/mapping adapter is compiled only when that library is part of the build
// (PSLAM_HAVE_MAPPING), so the system builds and runs with the built-in mapper alone.
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/system/KeyFrameMapper.h"

#ifdef PSLAM_HAVE_MAPPING
#include "pslam/mapping/LocalMapper.h"
#endif

namespace pslam::system {

#ifdef PSLAM_HAVE_MAPPING
namespace {
class MappingLibraryMapper : public KeyFrameMapper {
 public:
  MappingLibraryMapper(map::Map& map, const mapping::LocalMappingParams& params) : mapper_(map, params) {}
  std::string name() const override { return "mapping"; }
  MappingStepReport processKeyFrame(map::KeyFrameId kf, const std::vector<map::MapPointId>& recent) override {
    const mapping::LocalMappingReport r = mapper_.processKeyFrame(kf, recent);
    MappingStepReport out;
    out.newPoints = r.newPoints;
    out.culledPoints = r.culledPoints;
    out.culledKeyFrames = r.culledKeyFrames;
    out.baObservationsErased = r.baObservationsErased;
    out.fused = r.fusedPoints;
    out.fusionMs = r.fusionMs;
    out.triangulationMs = r.triangulationMs;
    out.localBaMs = r.localBaMs;
    return out;
  }
  void reset() override { mapper_.reset(); }
  std::string configText() const override {
    mrpt::config::CConfigFileMemory mem;
    mapper_.params().saveToConfigFile(mem, "LocalMapping");
    std::string text;
    mem.getContent(text);
    return text;
  }

 private:
  mapping::LocalMapper mapper_;
};
}  // namespace
bool haveMappingLibrary() { return true; }
#else
bool haveMappingLibrary() { return false; }
#endif

std::unique_ptr<KeyFrameMapper> makeKeyFrameMapper(const std::string& which, map::Map& map, const std::string& iniText,
                                                   const BuiltinMappingParams& builtinParams) {
  const std::string choice = which == "auto" ? (haveMappingLibrary() ? "mapping" : "builtin") : which;
  if (choice == "builtin") return std::make_unique<BuiltinLocalMapper>(map, builtinParams);
  if (choice == "mapping") {
#ifdef PSLAM_HAVE_MAPPING
    mrpt::config::CConfigFileMemory cfg(iniText);
    mapping::LocalMappingParams p;
    p.loadFromConfigFile(cfg, "LocalMapping");
    p.ba = builtinParams.ba;
    return std::make_unique<MappingLibraryMapper>(map, p);
#else
    (void)iniText;
    throw Error("[System] localMapper: 'mapping' requested but libs/mapping is not part of this build");
#endif
  }
  throw Error("[System] localMapper: unknown value '" + which + "' (auto | builtin | mapping)");
}

}  // namespace pslam::system
