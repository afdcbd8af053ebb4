#include "pslam/system/SlamRunApp.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/map/MapIO.h"
#include "pslam/system/SlamSystem.h"

namespace pslam::system {

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

nlohmann::json SlamRunSummary::toJson() const {
  return {{"frames_read", framesRead},
          {"frames_processed", framesProcessed},
          {"frames_tracked", framesTracked},
          {"frames_lost", framesLost},
          {"relocalizations", relocalizations},
          {"initialized", initialized()},
          {"initialized_at_frame", initializedAtFrame},
          {"keyframes", keyFrames},
          {"map_points", mapPoints},
          {"resets", resets},
          {"wall_seconds", wallSeconds},
          {"cpu_seconds", cpuSeconds}};
}

std::string SlamRunSummary::toText() const {
  std::ostringstream os;
  os << "frames " << framesProcessed << ", tracked " << framesTracked << ", lost " << framesLost
     << ", relocalizations " << relocalizations << ", initialized at "
     << (initialized() ? std::to_string(initializedAtFrame) : std::string("never")) << ", keyframes " << keyFrames
     << ", map points " << mapPoints << ", resets " << resets << ", wall " << std::fixed << std::setprecision(2)
     << wallSeconds << " s, cpu " << cpuSeconds << " s";
  return os.str();
}

SlamRunApp::SlamRunApp(SlamRunOptions options) : options_(std::move(options)) {}

namespace {
struct TrackedPose {
  double timestamp;
  int generation;
  map::KeyFrameId reference;
  Eigen::Isometry3d T_cam_ref;    ///< relative to the reference keyframe at tracking time
  Eigen::Isometry3d T_cam_world;  ///< as tracked (fallback when the reference keyframe is gone)
};
}  // namespace

SlamRunSummary SlamRunApp::run() {
  const auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = processCpuSeconds();
  require(!options_.outDir.empty(), "slam-run", "no output folder given");
  require(options_.last < 0 || options_.last >= static_cast<long long>(options_.first), "slam-run",
          "--last " + std::to_string(options_.last) + " is before --first " + std::to_string(options_.first));
  SlamParams params = loadSlamParams(options_.config.string());
  if (options_.threaded) params.system.threaded = true;
  require(std::filesystem::is_regular_file(options_.rawlog), options_.rawlog.string(), "rawlog not found");

  const std::size_t total = datasets::RawlogReader::countFrames(options_.rawlog);
  require(total > 0, options_.rawlog.string(), "rawlog has no CAMERA frame");
  datasets::RawlogReader reader(options_.rawlog);
  std::filesystem::create_directories(options_.outDir);

  std::unique_ptr<SlamSystem> slam;
  geometry::PinholeCamera camera;
  std::vector<TrackedPose> poses;
  nlohmann::json frames = nlohmann::json::array();
  SlamRunSummary sum;
  const std::size_t lastIndex = options_.last < 0 ? total - 1 : std::min<std::size_t>(options_.last, total - 1);
  const std::size_t toProcess = options_.first <= lastIndex ? lastIndex - options_.first + 1 : 0;
  Progress progress("slam-run", toProcess, options_.progress);
  int lastGeneration = 0;

  datasets::Frame input;
  while (reader.next(input)) {
    ++sum.framesRead;
    if (input.index < options_.first) continue;
    if (input.index > lastIndex) break;
    const std::string ctx = options_.rawlog.string() + ": frame " + std::to_string(input.index);
    require(!input.image.empty(), ctx, "CAMERA image is empty");
    if (!slam) {
      try {
        camera = geometry::PinholeCamera::fromTCamera(input.camera);
      } catch (const std::exception& e) {
        throw Error(ctx + ": invalid or missing CAMERA intrinsics: " + e.what());
      }
      require(camera.width == input.image.cols && camera.height == input.image.rows, ctx,
              "intrinsics resolution " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                  " differs from the image " + std::to_string(input.image.cols) + "x" + std::to_string(input.image.rows));
      slam = std::make_unique<SlamSystem>(params, camera, options_.seed, params.system.threaded);
    }
    require(input.image.cols == camera.width && input.image.rows == camera.height, ctx,
            "image size changed to " + std::to_string(input.image.cols) + "x" + std::to_string(input.image.rows) +
                " (first frame: " + std::to_string(camera.width) + "x" + std::to_string(camera.height) + ")");
    const tracking::Tracker::Result r = slam->processFrame(input);
    ++sum.framesProcessed;
    if (r.mapWasReset) ++sum.resets;
    const int gen = slam->mapGeneration();
    lastGeneration = gen;
    if (r.initialReferencePose) {
      if (sum.initializedAtFrame < 0 || r.mapWasReset) sum.initializedAtFrame = static_cast<long long>(input.index);
      const map::Map& m = slam->map();
      const map::KeyFrameId root = m.rootKeyFrame();
      poses.push_back({r.initialReferencePose->first, gen, root, Eigen::Isometry3d::Identity(),
                       r.initialReferencePose->second});
    }
    if (r.report.status == tracking::FrameStatus::Lost) ++sum.framesLost;
    if (r.report.status == tracking::FrameStatus::Relocalized) ++sum.relocalizations;
    if (r.hasPose) {
      ++sum.framesTracked;
      Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();
      map::KeyFrameId ref = r.referenceKeyFrame;
      if (!params.system.threaded && ref != map::kNoKeyFrame && slam->map().hasKeyFrame(ref))
        T_cam_ref = r.T_cam_world * slam->map().keyFrame(ref).T_world_cam();
      else
        ref = map::kNoKeyFrame;  // threaded: the keyframe pose may change concurrently; keep the tracked pose
      poses.push_back({input.timestamp, gen, ref, T_cam_ref, r.T_cam_world});
    }
    frames.push_back(r.report.toJson());
    progress.update(sum.framesProcessed, std::string(tracking::toString(r.report.status)) + " kf " +
                                             std::to_string(r.report.keyFrames) + " pts " +
                                             std::to_string(r.report.mapPoints));
  }
  require(sum.framesProcessed > 0 || sum.framesRead == 0, options_.rawlog.string(),
          "no frame in the range [" + std::to_string(options_.first) + ", " + std::to_string(lastIndex) + "]");
  if (slam) slam->finish();

  // ---- outputs
  Trajectory trajectory, keyframes;
  if (slam) {
    const map::Map& m = slam->map();
    for (const TrackedPose& p : poses) {
      if (p.generation != lastGeneration) continue;  // poses of a map discarded by a reset
      Eigen::Isometry3d T_cam_world = p.T_cam_world;
      // The reference keyframe may have been culled since: its pose then follows its spanning-tree parent.
      if (p.reference != map::kNoKeyFrame)
        if (const auto T_ref_world = m.keyFramePoseIncludingErased(p.reference)) T_cam_world = p.T_cam_ref * *T_ref_world;
      trajectory.emplace_back(p.timestamp, T_cam_world.inverse());
    }
    std::stable_sort(trajectory.begin(), trajectory.end(),
                     [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
    for (const auto& [id, kf] : m.keyFrames()) keyframes.emplace_back(kf.timestamp, kf.T_world_cam());
    sum.keyFrames = m.numKeyFrames();
    sum.mapPoints = m.numMapPoints();
  }
  sum.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  sum.cpuSeconds = processCpuSeconds() - cpu0;

  writeTumTrajectory(options_.outDir / "trajectory.txt", trajectory, "slam-run: every tracked frame, T_world_cam");
  writeTumTrajectory(options_.outDir / "keyframes.txt", keyframes, "slam-run: keyframes, T_world_cam");
  map::saveMap(slam ? slam->map() : map::Map(), options_.outDir / "map.slammap");

  nlohmann::json report;
  report["tool"] = "slam-run";
  report["rawlog"] = options_.rawlog.string();
  report["config_file"] = options_.config.string();
  report["config"] = params.toIniText();
  report["seed"] = options_.seed;
  report["mode"] = params.system.threaded ? "threaded" : "sequential";
  report["local_mapper"] = slam ? slam->mapperName() : "";
  if (slam) report["local_mapper_config"] = slam->mapperConfig();
  report["first"] = options_.first;
  report["last"] = lastIndex;
  if (slam) {
    report["camera"] = {{"fx", camera.fx}, {"fy", camera.fy}, {"cx", camera.cx}, {"cy", camera.cy},
                        {"width", camera.width}, {"height", camera.height}};
    report["timings"] = slam->timings().summary();
  }
  report["summary"] = sum.toJson();
  report["frames"] = frames;
  if (slam) report["mapping"] = slam->mappingLog();
  if (!sum.initialized())
    report["warning"] = "initialization never succeeded: the trajectory is empty";
  writeFileAtomically(options_.outDir / "report.json", [&](std::ostream& os) { os << report.dump(1) << "\n"; });
  progress.finish(sum.toText());
  return sum;
}

}  // namespace pslam::system
