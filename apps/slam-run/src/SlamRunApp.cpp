#include "pslam/apps/SlamRunApp.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <thread>
#include <utility>

#include "pslam/core/Error.h"
#include "pslam/core/Progress.h"
#include "pslam/core/Trajectory.h"
#include "pslam/eval/Plot.h"
#include "pslam/datasets/PrefetchingRawlogReader.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/core/AtomicFile.h"
#include "pslam/map/MapIO.h"
#include "pslam/system/RunReport.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"
#include "pslam/tracking/Frame.h"

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

/// The camera of a rawlog frame as System::track() takes it (intrinsics checked against the image size).
geometry::PinholeCamera cameraOfFrame(const datasets::Frame& f, const std::filesystem::path& rawlog) {
  const std::string ctx = rawlog.string() + ": frame " + std::to_string(f.index);
  geometry::PinholeCamera cam;
  try {
    cam = geometry::PinholeCamera::fromTCamera(f.camera);
    cam.check();
  } catch (const std::exception& e) {
    throw Error(ctx + ": invalid or missing CAMERA intrinsics: " + oneLineMessage(e));
  }
  require(cam.width == f.image.cols && cam.height == f.image.rows, ctx,
          "intrinsics resolution " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
              " differs from the image " + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows));
  return cam;
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
          {"map_loaded", mapLoaded},
          {"localization", localization},
          {"loaded_keyframes", loadedKeyFrames},
          {"loaded_map_points", loadedMapPoints},
          {"frames_localized", framesLocalized},
          {"frames_not_localized", framesProcessed - framesLocalized},
          {"localized_share", framesProcessed > 0 ? double(framesLocalized) / double(framesProcessed) : 0.0},
          {"first_localized_frame", firstLocalizedFrame},
          {"frames_late", framesLate},
          {"max_lateness_seconds", maxLatenessSeconds},
          {"realtime_waits_cut", waitsCut},
          {"warnings", warnings},
          {"wall_seconds", wallSeconds},
          {"cpu_seconds", cpuSeconds},
          {"frames_wall_seconds", framesWallSeconds},
          {"frames_cpu_seconds", framesCpuSeconds},
          {"outputs_wall_seconds", outputsWallSeconds}};
}

std::string SlamRunSummary::toText() const {
  std::ostringstream os;
  os << "frames " << framesProcessed << ", tracked " << framesTracked << ", lost " << framesLost
     << ", relocalizations " << relocalizations;
  if (mapLoaded)
    os << ", localized " << framesLocalized << "/" << framesProcessed << " in the loaded map ("
       << loadedKeyFrames << " keyframes, " << (localization ? "localization only" : "mapping on") << ")";
  else
    os << ", initialized at " << (initialized() ? std::to_string(initializedAtFrame) : std::string("never"));
  os << ", keyframes " << keyFrames
     << ", map points " << mapPoints << ", resets " << resets << ", wall " << std::fixed << std::setprecision(2)
     << wallSeconds << " s, cpu " << cpuSeconds << " s";
  return os.str();
}

namespace {
void plotManhattanModes(const nlohmann::json& frames, const std::filesystem::path& png) {
  // One row per outcome over the frame index: Manhattan path (2), 6-DoF fallback (1), no pose (0).
  std::vector<double> xm, ym, xf, yf, xn, yn;
  for (const auto& f : frames) {
    const double i = f["index"].get<double>();
    const bool tracked = f["status"] == "tracking" || f["status"] == "relocalized";
    const std::string mode = f["manhattan"]["mode"];
    if (tracked && mode == "manhattan") {
      xm.push_back(i);
      ym.push_back(2);
    } else if (tracked) {
      xf.push_back(i);
      yf.push_back(1);
    } else {
      xn.push_back(i);
      yn.push_back(0);
    }
  }
  eval::Plot plot("tracking path per frame (2 = Manhattan rotation, 1 = 6-DoF fallback, 0 = no pose)", "frame",
                  "path");
  plot.style().height = 360;
  plot.setYRange(-0.5, 2.5);
  plot.addScatter(xm, ym, "Manhattan (" + std::to_string(xm.size()) + ")", eval::colors::green(), 3);
  plot.addScatter(xf, yf, "fallback (" + std::to_string(xf.size()) + ")", eval::colors::orange(), 3);
  plot.addScatter(xn, yn, "no pose (" + std::to_string(xn.size()) + ")", eval::colors::red(), 3);
  plot.save(png);
}
}  // namespace

