#include "pslam/system/System.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/map/MapIO.h"
#include "pslam/manhattan/ManhattanTracker.h"
#include "pslam/loopclosing/LoopCloser.h"
#include "pslam/mapping/LocalMapper.h"
#include "pslam/priors/NormalMap.h"
#include "pslam/tracking/MapInitializer.h"
#include "pslam/tracking/PoseSolver.h"

namespace pslam::system {

double processCpuSeconds() { return processCpuMs() * 1e-3; }

namespace {

/// One frame with a pose, kept as ORB-SLAM keeps it for SaveTrajectoryTUM: relative to its reference keyframe,
/// so that the trajectory follows the keyframes when local BA refines them.
struct TrackedPose {
  double timestamp = 0.0;
  int generation = 0;
  map::KeyFrameId reference = map::kNoKeyFrame;
  Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();    ///< relative to the reference keyframe
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();  ///< as tracked (reference gone / unknown)
};

/// Reference keyframe of a tracked frame and the frame's pose relative to it (map lock held by the caller).
template <class ImplT>
void relativeToReference(const ImplT& s, const tracking::Tracker::Result& res, map::KeyFrameId& reference,
                         Eigen::Isometry3d& T_cam_ref, map::KeyFrameId& root) {
  if (res.hasPose && res.referenceKeyFrame != map::kNoKeyFrame && s.map.hasKeyFrame(res.referenceKeyFrame)) {
    reference = res.referenceKeyFrame;
    T_cam_ref = res.T_cam_world * s.map.keyFrame(reference).T_world_cam();
  }
  if (res.initialReferencePose) root = s.map.rootKeyFrame();
}

struct Counters {
  std::size_t frames = 0, tracked = 0, lost = 0, relocalizations = 0, relocalizationsWithdrawn = 0, resets = 0;
  std::size_t loopsClosed = 0;
  std::size_t loopsWithdrawn = 0;  ///< verified loops whose correction failed the outlier test (map restored)
  std::size_t manhattanFrames = 0, manhattanTracked = 0, fallbackTracked = 0;
  long long initializedAtFrame = -1;
};

}  // namespace

struct System::Impl {
  Impl(const SlamParams& p, const geometry::PinholeCamera& cam, std::uint32_t seed, bool threadedMode)
      : params(p),
        camera(cam),
        extractor(p.orb),
        initExtractor([&] {
          features::OrbParams o = p.orb;
          o.nFeatures = static_cast<int>(std::lround(p.initializer.featureFactor * o.nFeatures));
          return o;
        }()),
        threaded(threadedMode) {
    params.mapping.ba = params.bundleAdjustment;
    params.mapping.pointModel = params.pointModel;
    // A keyframe tracked by direct points alone shares no keypoint with the map: it triangulates with the two
    // most recent keyframes (LocalMappingParams::minTriangulationNeighbours) unless the config says otherwise.
    if (params.directFeatures.enabled && params.mapping.minTriangulationNeighbours == 0)
      params.mapping.minTriangulationNeighbours = 2;
    mapper = std::make_unique<mapping::LocalMapper>(map, params.mapping);
    if (params.mapping.refinement.enabled) {
      // Keyframe observations aligned to their point's anchor patch before local BA (doc/mapping.md).
      refiner = std::make_shared<mapping::ObservationRefiner>(params.mapping.refinement, camera);
      mapper->setObservationRefiner(refiner);
    }
    tracker = std::make_unique<tracking::Tracker>(
        map, camera, params.tracking,
        tracking::makeMapInitializer(params.system.initializer, camera, params.initializer, params.bundleAdjustment),
        tracking::makePoseSolver(params.system.poseSolver, params.poseOptimization), seed);
    // The one point-use decision (§3.4.2-3.4.3): tracking asks the policy local mapping culls and optimizes with.
    tracker->setPointUsePolicy(mapper->pointUsePolicy());
    if (params.directFeatures.enabled) {
      // Direct points (§3.2.2, §3.4): the tracker's pose optimization and local BA use them; their models follow
      // the same [PointModel] as the keypoints.
      directFrontEnd = std::make_shared<direct::DirectFrontEnd>(params.directFeatures, params.pointModel, camera,
                                                                params.mapping.depthPixelNoise);
      tracker->setDirectPointSource(directFrontEnd);
      mapper->setBAFactorHooks(
          [this](const map::Map& m, const optimize::BAProblem& problem) {
            return directFrontEnd->bundleAdjustmentFactors(m, problem);
          },
          [this](const std::vector<bool>& outliers) { directFrontEnd->afterBundleAdjustment(outliers); });
    }
    if (params.manhattan.enabled) {
      // §4.4: the mean shift gives every frame's Manhattan frame; the tracker uses its rotation with a
      // translation-only solver and falls back to 6-DoF tracking when the pose does not validate.
      manhattanTracker = std::make_unique<manhattan::ManhattanTracker>(params.manhattanTracker);
      tracker->enableManhattanPath(params.manhattan,
                                   tracking::makePoseSolver("translationOnly", params.poseOptimization));
      if (params.manhattan.baRotationSigmaDeg > 0.0)
        mapper->addBAFactorHooks(
            [this](const map::Map&, const optimize::BAProblem& problem) { return tracker->manhattanRotationPriors(problem); },
            nullptr);  // a prior has no state to update after BA
    }
    // ---- line segments ([Lines], eq. 2.59): tracking's pose optimization and local BA use them
    if (params.lines.enabled) {
      lineFrontEnd = std::make_shared<lines::LineFrontEnd>(params.lines, camera);
      tracker->setLineSource(lineFrontEnd);
      mapper->addBAFactorHooks(
          [this](const map::Map& m, const optimize::BAProblem& problem) {
            return lineFrontEnd->bundleAdjustmentFactors(m, problem);
          },
          [this](const std::vector<bool>& outliers) { lineFrontEnd->afterBundleAdjustment(outliers); });
    }
    // ---- end line segments
    if (threaded) {
      // Local mapping holds the map lock except while it searches keyframe pairs for triangulation and solves
      // local BA: those run on copies, with the lock released so tracking goes on. A reset meanwhile (a new map
      // generation) ends that keyframe's mapping.
      mapper->setOutsideMapLock(
          [this](const std::function<void()>& computation) { return runOutsideMapLock(computation); });
      mapper->setNewPointsReady([this](map::KeyFrameId) {
        {
          std::lock_guard<std::mutex> lk(queueMutex);
          pointsReadySeq = mappingSeq;
        }
        queueCv.notify_all();
      });
      worker = std::thread([this] { mappingLoop(); });
    }
  }

