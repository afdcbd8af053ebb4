#include "pslam/apps/SlamRunApp.h"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/core/AtomicFile.h"
#include "pslam/system/System.h"

namespace pslam::apps {

namespace {

/// The map-point depths of every keyframe, in the format `slam-eval --depths` reads (timestamp u v depth, see
/// pslam/eval/DepthRatio.h): one line per keyframe observation of a good point, depth along the keyframe's
/// optical axis in the map's units. The pixel is the undistorted keypoint (equal to the image pixel for the
/// rectified and synthetic cameras DR is evaluated on).
void writeMapPointDepths(const map::Map& map, const AtomicOutput& output) {
  writeOutputFile(output, [&](std::ostream& os) {
    os << "# slam-run: map-point depths per keyframe observation (slam-eval --depths)\n# timestamp u v depth\n";
    os << std::setprecision(17);
    for (const auto& [kfId, kf] : map.keyFrames())
      for (std::size_t k = 0; k < kf.mapPointIds.size(); ++k) {
        const map::MapPointId id = kf.mapPointIds[k];
        if (id == map::kNoMapPoint || !map.hasMapPoint(id) || map.mapPoint(id).bad) continue;
        const double z = (kf.T_cam_world * map.worldPosition(id)).z();
        if (!(z > 0) || !std::isfinite(z)) continue;
        const Eigen::Vector2d uv = kf.pixel(k);
        os << kf.timestamp << ' ' << std::setprecision(9) << uv.x() << ' ' << uv.y() << ' ' << z
           << std::setprecision(17) << '\n';
      }
  });
}

}  // namespace

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

SlamRunSummary SlamRunApp::run() {
  const auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = system::processCpuSeconds();
  require(!options_.outDir.empty(), "slam-run", "no output folder given");
  require(options_.last < 0 || options_.last >= static_cast<long long>(options_.first), "slam-run",
          "--last " + std::to_string(options_.last) + " is before --first " + std::to_string(options_.first));
  const system::SlamParams params = system::loadSlamParams(options_.config.string(), options_.overrides);
  require(std::filesystem::is_regular_file(options_.rawlog), options_.rawlog.string(), "rawlog not found");

  // All outputs are prepared before the run (none may be an input or replace a folder) and committed together.
  std::vector<std::filesystem::path> inputs = datasets::RawlogWriter::inputFilesOf(options_.rawlog);
  inputs.push_back(options_.config);
  OutputSet outputs(inputs);
  AtomicOutput& trajectoryOut = outputs.add(options_.outDir / "trajectory.txt");
  AtomicOutput& keyFramesOut = outputs.add(options_.outDir / "keyframes.txt");
  AtomicOutput& mapOut = outputs.add(options_.outDir / "map.slammap");
  AtomicOutput& depthsOut = outputs.add(options_.outDir / "depths.txt");
  AtomicOutput& reportOut = outputs.add(options_.outDir / "report.json");

  const std::size_t total = datasets::RawlogReader::countFrames(options_.rawlog);
  require(total > 0, options_.rawlog.string(), "rawlog has no CAMERA frame");
  datasets::RawlogReader reader(options_.rawlog);

  system::SystemOptions so;
  so.seed = options_.seed;
  if (options_.threaded) so.threaded = true;
  system::System slam(params, so);

  SlamRunSummary sum;
  const std::size_t lastIndex = options_.last < 0 ? total - 1 : std::min<std::size_t>(options_.last, total - 1);
  const std::size_t toProcess = options_.first <= lastIndex ? lastIndex - options_.first + 1 : 0;
  Progress progress("slam-run", toProcess, options_.progress);

  datasets::Frame input;
  while (reader.next(input)) {
    ++sum.framesRead;
    if (input.index < options_.first) continue;
    if (input.index > lastIndex) break;
    system::TrackResult r;
    try {
      r = slam.track(input);
    } catch (const Error& e) {
      throw Error(options_.rawlog.string() + ": " + e.what());
    }
    ++sum.framesProcessed;
    progress.update(sum.framesProcessed, std::string(tracking::toString(r.status)) + " kf " +
                                             std::to_string(r.report.keyFrames) + " pts " +
                                             std::to_string(r.report.mapPoints));
  }
  require(sum.framesProcessed > 0 || sum.framesRead == 0, options_.rawlog.string(),
          "no frame in the range [" + std::to_string(options_.first) + ", " + std::to_string(lastIndex) + "]");
  slam.finish();

  // ---- outputs
  const nlohmann::json counts = slam.summary();
  sum.framesTracked = counts["frames_tracked"];
  sum.framesLost = counts["frames_lost"];
  sum.relocalizations = counts["relocalizations"];
  sum.initializedAtFrame = counts["initialized_at_frame"];
  sum.keyFrames = counts["keyframes"];
  sum.mapPoints = counts["map_points"];
  sum.resets = counts["resets"];

  writeTumTrajectory(trajectoryOut.tempPath(), slam.trajectory(), "slam-run: every tracked frame, T_world_cam");
  writeTumTrajectory(keyFramesOut.tempPath(), slam.keyFrameTrajectory(), "slam-run: keyframes, T_world_cam");
  slam.saveMap(mapOut.tempPath());
  writeMapPointDepths(slam.mapSnapshot(), depthsOut);
  sum.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  sum.cpuSeconds = system::processCpuSeconds() - cpu0;

  nlohmann::json report = slam.report();
  report["tool"] = "slam-run";
  report["rawlog"] = options_.rawlog.string();
  report["config_file"] = options_.config.string();
  report["overrides"] = options_.overrides;
  report["first"] = options_.first;
  report["last"] = lastIndex;
  report["summary"] = sum.toJson();
  if (!sum.initialized()) report["warning"] = "initialization never succeeded: the trajectory is empty";
  writeOutputFile(reportOut, [&](std::ostream& os) { os << report.dump(1) << "\n"; });
  outputs.commit();
  progress.finish(sum.toText());
  return sum;
}

}  // namespace pslam::apps
