#include "pslam/tracking/MapInitializer.h"

#include <map>
#include <mutex>

#include "pslam/core/Error.h"
#include "pslam/tracking/MonocularInitializer.h"

namespace pslam::tracking {

namespace {
struct Registry {
  std::mutex mutex;
  std::map<std::string, MapInitializerFactory> factories{
      {"twoView", [](const geometry::PinholeCamera& camera, const InitializerParams& params,
                     const optimize::BundleAdjustmentParams& ba) {
         return std::make_unique<MonocularInitializer>(camera, params, ba);
       }}};
};
Registry& registry() {
  static Registry r;
  return r;
}
}  // namespace

std::unique_ptr<MapInitializer> makeMapInitializer(const std::string& name, const geometry::PinholeCamera& camera,
                                                   const InitializerParams& params,
                                                   const optimize::BundleAdjustmentParams& ba) {
  MapInitializerFactory factory;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lk(r.mutex);
    auto it = r.factories.find(name);
    if (it != r.factories.end()) factory = it->second;
  }
  if (!factory) {
    std::string known;
    for (const std::string& n : mapInitializerNames()) known += (known.empty() ? "" : ", ") + n;
    throw Error("[System] initializer = " + name + ": unknown initializer (known: " + known + ")");
  }
  return factory(camera, params, ba);
}

void registerMapInitializer(const std::string& name, MapInitializerFactory factory) {
  require(!name.empty() && factory != nullptr, "registerMapInitializer", "needs a name and a factory");
  Registry& r = registry();
  std::lock_guard<std::mutex> lk(r.mutex);
  r.factories[name] = std::move(factory);
}

std::vector<std::string> mapInitializerNames() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lk(r.mutex);
  std::vector<std::string> names;
  for (const auto& [n, f] : r.factories) names.push_back(n);
  return names;
}

}  // namespace pslam::tracking