SlamRunApp::SlamRunApp(SlamRunOptions options) : options_(std::move(options)) {}

SlamRunSummary SlamRunApp::run() {
  const auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = system::processCpuSeconds();
  require(!options_.outDir.empty(), "slam-run", "no output folder given");
  require(options_.last < 0 || options_.last >= static_cast<long long>(options_.first), "slam-run",
          "--last " + std::to_string(options_.last) + " is before --first " + std::to_string(options_.first));
  require(!options_.localization || !options_.mapIn.empty(), "--localization",
          "needs --map-in (the map to localize in)");
  const system::SlamParams params = system::loadSlamParams(options_.config.string(), options_.overrides);
  require(std::filesystem::is_regular_file(options_.rawlog), options_.rawlog.string(), "rawlog not found");

  // All outputs are prepared before the run (none may be an input or replace a folder) and committed together.
  std::vector<std::filesystem::path> inputs = datasets::RawlogWriter::inputFilesOf(options_.rawlog);
  inputs.push_back(options_.config);
  if (!options_.mapIn.empty()) inputs.push_back(options_.mapIn);  // never replaced by the map written
  OutputSet outputs(inputs);
  AtomicOutput& trajectoryOut = outputs.add(options_.outDir / "trajectory.txt");
  AtomicOutput& keyFramesOut = outputs.add(options_.outDir / "keyframes.txt");
  AtomicOutput& mapOut = outputs.add(options_.outDir / "map.slammap");
  AtomicOutput& depthsOut = outputs.add(options_.outDir / "depths.txt");
  AtomicOutput& reportOut = outputs.add(options_.outDir / "report.json");
  // §4.4: which path tracked each frame (a picture of where the Manhattan rotation held and where it did not).
  AtomicOutput* modesOut = params.manhattan.enabled ? &outputs.add(options_.outDir / "manhattan_modes.png") : nullptr;

  // The frame count serves only the progress line's total. Counting decodes the whole rawlog before the first frame
  // (seconds for one that embeds a depth image per frame), so a run without progress output does not count: its
  // range ends where the rawlog does (0: not counted).
  // A rawlog without frames is refused after the reading loop, counted or not.
  const std::size_t total = options_.progress ? datasets::RawlogReader::countFrames(options_.rawlog) : 0;

  // A map to start from is read and checked before any frame (errors name the file).
  std::optional<map::Map> loaded;
  SlamRunSummary sum;
  if (!options_.mapIn.empty()) {
    loaded = map::loadMap(options_.mapIn);
    require(loaded->numKeyFrames() > 0, options_.mapIn.string(), "map has no keyframe: nothing to localize in");
    sum.mapLoaded = true;
    sum.localization = options_.localization;
    sum.loadedKeyFrames = loaded->numKeyFrames();
    sum.loadedMapPoints = loaded->numMapPoints();
  }

  system::SystemOptions so;
  so.seed = options_.seed;
  if (options_.threaded) so.threaded = true;
  // Made now to check the parameters; with a map it is made again at the first frame, with the rawlog's camera.
  std::optional<system::System> slam;
  slam.emplace(params, so);
  if (loaded && !loaded->vocabulary().empty() && loaded->vocabulary() != slam->vocabularyFingerprint())
    sum.vocabularyWarning = options_.mapIn.string() + ": the map was built with the vocabulary '" +
                            loaded->vocabulary() + "', this run uses " +
                            (slam->vocabularyFingerprint().empty() ? std::string("none")
                                                                   : "'" + slam->vocabularyFingerprint() + "'") +
                            ": keyframes are indexed with this run's, place recognition may differ";

  if (loaded) {
    // The map's camera must be the rawlog's (the map stores undistorted intrinsics; the run keeps the rawlog's
    // distortion model). Checked on the rawlog's first frame, and the System made with that camera, before the
    // frames are read ahead (no MRPT deserialization runs next to the reading thread).
    datasets::RawlogReader firstReader(options_.rawlog, {},
                                       options_.sortStamps ? datasets::StampOrder::sort : datasets::StampOrder::strict);
    datasets::Frame first;
    require(firstReader.next(first), options_.rawlog.string(), "rawlog has no CAMERA frame");
    const geometry::PinholeCamera cam = cameraOfFrame(first, options_.rawlog);
    const geometry::PinholeCamera mapCamera = loaded->keyFrames().begin()->second.camera;
    require(cam.withoutDistortion() == mapCamera, options_.mapIn.string(),
            "map camera (" + mapCamera.describe() + ") differs from the camera of " + options_.rawlog.string() +
                " (" + cam.withoutDistortion().describe() + ")");
    so.camera = cam;
    slam.emplace(params, so);
    slam->setMappingEnabled(!options_.localization);
    slam->setMap(std::move(*loaded), options_.mapIn.string());
    loaded.reset();
  }
  // Frames are read and decoded a few ahead, in a thread of their own, while the current one is tracked; only the
  // channels the System uses are decoded (slam-eval reads DEPTH itself for the depth ratio).
  datasets::PrefetchingRawlogReader reader(options_.rawlog, 3, system::System::channelsUsed(params),
                                           options_.sortStamps ? datasets::StampOrder::sort
                                                               : datasets::StampOrder::strict);
  sum.warnings = reader.warnings();

  const std::size_t lastAsked =
      options_.last < 0 ? std::numeric_limits<std::size_t>::max() : static_cast<std::size_t>(options_.last);
  const std::size_t lastCounted = total > 0 ? std::min(lastAsked, total - 1) : lastAsked;
  const std::size_t toProcess =
      total > 0 && options_.first <= lastCounted ? lastCounted - options_.first + 1 : 0;  // 0: unknown
  Progress progress("slam-run", toProcess, options_.progress);

  datasets::Frame input;
  std::optional<std::chrono::steady_clock::time_point> realtimeStart;  // --realtime: wall time of the first frame
  double firstTimestamp = 0.0, previousStamp = 0.0;
  std::vector<bool> localized;            // per processed frame: has a pose in the map
  std::vector<std::size_t> localizedIndex;  // its rawlog index
  const auto framesWall0 = std::chrono::steady_clock::now();
  const double framesCpu0 = system::processCpuSeconds();
  while (reader.next(input)) {
    ++sum.framesRead;
    if (input.index < options_.first) continue;
    if (input.index > lastAsked) break;
    if (options_.realtime) {
      // The camera's clock: frame t is due at start + (t - t_first); waiting for it leaves the mapping thread
      // the time between frames, as live.
      const auto now = std::chrono::steady_clock::now();
      if (!realtimeStart) {
        realtimeStart = now;
        firstTimestamp = previousStamp = input.timestamp;
      }
      auto due = *realtimeStart + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(input.timestamp - firstTimestamp));
      const auto longest = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(options_.realtimeMaxWait));
      if (due - now > longest) {
        // A gap in the stamps longer than any wait we make (a clock jump, a pause in the recording): wait the bound,
        // then go on from there, so that the frames after it keep their pace.
        if (sum.waitsCut++ == 0) {
          char buf[200];
          std::snprintf(buf, sizeof buf, "frame %zu: its stamp is %.3f s after the previous frame's; --realtime waited "
                        "%.3f s (--realtime-max-wait) and went on from there", input.index,
                        input.timestamp - previousStamp, options_.realtimeMaxWait);
          sum.warnings.push_back(options_.rawlog.string() + ": " + buf);
        }
        *realtimeStart -= (due - now) - longest;
        due = now + longest;
      }
      previousStamp = input.timestamp;
      if (now < due) {
        std::this_thread::sleep_until(due);
      } else if (now > due) {
        ++sum.framesLate;
        sum.maxLatenessSeconds = std::max(sum.maxLatenessSeconds, std::chrono::duration<double>(now - due).count());
      }
    }
    system::FrameResult r;
    try {
      r = slam->track(input);
    } catch (const Error& e) {
      throw Error(options_.rawlog.string() + ": " + e.what());
    }
    // A withdrawn relocalization takes back the poses of the frames before this one.
    for (std::size_t k = localized.size() - std::min(r.retractedFrames, localized.size()); k < localized.size(); ++k)
      localized[k] = false;
    localized.push_back(r.pose.has_value());
    localizedIndex.push_back(input.index);
    ++sum.framesProcessed;
    progress.update(sum.framesProcessed, std::string(system::toString(r.state)) + " kf " +
                                             std::to_string(r.keyFrames) + " pts " + std::to_string(r.mapPoints));
  }
  reader.stop();  // before the outputs: saving the map serializes with MRPT too
  for (std::size_t k = 0; k < localized.size(); ++k) {
    if (!localized[k]) continue;
    ++sum.framesLocalized;
    if (sum.firstLocalizedFrame < 0) sum.firstLocalizedFrame = static_cast<long long>(localizedIndex[k]);
  }
  require(sum.framesRead > 0, options_.rawlog.string(), "rawlog has no CAMERA frame");
  // The range's last frame: the one asked for, or the rawlog's last (the reader stopped after the range or at the
  // end of the rawlog, whose frames are numbered from 0).
  const std::size_t lastIndex = std::min(lastAsked, sum.framesRead - 1);
  require(sum.framesProcessed > 0, options_.rawlog.string(),
          "no frame in the range [" + std::to_string(options_.first) + ", " + std::to_string(lastIndex) + "]");
  system::System& slamRef = *slam;
  slamRef.finish();
  const auto outputsWall0 = std::chrono::steady_clock::now();
  sum.framesWallSeconds = std::chrono::duration<double>(outputsWall0 - framesWall0).count();
  sum.framesCpuSeconds = system::processCpuSeconds() - framesCpu0;

  // ---- outputs
  const system::RunSummary runSummary = slamRef.summary();
  const nlohmann::json counts = system::toJson(runSummary);
  sum.framesTracked = runSummary.framesTracked;
  sum.framesLost = runSummary.framesLost;
  sum.relocalizations = runSummary.relocalizations;
  sum.initializedAtFrame = counts["initialized_at_frame"];
  sum.keyFrames = runSummary.keyFrames;
  sum.mapPoints = runSummary.mapPoints;
  sum.resets = runSummary.resets;

  writeTumTrajectory(trajectoryOut.tempPath(), system::toTrajectory(slamRef.trajectory()),
                     "slam-run: every tracked frame, T_world_cam");
  writeTumTrajectory(keyFramesOut.tempPath(), system::toTrajectory(slamRef.keyFrameTrajectory()),
                     "slam-run: keyframes, T_world_cam");
  // One copy of the map serves both outputs (System::saveMap would take another).
  map::Map finalMap = slamRef.mapSnapshot();
  writeMapPointDepths(finalMap, depthsOut);
  map::saveMap(std::move(finalMap), mapOut.tempPath());
  const auto outputsWall1 = std::chrono::steady_clock::now();
  sum.outputsWallSeconds = std::chrono::duration<double>(outputsWall1 - outputsWall0).count();
  sum.wallSeconds = std::chrono::duration<double>(outputsWall1 - wall0).count();
  sum.cpuSeconds = system::processCpuSeconds() - cpu0;

  nlohmann::json report = system::runReport(slamRef);
  report["tool"] = "slam-run";
  report["map_in"] = options_.mapIn.string();
  report["localization"] = options_.localization;
  nlohmann::json& frames = report["frames"];
  if (frames.size() == localized.size())
    for (std::size_t i = 0; i < localized.size(); ++i) frames[i]["localized"] = static_cast<bool>(localized[i]);
  report["rawlog"] = options_.rawlog.string();
  report["config_file"] = options_.config.string();
  report["overrides"] = options_.overrides;
  report["first"] = options_.first;
  report["last"] = lastIndex;
  report["summary"] = sum.toJson();
  for (const auto& [key, value] : counts.items())  // the System's counters the app summary does not repeat
    if (!report["summary"].contains(key)) report["summary"][key] = value;
  if (modesOut) plotManhattanModes(frames, modesOut->tempPath());
  if (!sum.vocabularyWarning.empty()) report["vocabulary_warning"] = sum.vocabularyWarning;
  if (!sum.hasMap()) report["warning"] = "initialization never succeeded: the trajectory is empty";
  else if (sum.mapLoaded && sum.framesLocalized == 0) report["warning"] = "no frame was localized in the loaded map";
  writeOutputFile(reportOut, [&](std::ostream& os) { os << report.dump(1) << "\n"; });
  outputs.commit();
  progress.finish(sum.toText());
  return sum;
}

}  // namespace pslam::apps
