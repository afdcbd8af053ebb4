#pragma once
// The composition root of a SLAM run (doc/architecture.md, "The System"): every part built from the parameters
// for one camera, and wired together. The one place that knows the concrete landmark modules and the order in
// which their factors enter pose optimization and local BA (a sequential run's bytes depend on it).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "pslam/features/OrbExtractor.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/map/Map.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/places/Vocabulary.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam/tracking/LandmarkModule.h"
#include "pslam/tracking/Tracker.h"

namespace pslam::system {

struct SlamParts {
  /// Builds the map, the feature extractors, the local mapper, the tracker with its point-use policy, solver,
  /// initializer and Manhattan path, the landmark modules ([DirectFeatures], [Lines]) and, with a vocabulary, place
  /// recognition in tracking and loop closing ([LoopClosing]). `params` must be checked.
  /// `extraModules` are registered after the shipped ones (SystemOptions::modules).
  SlamParts(const SlamParams& params, const geometry::PinholeCamera& camera, std::uint32_t seed,
            std::shared_ptr<const places::Vocabulary> vocabulary,
            const std::vector<SystemOptions::ModuleFactory>& extraModules = {});

  const SlamParams& params;
  geometry::PinholeCamera camera;
  map::Map map;
  features::OrbExtractor extractor;
  features::OrbExtractor initExtractor;  ///< featureFactor x nFeatures, used until the map is initialized
  std::unique_ptr<mapping::LocalMapper> mapper;
  std::unique_ptr<tracking::Tracker> tracker;
  /// The landmark modules in their order of registration (the direct points, then the lines).
  std::vector<std::shared_ptr<tracking::LandmarkModule>> modules;
  std::unique_ptr<manhattan::ManhattanTracker> manhattanTracker;  ///< null unless [Manhattan] enabled
  std::unique_ptr<loopclosing::LoopCloser> loopCloser;            ///< null unless [LoopClosing] enabled

  /// The frame's Manhattan frame from its NORMALS (Algorithm 4, labels tracked from frame to frame); sets
  /// frame.R_cam_mf when valid. A run whose first frame has no NORMALS is a setup mistake (an error naming `ctx`);
  /// a later frame without them has none.
  manhattan::ManhattanEstimate estimateManhattanFrame(tracking::Frame& frame, bool firstFrame, const std::string& ctx);
  /// Forgets the local mapper's recent points and every module's landmarks (a reset or a new map).
  void resetMapping();
  /// Sets `snapshot`'s extensions to what the modules and the loop closer hold (absent when they hold nothing or
  /// are off).
  void writeExtensions(map::Map& snapshot) const;
  /// Checks the extensions of a loaded map against it (pslam::Error naming `source`, nothing changed) and returns
  /// what restores them once the map is in place and the parts are reset.
  std::function<void()> prepareExtensions(const map::Map& loaded, const std::string& source);
};

}  // namespace pslam::system
