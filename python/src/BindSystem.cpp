// priorslam.System: the System façade (libs/system/include/pslam/system/System.h) and its FrameResult.
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "Common.h"
#include "pslam/core/Error.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/system/RunReport.h"
#include "pslam/system/SlamParams.h"
#include "pslam/system/System.h"

namespace pslam::python {

namespace {

using system::FrameResult;

/// "Section.key=value" strings from a dict {"Section.key": value} or a list of such strings.
std::vector<std::string> overridesFrom(const py::handle& overrides) {
  std::vector<std::string> out;
  if (overrides.is_none()) return out;
  if (py::isinstance<py::dict>(overrides)) {
    for (const auto& [key, value] : overrides.cast<py::dict>()) {
      std::string text;
      if (py::isinstance<py::bool_>(value)) text = value.cast<bool>() ? "true" : "false";
      else if (value.is_none()) text = "";
      else text = py::str(value).cast<std::string>();
      out.push_back(py::str(key).cast<std::string>() + "=" + text);
    }
    return out;
  }
  if (py::isinstance<py::str>(overrides)) throw Error("overrides: expected a dict or a list of 'Section.key=value'");
  for (const py::handle& o : overrides) out.push_back(py::str(o).cast<std::string>());
  return out;
}

std::vector<std::string> channelNames(const datasets::RawlogChannels& c) {
  std::vector<std::string> names;
  if (c.depth) names.emplace_back("depth");
  if (c.semantic) names.emplace_back("semantic");
  if (c.normals) names.emplace_back("normals");
  return names;
}

/// The System behind a Python object. Every call runs without the GIL, one at a time (the façade is not meant
/// for concurrent calls): other Python threads run while a frame is tracked, and a second thread's call waits.
class PySystem {
 public:
  PySystem(const std::filesystem::path& config, std::vector<std::string> overrides, system::SystemOptions options)
      : system_(std::make_unique<system::System>(config, overrides, std::move(options))) {}
  /// Without the GIL question: PySystemDeleter ends the System through close() first when it holds the GIL.
  ~PySystem() = default;

  /// Runs f(System&) without the GIL and with the System to itself, then drops the array references that
  /// Mats released meanwhile.
  template <class F>
  auto call(F&& f) {
    struct Drain {
      ~Drain() { releaseParkedArrays(); }
    } drain;  // runs after the GIL is taken back
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!system_) throw Error("System: closed");
    return f(*system_);
  }

  /// Ends the System (threaded mode: its mapping thread) now rather than when Python collects the object.
  void close() {
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      system_.reset();
    }
    releaseParkedArrays();
  }

 private:
  std::mutex mutex_;
  std::unique_ptr<system::System> system_;
};

/// The System is destroyed without the GIL: its mapping thread may be finishing a keyframe.
struct PySystemDeleter {
  void operator()(PySystem* s) const {
    if (Py_IsInitialized() && PyGILState_Check()) {
      s->close();
    }
    delete s;
  }
};

}  // namespace