  /// Threaded mode, on the mapping thread (which holds the map lock): runs `computation`, which reads only copies
  /// of map data, with the lock released. False when tracking reset the map meanwhile (a new generation).
  bool runOutsideMapLock(const std::function<void()>& computation) {
    const int before = generation;
    struct Relock {
      std::unique_lock<std::mutex>& lock;
      ~Relock() { lock.lock(); }
    };
    mappingLock->unlock();
    {
      Relock relock{*mappingLock};
      computation();
    }
    return generation == before;
  }

  /// Threaded: called on the global BA's thread when its result is ready; wakes the mapping thread.
  void onGlobalBaReady() {
    {
      std::lock_guard<std::mutex> lk(queueMutex);
      globalBa = GlobalBaState::Ready;
      ++globalBaSignals;
    }
    queueCv.notify_all();
  }

  /// Threaded, on the mapping thread with the map lock held, between keyframes: writes a finished global BA back.
  void applyGlobalBa() {
    if (!loopCloser) return;
    if (std::optional<nlohmann::json> applied = loopCloser->applyGlobalBundleAdjustment()) {
      (*applied)["generation"] = generation;
      mappingTimings.add("global_ba", (*applied)["global_ba_ms"].get<double>());
      mappingTimings.add("global_ba_apply", (*applied)["apply_ms"].get<double>());
      globalBaLog.push_back(std::move(*applied));
    }
  }

  /// Loop closing moved keyframes (LoopCloser::KeyFramesMoved, map lock held): frames are kept relative to their
  /// reference keyframe, so their offsets follow its change of scale, and the tracker's last frame follows its
  /// reference keyframe.
  void onLoopKeyFramesMoved(const loopclosing::LoopReport& lr,
                            const std::map<map::KeyFrameId, Eigen::Isometry3d>& posesBefore) {
    for (TrackedPose& p : poses) {
      const auto sc = lr.keyFrameScales.find(p.reference);
      if (p.generation == generation && sc != lr.keyFrameScales.end()) p.T_cam_ref.translation() /= sc->second;
    }
    const map::KeyFrameId ref = tracker->referenceKeyFrame();
    const auto before = posesBefore.find(ref);
    if (before == posesBefore.end() || !map.hasKeyFrame(ref)) return;
    const auto sc = lr.keyFrameScales.find(ref);
    tracker->onKeyFramesMoved(ref, before->second, sc != lr.keyFrameScales.end() ? sc->second : 1.0);
  }

  /// The frame's Manhattan frame from its NORMALS (Algorithm 4, labels tracked from frame to frame).
  manhattan::ManhattanEstimate estimateManhattanFrame(tracking::Frame& frame, const std::string& ctx) {
    // A rawlog without normals is a setup mistake (said at its first frame); a later frame without them has no
    // Manhattan frame and is tracked by the 6-DoF path.
    require(!frame.normals.empty() || counters.frames > 0, ctx,
            "[Manhattan] enabled = true but the frame has no NORMALS channel (add one with normal-priors "
            "--source depth|network, or render it with slam-synth)");
    if (frame.normals.empty()) {
      manhattan::ManhattanEstimate none;
      none.reason = "no NORMALS channel";
      return none;
    }
    // Only every normalStride-th pixel is used: those are picked from the 8-bit channel before decoding (the
    // same normals in the same order as decoding the whole image and collecting with the stride).
    const int stride = params.manhattan.normalStride;
    const cv::Mat& full = frame.normals;
    cv::Mat picked((full.rows + stride - 1) / stride, (full.cols + stride - 1) / stride, full.type());
    if (full.type() == CV_8UC3)
      for (int r = 0; r < picked.rows; ++r) {
        const auto* in = full.ptr<cv::Vec3b>(r * stride);
        auto* out = picked.ptr<cv::Vec3b>(r);
        for (int c = 0; c < picked.cols; ++c) out[c] = in[c * stride];
      }
    const cv::Mat normals = priors::decodeNormalMap(picked, ctx + " NORMALS");  // checks the type
    const manhattan::ManhattanEstimate est = manhattanTracker->process(priors::collectNormals(normals, 1));
    if (est.valid) frame.R_cam_mf = est.R_cam_mf;
    return est;
  }

  ~Impl() {
    if (worker.joinable()) {
      {
        std::lock_guard<std::mutex> lk(queueMutex);
        stop = true;
      }
      queueCv.notify_all();
      worker.join();
    }
    // Global BAs a later loop stopped may still be ending their iteration; their callback takes queueMutex, which
    // is destroyed before loopCloser.
    if (loopCloser) loopCloser->reset();
  }

