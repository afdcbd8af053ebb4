// The local mapper behind the KeyFrameMapper interface: libs/mapping's LocalMapper.
#include <mrpt/config/CConfigFileMemory.h>

#include "pslam/core/Error.h"
#include "pslam/system/KeyFrameMapper.h"

#include "pslam/mapping/LocalMapper.h"

namespace pslam::system {

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

std::unique_ptr<KeyFrameMapper> makeKeyFrameMapper(const std::string& which, map::Map& map,
                                                   const mapping::LocalMappingParams& params) {
  if (which == "builtin")
    throw Error("makeKeyFrameMapper: 'builtin' was merged into libs/mapping; use mapping with "
                "[LocalMapping] fusionDistanceBand = 0 for its fusion gate");
  if (which != "auto" && which != "mapping")
    throw Error("makeKeyFrameMapper: unknown mapper '" + which + "' (auto | mapping)");
  return std::make_unique<MappingLibraryMapper>(map, params);
}

}  // namespace pslam::system
