// priorslam.Rawlog and priorslam.Frame: the frames of a rawlog (doc/architecture.md, "Data contracts").
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "Common.h"
#include "pslam/core/Error.h"
#include "pslam/datasets/PrefetchingRawlogReader.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam::python {

namespace {

/// The channels named in `names` ("depth", "semantic", "normals"); None = all of them.
datasets::RawlogChannels channelsFrom(const py::handle& names) {
  datasets::RawlogChannels c;
  if (names.is_none()) return c;
  c.depth = c.semantic = c.normals = false;
  if (py::isinstance<py::str>(names)) throw Error("channels: expected a list of names, not a string");
  for (const py::handle& n : names) {
    const std::string s = py::str(n);
    if (s == "depth" || s == datasets::kDepthLabel) c.depth = true;
    else if (s == "semantic" || s == datasets::kSemanticLabel) c.semantic = true;
    else if (s == "normals" || s == datasets::kNormalsLabel) c.normals = true;
    else throw Error("channels: unknown channel '" + s + "' (depth, semantic, normals)");
  }
  return c;
}

/// A rawlog read one frame at a time, ahead of the caller in a thread of its own when `prefetch` > 0 (the
/// PrefetchingRawlogReader slam-run uses), else in the calling thread.
class Rawlog {
 public:
  Rawlog(std::filesystem::path path, datasets::RawlogChannels channels, std::size_t prefetch) : path_(path) {
    if (prefetch > 0)
      prefetching_ = std::make_unique<datasets::PrefetchingRawlogReader>(std::move(path), prefetch, channels);
    else
      plain_ = std::make_unique<datasets::RawlogReader>(std::move(path), channels);
  }

  /// The next frame, or nullptr at the end (or after close()).
  std::shared_ptr<datasets::Frame> next() {
    std::lock_guard<std::mutex> lock(mutex_);
    auto frame = std::make_shared<datasets::Frame>();
    bool more = false;
    if (prefetching_) more = prefetching_->next(*frame);
    else if (plain_) more = plain_->next(*frame);
    if (!more) {
      closeLocked();
      return nullptr;
    }
    return frame;
  }

  void close() {
    std::lock_guard<std::mutex> lock(mutex_);
    closeLocked();
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  void closeLocked() {
    prefetching_.reset();  // stops and joins the reading thread
    plain_.reset();
  }
  std::filesystem::path path_;
  std::mutex mutex_;
  std::unique_ptr<datasets::PrefetchingRawlogReader> prefetching_;
  std::unique_ptr<datasets::RawlogReader> plain_;
};

/// The intrinsics of a frame as stored (not checked: a frame may carry a camera the System refuses, with its
/// message, when tracked).
geometry::PinholeCamera cameraOf(const mrpt::img::TCamera& c) {
  geometry::PinholeCamera out;
  out.fx = c.fx();
  out.fy = c.fy();
  out.cx = c.cx();
  out.cy = c.cy();
  out.width = static_cast<int>(c.ncols);
  out.height = static_cast<int>(c.nrows);
  if (c.distortion != mrpt::img::DistortionModel::none)
    for (std::size_t k = 0; k < out.distortion.size(); ++k) out.distortion[k] = c.dist[k];
  return out;
}

}  // namespace

void bindRawlog(py::module_& m) {
  using datasets::Frame;
  py::class_<Frame, std::shared_ptr<Frame>>(
      m, "Frame",
      "One frame of a rawlog: the CAMERA image with its intrinsics and the optional DEPTH, SEMANTIC and NORMALS "
      "images of the same instant. The arrays share the frame's pixels (read-only, no copy).")
      .def_readonly("index", &Frame::index, "0-based position in the rawlog")
      .def_readonly("timestamp", &Frame::timestamp, "seconds")
      .def_property_readonly("image", [](const Frame& f) { return arrayFromMat(f.image); },
                             "uint8 (H, W) grey or (H, W, 3) BGR")
      .def_property_readonly("depth", [](const Frame& f) { return arrayFromMat(f.depth); },
                             "uint16 (H, W), depth along the optical axis in depth_units metres (0 = invalid), or None")
      .def_readonly("depth_units", &Frame::depthUnits, "metres per depth unit (0 without DEPTH)")
      .def_property_readonly("semantic", [](const Frame& f) { return arrayFromMat(f.semantic); },
                             "uint8 (H, W, 3): round(255 P(static, dynamic, invalid)) per pixel, or None")
      .def_property_readonly("normals", [](const Frame& f) { return arrayFromMat(f.normals); },
                             "uint8 (H, W, 3): round((n + 1) / 2 * 255) of the camera-frame unit normal "
                             "((0, 0, 0) = none), or None")
      .def_property_readonly("camera", [](const Frame& f) { return cameraOf(f.camera); },
                             "the CAMERA intrinsics (priorslam.Camera)")
      .def_property_readonly("sensor_pose", [](const Frame& f) { return poseMatrix(f.sensorPoseOnBody); },
                             "4x4 pose of the camera on the body (identity if unknown)")
      .def("__repr__", [](const Frame& f) {
        std::string s = "Frame(index=" + std::to_string(f.index) + ", timestamp=" + py::repr(py::float_(f.timestamp)).cast<std::string>() +
                        ", image=" + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows) + "x" +
                        std::to_string(f.image.channels());
        if (f.hasDepth()) s += ", depth";
        if (f.hasSemantic()) s += ", semantic";
        if (f.hasNormals()) s += ", normals";
        return s + ")";
      });

  py::class_<Rawlog>(m, "Rawlog",
                     "The frames of a rawlog, one at a time: `for frame in priorslam.Rawlog(path): ...`. A rawlog is "
                     "read once (an iterator, like a file). Read errors (a missing image file, a corrupt or cut "
                     "archive) raise priorslam.Error naming the rawlog and the frame.")
      .def(py::init([](const std::filesystem::path& path, const py::object& channels, std::size_t prefetch) {
             const datasets::RawlogChannels c = channelsFrom(channels);
             py::gil_scoped_release release;
             return std::make_unique<Rawlog>(path, c, prefetch);
           }),
           py::arg("path"), py::arg("channels") = py::none(), py::arg("prefetch") = 3,
           "channels: the channels to decode besides CAMERA ('depth', 'semantic', 'normals'; None = all; "
           "System.channels_used() names those a System uses). prefetch: frames read and decoded ahead in a "
           "thread of the reader's own (as slam-run does; 0 = read in the calling thread).")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__",
           [](Rawlog& r) {
             std::shared_ptr<Frame> f;
             {
               py::gil_scoped_release release;
               f = r.next();
             }
             if (!f) throw py::stop_iteration();
             return f;
           })
      .def("close", [](Rawlog& r) {
             py::gil_scoped_release release;
             r.close();
           },
           "Stops reading (and the read-ahead thread); iteration then ends.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](Rawlog& r, py::args) {
        py::gil_scoped_release release;
        r.close();
      })
      .def_property_readonly("path", &Rawlog::path)
      .def_static(
          "count_frames",
          [](const std::filesystem::path& path) {
            py::gil_scoped_release release;
            return datasets::RawlogReader::countFrames(path);
          },
          py::arg("path"), "The number of frames (reads and verifies the whole archive, without the images).");
}

}  // namespace pslam::python