  /// Runs local mapping on `kfs` (caller holds mapMutex in threaded mode).
  void mapKeyFrames(const std::vector<map::KeyFrameId>& kfs, bool measuredByTracking) {
    for (map::KeyFrameId kf : kfs) {
      if (!map.hasKeyFrame(kf)) continue;  // erased meanwhile
      const mapping::LocalMappingReport r = mapper->processKeyFrame(kf, {}, measuredByTracking);
      if (r.mapChanged) return;  // threaded: tracking reset the map meanwhile, kf belongs to the old one
      direct::DirectCreationReport d;
      if (directFrontEnd && map.hasKeyFrame(kf)) {
        // New direct points at the keyframe's refined pose (§3.4.3), matched into its best covisible keyframe.
        d = directFrontEnd->createPoints(map, kf);
        directFrontEnd->prune(map);
        mappingTimings.add("direct_creation", d.ms);
        if (d.partner != map::kNoKeyFrame) {  // its steps (doc/experiments.md, cost of the direct points)
          mappingTimings.add("direct_selection", d.selectionMs);
          mappingTimings.add("direct_flow", d.flowMs);
          mappingTimings.add("direct_new_points", d.pointsMs);
        }
      }
      mappingLog.push_back({{"generation", generation},
                            {"direct_selected", d.selected},
                            {"direct_tracked", d.tracked},
                            {"direct_created", d.created},
                            {"direct_partner", d.partner == map::kNoKeyFrame ? -1 : static_cast<long long>(d.partner)},
                            {"keyframe", kf},
                            {"new_points", r.newPoints},
                            {"culled_points", r.culledPoints},
                            {"culled_recent", r.culledRecent},
                            {"culled_inlier_ratio", r.culledInlierRatio},
                            {"landmark_updates", r.landmarkUpdates},
                            {"culled_keyframes", r.culledKeyFrames},
                            {"ba_observations_erased", r.baObservationsErased},
                            {"ba_stopped", r.baStopped},
                            {"ba_final_rms_px", r.baFinalRmsPixels},
                            {"fused", r.fusedPoints},
                            {"refined_observations", r.refinement.refined},
                            {"refinement_tried", r.refinement.tried},
                            {"map_points", map.numMapPoints()},
                            {"keyframes", map.numKeyFrames()}});
      // ---- line segments: new lines of the keyframe with its covisible keyframes (after local BA)
      if (lineFrontEnd && map.hasKeyFrame(kf)) {
        const lines::LineCreationReport l = lineFrontEnd->createLines(map, kf);
        lineFrontEnd->prune(map);
        mappingTimings.add("line_creation", l.ms);
        mappingLog.back()["lines_created"] = l.created;
        mappingLog.back()["lines_fused"] = l.fused;
        mappingLog.back()["lines_culled"] = l.culled;
        mappingLog.back()["lines"] = lineFrontEnd->numLines();
      }
      // ---- loop closing: the keyframe is queried for a place seen long before, after its local mapping
      if (loopCloser && map.hasKeyFrame(kf)) {
        const loopclosing::LoopReport lr = loopCloser->processKeyFrame(kf);  // calls onLoopKeyFramesMoved
        mappingTimings.add("loop_closing", lr.ms);
        if (lr.closed && !lr.globalBaAsynchronous) mappingTimings.add("global_ba", lr.globalBaMs);
        if (lr.candidates > 0) {
          nlohmann::json j = lr.toJson();
          j["generation"] = generation;
          loops.push_back(std::move(j));
        }
        if (lr.closed) ++counters.loopsClosed;
        if (lr.withdrawn) ++counters.loopsWithdrawn;
        if (lr.globalBaAsynchronous) {
          std::lock_guard<std::mutex> lk(queueMutex);
          if (globalBa == GlobalBaState::None) globalBa = GlobalBaState::Running;  // Ready when it was that quick
        }
      }
      // Every step of a keyframe's local mapping (issue: mapping cost per keyframe, doc/performance.md).
      mappingTimings.add("mapping_insert", r.processMs);  // keyframe insertion, model updates of its points
      mappingTimings.add("culling_points", r.cullPointsMs);
      mappingTimings.add("triangulation", r.triangulationMs);
      mappingTimings.add("fusion", r.fusionMs);
      if (refiner) mappingTimings.add("observation_refinement", r.refinementMs);
      mappingTimings.add("local_ba", r.localBaMs);
      mappingTimings.add("culling_keyframes", r.cullKeyFramesMs);
      mappingTimings.add("mapping_total", r.totalMs);
    }
  }

  void mappingLoop() {
    for (;;) {
      std::pair<int, QueuedKeyFrame> item;
      {
        std::unique_lock<std::mutex> lk(queueMutex);
        queueCv.wait(lk, [&] {
          return globalBa == GlobalBaState::Ready || !queue.empty() || (stop && globalBa == GlobalBaState::None);
        });
        if (globalBa == GlobalBaState::Ready) {
          // A loop's global BA finished: written back between two keyframes, with the map lock held.
          const std::uint64_t signalsSeen = globalBaSignals;
          busy = true;
          lk.unlock();
          bool stale = false;
          {
            std::lock_guard<std::mutex> mk(mapMutex);
            // Unless the Ready came from a BA that a later loop stopped (LoopCloser::abortGlobalBundleAdjustment, a
            // race the stop can lose) while the later loop's BA still runs: never wait on the solver here.
            stale = loopCloser && loopCloser->globalBaPending() && !loopCloser->globalBaFinished();
            if (!stale) applyGlobalBa();
          }
          lk.lock();
          busy = false;
          if (!stale)
            globalBa = GlobalBaState::None;  // new BAs start on this thread only: none signalled meanwhile
          else if (globalBaSignals == signalsSeen)
            globalBa = GlobalBaState::Running;  // else the running BA signalled meanwhile: Ready stays
          lk.unlock();
          queueCv.notify_all();
          continue;
        }
        if (queue.empty()) return;  // stop requested and nothing left
        item = queue.front();
        queue.pop_front();
        busy = true;
        mappingSeq = item.second.seq;
      }
      queueCv.notify_all();  // tracking may wait for the queue to shrink
      {
        std::unique_lock<std::mutex> mk(mapMutex);
        mappingLock = &mk;  // released by the mapper around its computations on copies (setOutsideMapLock)
        // Keyframe ids restart after a reset: a queued id of an older map generation is stale.
        if (item.first == generation && mappingEnabled) mapKeyFrames({item.second.keyFrame}, item.second.measuredByTracking);
        mappingLock = nullptr;
      }
      {
        std::lock_guard<std::mutex> lk(queueMutex);
        busy = false;
        pointsReadySeq = std::max(pointsReadySeq, item.second.seq);  // skipped, stopped early or done
      }
      queueCv.notify_all();
    }
  }

  /// Threaded: waits until the mapping thread has mapped every queued keyframe and, unless `localMappingOnly`, a
  /// loop's global BA is written back (outputs, map loading, resets). Tracking's urgent wait for a keyframe waits
  /// for local mapping only: a global BA runs on a thread of its own and local mapping goes on beside it.
  void waitForMapping(bool localMappingOnly = false) {
    if (!threaded) return;
    std::unique_lock<std::mutex> lk(queueMutex);
    queueCv.wait(lk, [&] {
      return queue.empty() && !busy && (localMappingOnly || globalBa == GlobalBaState::None);
    });
  }

