#include "pslam/tracking/MapInitializer.h"

#include "pslam/core/NamedRegistry.h"
#include "pslam/tracking/ManhattanInitializer.h"
#include "pslam/tracking/MonocularInitializer.h"

namespace pslam::tracking {

namespace {
NamedRegistry<MapInitializerFactory>& initializerRegistry() {
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
  return initializerRegistry().get(name, "[System] initializer", "initializer")(camera, params, ba);
}

void registerMapInitializer(const std::string& name, MapInitializerFactory factory) {
  initializerRegistry().add(name, std::move(factory));
}

void requireMapInitializer(const std::string& name) {
  initializerRegistry().get(name, "[System] initializer", "initializer");
}

}  // namespace pslam::tracking
