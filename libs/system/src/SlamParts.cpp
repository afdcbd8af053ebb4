#include "SlamParts.h"

#include <cmath>

#include "pslam/core/Error.h"
#include "pslam/direct/DirectFrontEnd.h"
#include "pslam/lines/LineFrontEnd.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/PoseSolver.h"

namespace pslam::system {

namespace {
features::OrbParams initializationOrb(const SlamParams& p) {
  features::OrbParams o = p.orb;
  o.nFeatures = static_cast<int>(std::lround(p.initializer.featureFactor * o.nFeatures));
  return o;
}
}  // namespace

SlamParts::SlamParts(const SlamParams& p, const geometry::PinholeCamera& cam, std::uint32_t seed,
                     std::shared_ptr<const places::Vocabulary> vocabulary,
                     const std::vector<SystemOptions::ModuleFactory>& extraModules)
    : params(p), camera(cam), extractor(p.orb), initExtractor(initializationOrb(p)) {
  mapper = std::make_unique<mapping::LocalMapper>(map, p.localMapping());
  tracker = std::make_unique<tracking::Tracker>(
      map, camera, p.tracking, tracking::makeMapInitializer(p.system.initializer, camera, p.initializer, p.bundleAdjustment),
      tracking::makePoseSolver(p.system.poseSolver, p.poseOptimization), seed);
  // The one point-use decision (§3.4.2-3.4.3): tracking asks the policy local mapping culls and optimizes with.
  tracker->setPointUsePolicy(mapper->pointUsePolicy());

  // The landmark modules, and what local BA optimizes besides the keypoints, in this order: the direct points
  // (§3.2.2, §3.4; their models follow the same [PointModel] as the keypoints), the Manhattan rotation priors of the
  // keyframes (§4.4), the line segments (eq. 2.59), the caller's own modules.
  std::shared_ptr<tracking::LandmarkModule> directPoints, lineSegments;
  if (p.directFeatures.enabled)
    directPoints = std::make_shared<direct::DirectFrontEnd>(p.directFeatures, p.pointModel, camera,
                                                            p.localMapping().depthPixelNoise);
  if (p.lines.enabled) lineSegments = std::make_shared<lines::LineFrontEnd>(p.lines, camera);
  for (const auto& module : {directPoints, lineSegments})
    if (module) modules.push_back(module);
  std::vector<std::shared_ptr<tracking::LandmarkModule>> extra;
  for (const SystemOptions::ModuleFactory& make : extraModules) {
    extra.push_back(make ? make(camera) : nullptr);
    require(extra.back() != nullptr, "SystemOptions::modules", "a module factory returned no module");
    modules.push_back(extra.back());
  }
  for (const auto& module : modules) tracker->addModule(module);
  if (directPoints) mapper->addBAFactorSource(directPoints);
  if (p.manhattan.enabled) {
    // §4.4: the mean shift gives every frame's Manhattan frame; the tracker uses its rotation with a
    // translation-only solver and falls back to 6-DoF tracking when the pose does not validate.
    manhattanTracker = std::make_unique<manhattan::ManhattanTracker>(p.manhattanTracker);
    tracker->enableManhattanPath(p.manhattan, tracking::makePoseSolver("translationOnly", p.poseOptimization));
    if (p.manhattan.baRotationSigmaDeg > 0.0) mapper->addBAFactorSource(tracker->manhattanPath());
  }
  if (lineSegments) mapper->addBAFactorSource(lineSegments);
  for (const auto& module : extra) mapper->addBAFactorSource(module);

  if (vocabulary) {
    tracker->setVocabulary(vocabulary, p.places);
    if (p.places.triangulation) mapper->setTriangulationSearch(mapping::TriangulationSearch::VocabularyNode);
    if (p.loopClosing.enabled)
      loopCloser = std::make_unique<loopclosing::LoopCloser>(map, p.loopClosing, p.bundleAdjustment, seed);
  }
}

manhattan::ManhattanEstimate SlamParts::estimateManhattanFrame(tracking::Frame& frame, bool firstFrame,
                                                              const std::string& ctx) {
  require(!frame.normals.empty() || !firstFrame, ctx,
          "[Manhattan] enabled = true but the frame has no NORMALS channel (add one with normal-priors "
          "--source depth|network, or render it with slam-synth)");
  if (frame.normals.empty()) {
    manhattan::ManhattanEstimate none;
    none.reason = "no NORMALS channel";
    return none;
  }
  // Only every normalStride-th pixel is used: those are picked from the 8-bit channel before decoding.
  const manhattan::ManhattanEstimate est =
      manhattanTracker->process(priors::sampleNormals(frame.normals, params.manhattan.normalStride, ctx + " NORMALS"));
  if (est.valid) frame.R_cam_mf = est.R_cam_mf;
  return est;
}

void SlamParts::resetMapping() {
  mapper->reset();
  for (const auto& module : modules) module->reset();
}

void SlamParts::writeExtensions(map::Map& snapshot) const {
  auto set = [&](const std::string& name, const std::optional<std::string>& bytes) {
    if (bytes)
      snapshot.setExtension(name, *bytes);
    else
      snapshot.eraseExtension(name);
  };
  for (const char* name : {lines::LineFrontEnd::kMapExtension, direct::DirectFrontEnd::kMapExtension})
    snapshot.eraseExtension(name);  // a module that is off writes none
  for (const auto& module : modules)
    if (!module->mapExtensionName().empty()) set(module->mapExtensionName(), module->mapExtension());
  std::optional<std::string> loopEdges;
  if (loopCloser && !loopCloser->loopEdges().empty()) loopEdges = loopCloser->serializeLoopEdges();
  set(loopclosing::LoopCloser::kMapExtension, loopEdges);
}

std::function<void()> SlamParts::prepareExtensions(const map::Map& loaded, const std::string& source) {
  std::vector<std::function<void()>> installs;
  try {
    for (const auto& module : modules)
      if (const std::string* bytes = module->mapExtensionName().empty() ? nullptr
                                                                          : loaded.extension(module->mapExtensionName()))
        installs.push_back(module->prepareLoad(*bytes, loaded));
    if (loopCloser)
      if (const std::string* bytes = loaded.extension(loopclosing::LoopCloser::kMapExtension)) {
        loopclosing::LoopCloser::parseLoopEdges(*bytes, loaded);
        // The map is moved into place before this runs: read its extension there.
        installs.push_back([this] {
          loopCloser->restoreLoopEdges(*map.extension(loopclosing::LoopCloser::kMapExtension), map);
        });
      }
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  return [installs] {
    for (const auto& install : installs) install();
  };
}

}  // namespace pslam::system