  /// A new map generation: poses of earlier maps are never mixed with the new one.
  void newGeneration() {
    ++generation;
    poses.clear();
    if (loopCloser) {
      loopCloser->reset();  // waits for a running global BA and drops it
      std::lock_guard<std::mutex> lk(queueMutex);
      globalBa = GlobalBaState::None;
    }
    queueCv.notify_all();
  }

  SlamParams params;
  geometry::PinholeCamera camera;
  map::Map map;
  features::OrbExtractor extractor;
  features::OrbExtractor initExtractor;  ///< featureFactor x nFeatures, used until the map is initialized
  std::unique_ptr<mapping::LocalMapper> mapper;
  std::unique_ptr<tracking::Tracker> tracker;
  std::shared_ptr<direct::DirectFrontEnd> directFrontEnd;  ///< null unless [DirectFeatures] enabled
  std::unique_ptr<manhattan::ManhattanTracker> manhattanTracker;  ///< null unless [Manhattan] enabled
  std::shared_ptr<lines::LineFrontEnd> lineFrontEnd;       ///< null unless [Lines] enabled
  std::shared_ptr<mapping::ObservationRefiner> refiner;   ///< null unless [LocalMapping] refinement.enabled
  std::unique_ptr<loopclosing::LoopCloser> loopCloser;     ///< null unless [LoopClosing] enabled
  nlohmann::json loops = nlohmann::json::array();          ///< loop-closing reports with candidates
  StageTimings trackingTimings, mappingTimings;
  nlohmann::json mappingLog = nlohmann::json::array();
  nlohmann::json frames = nlohmann::json::array();
  std::vector<TrackedPose> poses;  ///< of the current generation
  Counters counters;
  int generation = 0;
  bool mappingEnabled = true;

  bool threaded = false;
  mutable std::mutex mapMutex;
  std::mutex queueMutex;
  std::condition_variable queueCv;
  struct QueuedKeyFrame {
    map::KeyFrameId keyFrame = map::kNoKeyFrame;
    bool measuredByTracking = false;
    std::uint64_t seq = 0;  ///< 1, 2, ... in the order tracking queued them
  };
  std::uint64_t queuedSeq = 0;      ///< seq of the last keyframe queued
  std::uint64_t mappingSeq = 0;     ///< seq of the keyframe being mapped
  std::uint64_t pointsReadySeq = 0; ///< keyframes up to this seq have their new points in the map
  std::deque<std::pair<int, QueuedKeyFrame>> queue;  ///< (generation, keyframe)
  std::unique_lock<std::mutex>* mappingLock = nullptr;  ///< the mapping thread's hold of mapMutex
  bool busy = false;
  /// Threaded, [System] waitAfterNextExtraction: the wait the last frame left for this one (tracking thread only).
  enum class PendingWait { None, WeakKeyFrame, Urgent };
  PendingWait pendingWait = PendingWait::None;

