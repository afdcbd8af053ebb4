#pragma once
// Swappable map initializer used by the tracker until a map exists, chosen by name ([System] initializer)
// through a factory:
//   twoView  ORB-SLAM's monocular initialization (parallel H/F model selection, Algorithm 1; MonocularInitializer)
//   manhattan  the decoupled initializer of thesis §4.4.1 (rotation from the Manhattan frames, translation by
//              eq. 4.1; ManhattanInitializer), H/F for frames without a Manhattan frame
// Tests register their own with registerMapInitializer().
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "pslam/geometry/PinholeCamera.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/Params.h"
#include "pslam/tracking/Frame.h"

namespace pslam::tracking {

struct InitializerParams;

struct InitializationOutcome {
  bool initialized = false;
  std::string message;  ///< why not / what was built
  int matches = 0;
  map::KeyFrameId kf1 = map::kNoKeyFrame, kf2 = map::kNoKeyFrame;
  /// The relative rotation came from the two frames' Manhattan frames (ManhattanInitializer's decoupled path).
  bool manhattanRotation = false;
};

class MapInitializer {
 public:
  virtual ~MapInitializer() = default;
  virtual std::string name() const = 0;
  /// Feeds one frame. On success `map` (which must be empty) holds the initial map (keyframes kf1, kf2 of the
  /// outcome), `current` has its pose and its matches to the new points, and the reference frame is returned in
  /// `referenceOut` with its pose.
  virtual InitializationOutcome process(Frame& current, map::Map& map, std::mt19937& rng,
                                        Frame* referenceOut = nullptr) = 0;
  /// Forgets the reference frame (after a map reset).
  virtual void reset() = 0;
  virtual bool hasReference() const = 0;
};

using MapInitializerFactory = std::function<std::unique_ptr<MapInitializer>(
    const geometry::PinholeCamera& camera, const InitializerParams& params, const optimize::BundleAdjustmentParams& ba)>;
/// Makes the initializer registered under `name`. Throws pslam::Error("[System] initializer = <name>: unknown
/// initializer (known: ...)") for an unknown name.
std::unique_ptr<MapInitializer> makeMapInitializer(const std::string& name, const geometry::PinholeCamera& camera,
                                                   const InitializerParams& params,
                                                   const optimize::BundleAdjustmentParams& ba);
/// Adds (or replaces) an initializer under `name`; thread-safe.
void registerMapInitializer(const std::string& name, MapInitializerFactory factory);
/// Throws the error of the factory (naming the key and the known names) when `name` is not registered.
void requireMapInitializer(const std::string& name);

}  // namespace pslam::tracking
