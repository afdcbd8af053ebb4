#include "pslam/tracking/MapInitializer.h"

#include "pslam/core/NamedRegistry.h"
#include "pslam/tracking/ManhattanInitializer.h"
#include "pslam/tracking/MonocularInitializer.h"

namespace pslam::tracking {

namespace {
NamedRegistry<MapInitializerFactory>& registry() {
  static NamedRegistry<MapInitializerFactory> r(
      {{"twoView", [](const geometry::PinholeCamera& camera, const InitializerParams& params,
                      const optimize::BundleAdjustmentParams& ba) {
          return std::make_unique<MonocularInitializer>(camera, params, ba);
        }},
       {"manhattan", [](const geometry::PinholeCamera& camera, const InitializerParams& params,
                        const optimize::BundleAdjustmentParams& ba) {
          return std::make_unique<ManhattanInitializer>(camera, params, ba);
        }}});
  return r;
}
}  // namespace

std::unique_ptr<MapInitializer> makeMapInitializer(const std::string& name, const geometry::PinholeCamera& camera,
                                                   const InitializerParams& params,
                                                   const optimize::BundleAdjustmentParams& ba) {
  return registry().get(name, "[System] initializer", "initializer")(camera, params, ba);
}

void registerMapInitializer(const std::string& name, MapInitializerFactory factory) {
  registry().add(name, std::move(factory));
}

std::vector<std::string> mapInitializerNames() { return registry().names(); }

void requireMapInitializer(const std::string& name) { registry().get(name, "[System] initializer", "initializer"); }

}  // namespace pslam::tracking