void bindSystem(py::module_& m) {
  py::class_<FrameResult>(m, "FrameResult", "What System.track() tells about one frame.")
      .def_readonly("index", &FrameResult::index, "the frame's index (the rawlog's, or the count of frames so far)")
      .def_readonly("timestamp", &FrameResult::timestamp, "seconds")
      .def_property_readonly(
          "state", [](const FrameResult& r) { return std::string(system::toString(r.state)); },
          "'initializing', 'tracking', 'lost' or 'relocalized' (as report.json)")
      .def_property_readonly(
          "pose", [](const FrameResult& r) -> py::object { return r.pose ? py::object(poseMatrix(*r.pose)) : py::none(); },
          "T_world_cam as a 4x4 array when the frame has a pose (tracked, relocalized, or the initializing frame), "
          "else None")
      .def_property_readonly("tracked", [](const FrameResult& r) { return r.pose.has_value(); },
                             "the frame has a pose")
      .def_readonly("keyframe", &FrameResult::keyFrame, "the frame became a keyframe")
      .def_readonly("map_was_reset", &FrameResult::mapWasReset,
                    "the tracker discarded the map (lost too early) and re-initializes")
      .def_readonly("retracted_frames", &FrameResult::retractedFrames,
                    "> 0: lost right after a relocalization; the poses of that many previous frames are withdrawn")
      .def_readonly("method", &FrameResult::method,
                    "initializer / motion / reference / relocalization / manhattan")
      .def_readonly("matches", &FrameResult::matches, "after the motion / reference / relocalization search")
      .def_readonly("inliers", &FrameResult::inliers, "after local-map tracking")
      .def_readonly("manhattan_mode", &FrameResult::manhattanMode, "'manhattan', 'fallback' or 'none'")
      .def_readonly("normals", &FrameResult::normals, "the frame had a NORMALS image")
      .def_readonly("keyframes", &FrameResult::keyFrames, "keyframes in the map after the frame")
      .def_readonly("map_points", &FrameResult::mapPoints, "map points in the map after the frame")
      .def_readonly("message", &FrameResult::message)
      .def("__repr__", [](const FrameResult& r) {
        return "FrameResult(index=" + std::to_string(r.index) + ", state='" + system::toString(r.state) +
               "', keyframe=" + (r.keyFrame ? "True" : "False") + ", keyframes=" + std::to_string(r.keyFrames) +
               ", map_points=" + std::to_string(r.mapPoints) + ")";
      });

  py::class_<PySystem, std::unique_ptr<PySystem, PySystemDeleter>>(
      m, "System",
      "Monocular SLAM: the System façade of the C++ library (doc/api.md). Sequential mode (the shipped configs) "
      "maps every keyframe before track() returns, so the same seed and frames give the same bytes as slam-run. "
      "Every call releases the GIL; calls on one System run one at a time.")
      .def(py::init([](const std::filesystem::path& config, const py::object& overrides, std::uint32_t seed,
                       std::optional<bool> threaded, std::optional<geometry::PinholeCamera> camera) {
             system::SystemOptions options;
             options.seed = seed;
             options.threaded = threaded;
             options.camera = std::move(camera);
             std::vector<std::string> o = overridesFrom(overrides);
             py::gil_scoped_release release;
             return std::unique_ptr<PySystem, PySystemDeleter>(new PySystem(config, std::move(o), std::move(options)));
           }),
           py::arg("config_path"), py::arg("overrides") = py::none(), py::arg("seed") = 0,
           py::arg("threaded") = py::none(), py::arg("camera") = py::none(),
           "config_path: an ini file (config/slam/*.ini; paths in it are relative to it). overrides: "
           "{'Section.key': value} or ['Section.key=value', ...], as slam-run --set. seed: of every random process. "
           "threaded: local mapping in a second thread (None: the config's [System] threaded). camera: the "
           "priorslam.Camera of the images given to track(); rawlog frames carry their own. Raises priorslam.Error "
           "naming the file, [Section] key or value at fault.")
      .def(
          "track",
          [](PySystem& s, const py::object& image, double timestamp, const py::object& semantic,
             const py::object& normals) {
            const cv::Mat im = matFromArray(image, "image");
            const cv::Mat sem = matFromArray(semantic, "semantic");
            const cv::Mat nor = matFromArray(normals, "normals");
            return s.call([&](system::System& sys) { return sys.track(im, timestamp, sem, nor); });
          },
          py::arg("image"), py::arg("timestamp"), py::arg("semantic") = py::none(), py::arg("normals") = py::none(),
          "Tracks one image: uint8 (H, W) grey or (H, W, 3) BGR of the camera's size (needs camera=...), taken at "
          "`timestamp` seconds; optional SEMANTIC and NORMALS uint8 (H, W, 3) images. C-contiguous rows are used "
          "in place (no copy). Returns a FrameResult. Raises priorslam.Error for an empty image, a wrong size or "
          "type, or a non-finite timestamp.")
      .def(
          "track_frame",
          [](PySystem& s, const std::shared_ptr<datasets::Frame>& frame) {
            if (!frame) throw Error("track_frame: expected a priorslam.Frame, got None");
            return s.call([&](system::System& sys) { return sys.track(*frame); });
          },
          py::arg("frame"),
          "Tracks one rawlog frame (priorslam.Rawlog), with its intrinsics and its SEMANTIC / NORMALS channels.")
      .def("finish", [](PySystem& s) { s.call([](system::System& sys) { sys.finish(); }); },
           "Threaded mode: waits until every queued keyframe is mapped (and a loop's global BA written back). "
           "Sequential: returns at once.")
      .def(
          "trajectory",
          [](PySystem& s) {
            const Trajectory t = s.call([](system::System& sys) { return system::toTrajectory(sys.trajectory()); });
            return trajectoryArray(t);
          },
          "(N, 8) array t, x, y, z, qx, qy, qz, qw (T_world_cam) of every frame with a pose since the map was "
          "(re)initialized, each following the refined pose of its reference keyframe (the poses of "
          "save_trajectory). Threaded mode: call finish() first.")
      .def(
          "keyframe_trajectory",
          [](PySystem& s) {
            const Trajectory t =
                s.call([](system::System& sys) { return system::toTrajectory(sys.keyFrameTrajectory()); });
            return trajectoryArray(t);
          },
          "(N, 8) array of the map's keyframes, by keyframe id.")
      .def(
          "save_trajectory",
          [](PySystem& s, const std::filesystem::path& path, const std::string& comment) {
            s.call([&](system::System& sys) {
              writeTumTrajectory(path, system::toTrajectory(sys.trajectory()), comment);
            });
          },
          py::arg("path"), py::arg("comment") = "",
          "Writes trajectory() as a TUM file (atomically; stamps with 6 decimals, poses with 9 significant digits), "
          "with `comment` as a '# ' header line when not empty (slam-run's trajectory.txt has "
          "'slam-run: every tracked frame, T_world_cam').")
      .def(
          "save_keyframe_trajectory",
          [](PySystem& s, const std::filesystem::path& path, const std::string& comment) {
            s.call([&](system::System& sys) {
              writeTumTrajectory(path, system::toTrajectory(sys.keyFrameTrajectory()), comment);
            });
          },
          py::arg("path"), py::arg("comment") = "", "keyframe_trajectory() as a TUM file.")
      .def("save_map",
           [](PySystem& s, const std::filesystem::path& path) { s.call([&](system::System& sys) { sys.saveMap(path); }); },
           py::arg("path"), "Writes the map (.slammap, atomically). Raises priorslam.Error naming the path.")
      .def("load_map",
           [](PySystem& s, const std::filesystem::path& path) { s.call([&](system::System& sys) { sys.loadMap(path); }); },
           py::arg("path"),
           "Replaces the map by a saved one; the next frames relocalize in it. Raises priorslam.Error naming the "
           "file for a missing, corrupt or foreign map, or one whose camera differs from the System's.")
      .def("set_mapping_enabled",
           [](PySystem& s, bool enabled) { s.call([&](system::System& sys) { sys.setMappingEnabled(enabled); }); },
           py::arg("enabled"),
           "False: localization only (no new keyframes, the map is not changed); True (default): full SLAM.")
      .def_property_readonly("mapping_enabled",
                             [](PySystem& s) { return s.call([](system::System& sys) { return sys.mappingEnabled(); }); })
      .def("reset", [](PySystem& s) { s.call([](system::System& sys) { sys.reset(); }); },
           "Discards the map and the trajectory; the next frames initialize a new map.")
      .def_property_readonly("initialized",
                             [](PySystem& s) { return s.call([](system::System& sys) { return sys.initialized(); }); },
                             "a map has been initialized")
      .def_property_readonly(
          "camera",
          [](PySystem& s) -> std::optional<geometry::PinholeCamera> {
            return s.call([](system::System& sys) -> std::optional<geometry::PinholeCamera> {
              if (!sys.hasCamera()) return std::nullopt;
              return sys.camera();
            });
          },
          "the run's camera (priorslam.Camera), None before the first rawlog frame")
      .def_property_readonly("seed", [](PySystem& s) { return s.call([](system::System& sys) { return sys.seed(); }); })
      .def_property_readonly("threaded",
                             [](PySystem& s) { return s.call([](system::System& sys) { return sys.threaded(); }); })
      .def(
          "channels_used",
          [](PySystem& s) {
            return channelNames(
                s.call([](system::System& sys) { return system::System::channelsUsed(sys.params()); }));
          },
          "The rawlog channels this System uses besides CAMERA (for Rawlog(path, channels=...)).")
      .def(
          "summary",
          [](PySystem& s) {
            const nlohmann::json j = s.call([](system::System& sys) { return system::toJson(sys.summary()); });
            return toPython(j);
          },
          "The run's counters as a dict (the summary keys of report.json: frames_processed, frames_tracked, "
          "frames_lost, relocalizations, initialized_at_frame (-1: never), keyframes, map_points, resets, ...).")
      .def(
          "timings",
          [](PySystem& s) { return toPython(s.call([](system::System& sys) { return sys.timings().summary(); })); },
          "Per-stage timings {stage: {count, total_ms, mean_ms, median_ms, p90_ms, max_ms}}.")
      .def(
          "report", [](PySystem& s) { return toPython(s.call([](system::System& sys) { return system::runReport(sys); })); },
          "The run report as a dict (report.json without slam-run's own fields): effective config, seed, mode, "
          "camera, timings, summary, per-frame reports, mapping log, loops.")
      .def("close", &PySystem::close,
           "Ends the System now (threaded mode: its mapping thread); later calls raise priorslam.Error.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PySystem& s, py::args) { s.close(); });
}

}  // namespace pslam::python