  /// The waits tracking takes for the mapping thread after a frame: a weak keyframe's new points in the map
  /// (wait_for_weak_keyframe), or mapping idle for an urgent keyframe (wait_for_mapping_urgent).
  void waitFor(PendingWait what) {
    if (what == PendingWait::WeakKeyFrame) {
      ScopedStage wait(trackingTimings, "wait_for_weak_keyframe");
      std::unique_lock<std::mutex> lk(queueMutex);
      queueCv.wait(lk, [&] { return pointsReadySeq >= queuedSeq; });
    } else if (what == PendingWait::Urgent) {
      ScopedStage wait(trackingTimings, "wait_for_mapping_urgent");
      waitForMapping(true);
    }
  }
  /// The wait the last frame left ([System] waitAfterNextExtraction), if any.
  void takePendingWait() {
    waitFor(pendingWait);
    pendingWait = PendingWait::None;
  }
  /// Threaded: a loop's global BA on its own thread (LoopCloser::setAsynchronousGlobalBa), guarded by queueMutex.
  enum class GlobalBaState { None, Running, Ready };
  GlobalBaState globalBa = GlobalBaState::None;
  std::uint64_t globalBaSignals = 0;  ///< ready callbacks so far (queueMutex)
  nlohmann::json globalBaLog = nlohmann::json::array();  ///< report.json "global_ba": one entry per BA written back
  bool stop = false;
  std::thread worker;
};

System::System(SlamParams params, SystemOptions options)
    : params_(std::move(params)), options_(std::move(options)) {
  params_.check();
  // Unknown solver / initializer names fail here, not at the first frame.
  tracking::requirePoseSolver(params_.system.poseSolver);
  tracking::requireMapInitializer(params_.system.initializer);
  if (params_.loopClosing.enabled && params_.places.vocabulary.empty())
    throw Error("[LoopClosing] enabled = true needs a vocabulary ([Places] vocabulary)");
  // The vocabulary is read before the first frame: a bad file fails the run at its start.
  if (!params_.places.vocabulary.empty()) {
    // The configs' default vocabulary is generated by the build, not stored in the repository: say how to get it.
    if (!std::filesystem::exists(params_.places.vocabulary))
      throw Error(params_.places.vocabulary + ": vocabulary file not found (the configs' default one is trained " +
                  "by the build: cmake --build <build> --target vocabulary, or bash scripts/train-vocabulary.sh; " +
                  "without place recognition: --set Places.vocabulary= --set LoopClosing.enabled=false)");
    vocabulary_ = std::make_shared<const places::Vocabulary>(places::Vocabulary::load(params_.places.vocabulary));
  }
  if (vocabulary_) vocabularyFingerprint_ = vocabulary_->fingerprint();
  threaded_ = options_.threaded.value_or(params_.system.threaded);
  if (options_.camera) {
    options_.camera->check();
    start(*options_.camera);
  }
}

void System::start(const geometry::PinholeCamera& camera) {
  camera_ = camera;
  impl_ = std::make_unique<Impl>(params_, camera, options_.seed, threaded_);
  if (vocabulary_) {
    impl_->tracker->setVocabulary(vocabulary_, params_.places);
    if (params_.places.triangulation) impl_->mapper->setTriangulationSearch(mapping::TriangulationSearch::VocabularyNode);
    if (params_.loopClosing.enabled) {
      impl_->loopCloser = std::make_unique<loopclosing::LoopCloser>(impl_->map, params_.loopClosing,
                                                                    params_.bundleAdjustment, options_.seed);
      Impl* impl = impl_.get();
      impl_->loopCloser->setKeyFramesMoved(
          [impl](const loopclosing::LoopReport& lr, const std::map<map::KeyFrameId, Eigen::Isometry3d>& before) {
            impl->onLoopKeyFramesMoved(lr, before);
          });
      // Threaded: the global BA of a closed loop runs on a thread of its own; the mapping thread writes it back.
      if (threaded_) impl_->loopCloser->setAsynchronousGlobalBa([impl] { impl->onGlobalBaReady(); });
    }
  }
  impl_->mappingEnabled = mappingEnabled_;
  impl_->tracker->setMapUpdatesEnabled(mappingEnabled_);
  // Threaded live: weak tracking asks for a keyframe on its own (KeyFrameDecisionInput::weakInliers), with the
  // threshold at which a keyframe's new points are waited for.
  if (threaded_ && params_.system.threadedTracking == "live")
    impl_->tracker->setWeakTrackingInliers(params_.system.weakKeyFrameInliers);
}

System::~System() = default;

const geometry::PinholeCamera& System::camera() const {
  require(camera_.has_value(), "System", "no camera yet: it is taken from the first frame");
  return *camera_;
}

bool System::initialized() const {
  if (!impl_) return false;
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  return impl_->tracker->initialized();
}

TrackResult System::track(const datasets::Frame& input) {
  const std::string ctx = "frame " + std::to_string(input.index);
  require(!input.image.empty(), ctx, "CAMERA image is empty");
  require(std::isfinite(input.timestamp), ctx, "timestamp is not finite");
  if (!impl_) {
    geometry::PinholeCamera cam;
    try {
      cam = geometry::PinholeCamera::fromTCamera(input.camera);
    } catch (const std::exception& e) {
      throw Error(ctx + ": invalid or missing CAMERA intrinsics: " + e.what());
    }
    require(cam.width == input.image.cols && cam.height == input.image.rows, ctx,
            "intrinsics resolution " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                " differs from the image " + std::to_string(input.image.cols) + "x" + std::to_string(input.image.rows));
    start(cam);
  }
  Impl& s = *impl_;
  require(input.image.cols == s.camera.width && input.image.rows == s.camera.height, ctx,
          "image size changed to " + std::to_string(input.image.cols) + "x" + std::to_string(input.image.rows) +
              " (first frame: " + std::to_string(s.camera.width) + "x" + std::to_string(s.camera.height) + ")");

  tracking::Tracker::Result res;
  Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();
  map::KeyFrameId reference = map::kNoKeyFrame;
  map::KeyFrameId root = map::kNoKeyFrame;
  {
    // tracking_total = extraction + tracking without local mapping (ORB-SLAM's per-frame tracking time).
    ScopedStage total(s.trackingTimings, "tracking_total");
    tracking::Frame frame;
    {
      ScopedStage st(s.trackingTimings, "extraction");
      // [PointModel] semantic = false: the SEMANTIC channel is not used anywhere (point model, initializer).
      datasets::Frame withoutSemantic;
      const bool dropSemantic = !channelsUsed(s.params).semantic && input.hasSemantic();
      if (dropSemantic) {
        withoutSemantic = input;
        withoutSemantic.semantic = cv::Mat();
      }
      frame = tracking::makeFrame(dropSemantic ? withoutSemantic : input, s.camera, s.tracker->initialized() ? s.extractor : s.initExtractor,
                                  ctx + " (t=" + std::to_string(input.timestamp) + ")");
    }
    if (s.pendingWait != Impl::PendingWait::None) {
      // The last frame's wait for mapping, taken now that this frame's features are extracted (the extraction
      // overlapped with the mapping waited for); not part of this frame's tracking time.
      const auto waitStart = std::chrono::steady_clock::now();
      s.takePendingWait();
      total.exclude(msSince(waitStart));
    }
    std::optional<manhattan::ManhattanEstimate> mf;
    const bool hasNormals = !frame.normals.empty();
    if (s.manhattanTracker) {
      ScopedStage st(s.trackingTimings, "manhattan_frame");
      mf = s.estimateManhattanFrame(frame, ctx);
    }
    if (s.threaded) {
      std::unique_lock<std::mutex> lk(s.queueMutex);
      if (s.params.system.threadedTracking == "afterNewPoints") {
        // The frame is tracked once the last keyframe's new points are in the map (its triangulation and fusion
        // done): this frame's extraction overlaps with them, tracking with that keyframe's local BA and culling;
        // a keyframe may be made whenever none waits for the mapping thread.
        {
          ScopedStage wait(s.trackingTimings, "wait_for_mapping_queue");
          s.queueCv.wait(lk, [&] { return s.pointsReadySeq >= s.queuedSeq; });
        }
        s.tracker->setLocalMappingIdle(s.queue.empty());
      } else {
        // live (ORB-SLAM's): tracking goes on while a keyframe is mapped and makes a keyframe only when the mapping
        // thread is idle (AcceptKeyFrames) or maxFrames have passed; a keyframe made meanwhile waits until the
        // mapping thread takes it, so tracking is never more than one keyframe ahead.
        {
          ScopedStage wait(s.trackingTimings, "wait_for_mapping_queue");
          s.queueCv.wait(lk, [&] { return s.queue.empty(); });
        }
        s.tracker->setLocalMappingIdle(!s.busy);
      }
    }
    std::unique_lock<std::mutex> mk(s.mapMutex, std::defer_lock);
    if (s.threaded) {
      // How long tracking waits while the mapping thread holds the map (doc/performance.md).
      ScopedStage wait(s.trackingTimings, "wait_for_map_lock");
      mk.lock();
    }
    const cv::Mat grey = frame.grey, semantic = frame.semantic;
    if (s.lineFrontEnd && s.tracker->initialized()) {  // ---- line segments: LSD + LBD of the frame
      ScopedStage st(s.trackingTimings, "line_extraction");
      s.lineFrontEnd->prepareFrame(frame);
    }
    res = s.tracker->track(std::move(frame), s.trackingTimings);
    if (res.keyFrameWaitsForMapping) s.mapper->interruptBundleAdjustment();
    if (mf) {
      tracking::ManhattanFrameReport& m = res.report.manhattan;
      m.normals = hasNormals;
      m.frameValid = mf->valid;
      m.observedAxes = mf->observedAxes;
      if (!mf->valid) m.reason = "no Manhattan frame: " + mf->reason;
    }
    if (res.mapWasReset) {
      s.mapper->reset();
      s.newGeneration();
      if (s.directFrontEnd) s.directFrontEnd->reset();
      if (s.lineFrontEnd) s.lineFrontEnd->reset();
      if (s.refiner) s.refiner->reset();
    }
    if (s.refiner && s.mappingEnabled && !res.newKeyFrames.empty()) {
      // The two keyframes of a new map: the initializer's reference frame and this one.
      if (res.initialReferencePose) s.refiner->reset();
      for (std::size_t k = 0; k < res.newKeyFrames.size(); ++k) {
        const bool reference = res.initialReferencePose && k == 0;
        s.refiner->addKeyFrame(res.newKeyFrames[k], reference ? res.initialReferenceGrey : grey,
                               s.map.keyFrame(res.newKeyFrames[k]).scaleFactors);
      }
    }
    if (s.lineFrontEnd && s.mappingEnabled && !res.newKeyFrames.empty()) {  // ---- line segments: keyframes
      // The two keyframes of a new map: the initializer's reference frame and this one (no lines matched yet).
      if (res.initialReferencePose) s.lineFrontEnd->reset();
      for (std::size_t k = 0; k < res.newKeyFrames.size(); ++k) {
        const bool reference = res.initialReferencePose && k == 0;
        s.lineFrontEnd->addKeyFrame(res.newKeyFrames[k], reference ? res.initialReferenceGrey : grey,
                                    !reference && !res.initialReferencePose);
      }
    }
    if (s.directFrontEnd && s.mappingEnabled && !res.newKeyFrames.empty()) {
      // Keyframe images for the direct points; the two keyframes of a new map are the initializer's reference
      // frame and this one (affine brightness (0, 0): the first map sets the reference exposure).
      if (res.initialReferencePose) {
        s.directFrontEnd->reset();
        s.directFrontEnd->addKeyFrame(res.newKeyFrames.front(), res.initialReferenceGrey, res.initialReferenceSemantic,
                                      false);
        for (std::size_t k = 1; k < res.newKeyFrames.size(); ++k)
          s.directFrontEnd->addKeyFrame(res.newKeyFrames[k], grey, semantic, false);
      } else {
        for (map::KeyFrameId kf : res.newKeyFrames) s.directFrontEnd->addKeyFrame(kf, grey, semantic, true);
      }
    }
    // The pose relative to the reference keyframe as tracking left it, before local mapping (ORB-SLAM's relative
    // frame poses): a frame that made a keyframe is that keyframe (identity) and follows every later refinement of
    // it, the local BA it triggers included. Taking it after local mapping instead kept such a frame at its pre-BA
    // pose in the moved map (single-frame jumps of 3-5x the step where BA moves keyframes a lot). Threaded: read
    // under the same lock as tracking, since the mapping thread may move the keyframe right after.
    relativeToReference(s, res, reference, T_cam_ref, root);
  }

  // Local mapping: in this thread (sequential, deterministic) or queued for the mapping thread.
  if (s.mappingEnabled && !res.newKeyFrames.empty()) {
    if (!s.threaded) {
      s.mapKeyFrames(res.newKeyFrames, res.measuredByTracking);
    } else {
      {
        std::lock_guard<std::mutex> lk(s.queueMutex);
        for (map::KeyFrameId kf : res.newKeyFrames)
          s.queue.emplace_back(s.generation, Impl::QueuedKeyFrame{kf, res.measuredByTracking, ++s.queuedSeq});
      }
      s.queueCv.notify_all();
    }
  }

  // Threaded live: a keyframe made on weak tracking ([System] weakKeyFrameInliers) holds tracking until its new
  // points are in the map; the next frames would otherwise be tracked without them and fall further.
  Impl::PendingWait wait = Impl::PendingWait::None;
  if (s.threaded && s.mappingEnabled && !res.newKeyFrames.empty() && s.params.system.threadedTracking == "live" &&
      res.report.inliers < s.params.system.weakKeyFrameInliers)
    wait = Impl::PendingWait::WeakKeyFrame;
  // Threaded: the frame needed a keyframe that mapping was too busy to take, and tracks too few of the reference
  // keyframe's points to go on without one ([Tracking] keyFrames.waitRatio): tracking waits until mapping is idle,
  // so the next frame can make that keyframe (its BA was asked to stop above).
  if (s.threaded && res.keyFrameUrgent && s.mappingEnabled) wait = Impl::PendingWait::Urgent;
  // Both waits are for the next frame's tracking: taken here, or after the next frame's extraction.
  if (s.params.system.waitAfterNextExtraction)
    s.pendingWait = wait;
  else
    s.waitFor(wait);

  // Bookkeeping of the trajectory and the counters (under the map lock when threaded: the getters take it).
  std::unique_lock<std::mutex> bookLock(s.mapMutex, std::defer_lock);
  if (s.threaded) bookLock.lock();
  Counters& c = s.counters;
  ++c.frames;
  if (res.mapWasReset) ++c.resets;
  if (res.initialReferencePose) {
    if (c.initializedAtFrame < 0 || res.mapWasReset) c.initializedAtFrame = static_cast<long long>(input.index);
    s.poses.push_back({res.initialReferencePose->first, s.generation, root, Eigen::Isometry3d::Identity(),
                       res.initialReferencePose->second});
  }
  if (res.retractedFrames > 0) {
    // The tracker withdrew a relocalization (lost again right after it): its frames lose their poses, in the
    // trajectory, the counters and report.json alike. They are the last frames with a pose, none a keyframe.
    const std::size_t n = std::min({res.retractedFrames, s.poses.size(), s.frames.size()});
    s.poses.erase(s.poses.end() - static_cast<std::ptrdiff_t>(n), s.poses.end());
    for (std::size_t k = s.frames.size() - n; k < s.frames.size(); ++k) {
      s.frames[k]["status"] = tracking::toString(tracking::FrameStatus::Lost);
      s.frames[k]["relocalization_withdrawn"] = true;
    }
    c.tracked -= n;
    c.lost += n;
    if (c.relocalizations > 0) --c.relocalizations;
    ++c.relocalizationsWithdrawn;
  }
  if (res.report.status == tracking::FrameStatus::Lost) ++c.lost;
  if (res.report.manhattan.frameValid) ++c.manhattanFrames;
  if (res.hasPose && res.report.manhattan.mode == "manhattan") ++c.manhattanTracked;
  if (res.hasPose && res.report.manhattan.mode == "fallback") ++c.fallbackTracked;
  if (res.report.status == tracking::FrameStatus::Relocalized) ++c.relocalizations;
  if (res.hasPose) {
    ++c.tracked;
    s.poses.push_back({input.timestamp, s.generation, reference, T_cam_ref, res.T_cam_world});
  }
  s.frames.push_back(res.report.toJson());
  if (bookLock.owns_lock()) bookLock.unlock();

  TrackResult out;
  out.status = res.report.status;
  out.keyFrame = res.report.keyFrame;
  out.mapWasReset = res.mapWasReset;
  out.retractedFrames = res.retractedFrames;
  if (res.hasPose) out.pose = StampedPose(input.timestamp, res.T_cam_world.inverse()).toCPose3D();
  out.report = std::move(res.report);
  return out;
}

void System::finish() {
  if (!impl_) return;
  impl_->takePendingWait();  // the last frame's wait, had another frame come
  impl_->waitForMapping();
}

void System::waitForLocalMapping() {
  if (impl_) impl_->waitForMapping(true);
}

Trajectory System::trajectory() const {
  Trajectory trajectory;
  if (!impl_) return trajectory;
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  const map::Map& m = impl_->map;
  for (const TrackedPose& p : impl_->poses) {
    Eigen::Isometry3d T_cam_world = p.T_cam_world;
    // The reference keyframe may have been culled since: its pose then follows its spanning-tree parent.
    if (p.reference != map::kNoKeyFrame)
      if (const auto T_ref_world = m.keyFramePoseIncludingErased(p.reference)) T_cam_world = p.T_cam_ref * *T_ref_world;
    trajectory.emplace_back(p.timestamp, T_cam_world.inverse());
  }
  std::stable_sort(trajectory.begin(), trajectory.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  return trajectory;
}

Trajectory System::keyFrameTrajectory() const {
  Trajectory keyframes;
  if (!impl_) return keyframes;
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  for (const auto& [id, kf] : impl_->map.keyFrames()) keyframes.emplace_back(kf.timestamp, kf.T_world_cam());
  return keyframes;
}

map::Map System::mapSnapshot() const {
  if (!impl_) return map::Map();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  map::Map snapshot = impl_->map;
  // The map records the vocabulary of the run that builds it; a localization run leaves the loaded map as it was.
  if (!mappingEnabled_) return snapshot;
  snapshot.setVocabulary(vocabularyFingerprint_);
  // What lives beside the map proper (map extensions): what this run's front ends hold, absent when they hold
  // nothing or are off.
  auto extension = [&](const char* name, const std::string& bytes, bool empty) {
    if (empty)
      snapshot.eraseExtension(name);
    else
      snapshot.setExtension(name, bytes);
  };
  if (impl_->lineFrontEnd)
    extension(lines::LineFrontEnd::kMapExtension, impl_->lineFrontEnd->serialize(),
              impl_->lineFrontEnd->keyFrames().empty());
  else
    snapshot.eraseExtension(lines::LineFrontEnd::kMapExtension);
  if (impl_->loopCloser)
    extension(loopclosing::LoopCloser::kMapExtension, impl_->loopCloser->serializeLoopEdges(),
              impl_->loopCloser->loopEdges().empty());
  else
    snapshot.eraseExtension(loopclosing::LoopCloser::kMapExtension);
  if (impl_->directFrontEnd)
    extension(direct::DirectFrontEnd::kMapExtension, impl_->directFrontEnd->serialize(),
              impl_->directFrontEnd->numPoints() == 0);
  else
    snapshot.eraseExtension(direct::DirectFrontEnd::kMapExtension);
  return snapshot;
}

void System::saveMap(const std::filesystem::path& path) const { map::saveMap(mapSnapshot(), path); }

void System::loadMap(const std::filesystem::path& path) { setMap(map::loadMap(path), path.string()); }

namespace {
std::string describe(const map::CameraIntrinsics& c) {
  std::ostringstream os;
  os.precision(10);  // intrinsics that differ in a late digit must not print alike
  os << "fx " << c.fx << ", fy " << c.fy << ", cx " << c.cx << ", cy " << c.cy << ", " << c.width << "x" << c.height;
  return os.str();
}
}  // namespace

void System::setMap(map::Map loaded, const std::string& source) {
  require(loaded.numKeyFrames() > 0, source, "map has no keyframe: nothing to localize against");
  const map::CameraIntrinsics mapCamera = loaded.keyFrames().begin()->second.camera;
  if (!impl_) {
    // Without a camera yet, the map's (undistorted) intrinsics are the camera; frames must then fit them.
    geometry::PinholeCamera cam(mapCamera.fx, mapCamera.fy, mapCamera.cx, mapCamera.cy, mapCamera.width,
                                mapCamera.height);
    cam.check();
    start(cam);
  }
  impl_->waitForMapping();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  const map::CameraIntrinsics own = tracking::toIntrinsics(impl_->camera);
  require(own == mapCamera, source,
          "map camera (" + describe(mapCamera) + ") differs from the camera of this run (" + describe(own) + ")");
  // The map's extensions are checked against it before anything is replaced (a bad one: nothing changes).
  const std::string* lineStore = impl_->lineFrontEnd ? loaded.extension(lines::LineFrontEnd::kMapExtension) : nullptr;
  const std::string* loopEdges =
      impl_->loopCloser ? loaded.extension(loopclosing::LoopCloser::kMapExtension) : nullptr;
  const std::string* directPoints =
      impl_->directFrontEnd ? loaded.extension(direct::DirectFrontEnd::kMapExtension) : nullptr;
  std::map<map::KeyFrameId, direct::DirectHost> directHosts;
  lines::LineFrontEnd::Store lines;
  try {
    if (lineStore) lines = lines::LineFrontEnd::parse(*lineStore, loaded);
    if (loopEdges) loopclosing::LoopCloser::parseLoopEdges(*loopEdges, loaded);
    if (directPoints) directHosts = direct::DirectFrontEnd::parse(*directPoints, loaded);
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  impl_->map = std::move(loaded);
  impl_->mapper->reset();
  if (impl_->directFrontEnd) impl_->directFrontEnd->reset();
  if (impl_->lineFrontEnd) impl_->lineFrontEnd->reset();
  if (impl_->refiner) impl_->refiner->reset();
  impl_->tracker->onMapLoaded();
  impl_->newGeneration();  // resets loop closing
  // The lines, loop edges and direct points the map was saved with (its extensions "lines", "loop_edges",
  // "direct_points").
  if (lineStore) impl_->lineFrontEnd->restore(std::move(lines));
  if (loopEdges)
    impl_->loopCloser->restoreLoopEdges(*impl_->map.extension(loopclosing::LoopCloser::kMapExtension), impl_->map);
  if (directPoints) impl_->directFrontEnd->restore(std::move(directHosts));
}

void System::setMappingEnabled(bool enabled) {
  mappingEnabled_ = enabled;
  if (!impl_) return;
  impl_->waitForMapping();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  impl_->mappingEnabled = enabled;
  impl_->tracker->setMapUpdatesEnabled(enabled);
}

void System::reset() {
  if (!impl_) return;
  impl_->waitForMapping();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  impl_->tracker->reset();
  impl_->mapper->reset();
  if (impl_->directFrontEnd) impl_->directFrontEnd->reset();
  if (impl_->lineFrontEnd) impl_->lineFrontEnd->reset();
  if (impl_->refiner) impl_->refiner->reset();
  impl_->newGeneration();
  impl_->counters.initializedAtFrame = -1;
}

StageTimings System::timings() const {
  StageTimings all;
  if (!impl_) return all;
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  all = impl_->trackingTimings;
  for (const auto& [stage, samples] : impl_->mappingTimings.samples())
    for (double v : samples) all.add(stage, v);
  return all;
}

nlohmann::json System::mappingLog() const {
  if (!impl_) return nlohmann::json::array();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  return impl_->mappingLog;
}

nlohmann::json System::loops() const {
  if (!impl_) return nlohmann::json::array();
  std::lock_guard<std::mutex> mk(impl_->mapMutex);
  return impl_->loops;
}

nlohmann::json System::summary() const {
  Counters c;
  std::size_t keyFrames = 0, mapPoints = 0;
  nlohmann::json direct = {{"direct_points", 0}, {"direct_active", 0}, {"direct_hosts", 0}};
  std::size_t lineCount = 0;
  if (impl_) {
    std::lock_guard<std::mutex> mk(impl_->mapMutex);
    c = impl_->counters;
    keyFrames = impl_->map.numKeyFrames();
    mapPoints = impl_->map.numMapPoints();
    if (impl_->directFrontEnd) direct = impl_->directFrontEnd->summary();
    if (impl_->lineFrontEnd) lineCount = impl_->lineFrontEnd->numLines();
  }
  return {{"frames_processed", c.frames},
          {"frames_tracked", c.tracked},
          {"frames_lost", c.lost},
          {"relocalizations", c.relocalizations},
          {"relocalizations_withdrawn", c.relocalizationsWithdrawn},
          {"initialized", c.initializedAtFrame >= 0},
          {"initialized_at_frame", c.initializedAtFrame},
          {"keyframes", keyFrames},
          {"map_points", mapPoints},
          {"resets", c.resets},
          {"loops_closed", c.loopsClosed},
          {"loops_withdrawn", c.loopsWithdrawn},
          {"direct_points", direct["direct_points"]},
          {"direct_active", direct["direct_active"]},
          {"manhattan_frames", c.manhattanFrames},
          {"manhattan_tracked", c.manhattanTracked},
          {"fallback_tracked", c.fallbackTracked},
          {"lines", lineCount}};
}

datasets::RawlogChannels System::channelsUsed(const SlamParams& params) {
  datasets::RawlogChannels c;
  c.depth = false;
  c.semantic = params.pointModel.semantic;
  c.normals = params.manhattan.enabled;  // Impl builds the Manhattan tracker exactly then
  return c;
}

nlohmann::json System::report() const {
  nlohmann::json r;
  r["config"] = params_.toIniText();
  r["seed"] = options_.seed;
  r["mode"] = threaded_ ? "threaded" : "sequential";
  r["mapping_enabled"] = mappingEnabled_;
  r["pose_solver"] = params_.system.poseSolver;
  r["map_initializer"] = params_.system.initializer;
  r["summary"] = summary();
  if (impl_) {
    const geometry::PinholeCamera& cam = impl_->camera;
    r["camera"] = {{"fx", cam.fx}, {"fy", cam.fy}, {"cx", cam.cx}, {"cy", cam.cy},
                   {"width", cam.width}, {"height", cam.height}};
    r["point_policy"] = impl_->mapper->pointUsePolicy()->name();
    r["timings"] = timings().summary();
    r["mapping"] = mappingLog();
    r["loops"] = loops();
    std::lock_guard<std::mutex> mk(impl_->mapMutex);
    r["global_ba"] = impl_->globalBaLog;
    r["frames"] = impl_->frames;
  } else {
    r["frames"] = nlohmann::json::array();
  }
  return r;
}

}  // namespace pslam::system
