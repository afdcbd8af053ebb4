#include "Common.h"

#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <new>
#include <sstream>
#include <vector>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "pslam/core/Error.h"
#include "pslam/datasets/Camera.h"
#include "pslam/geometry/PinholeCamera.h"

namespace pslam::python {

namespace {

// ---- numpy arrays as cv::Mat buffers
//
// A Mat over a numpy buffer carries a UMatData whose userdata is an owned reference to the array (as OpenCV's own
// Python bindings do). The last Mat to let go of it may do so on a thread without the GIL (the mapping thread
// drops a keyframe's image, or track() runs with the GIL released): taking the GIL there could deadlock against a
// Python thread that waits for that thread, so such references are parked and dropped by the next call that holds
// the GIL (releaseParkedArrays).

std::mutex& parkedMutex() {
  static std::mutex m;
  return m;
}
std::vector<PyObject*>& parkedArrays() {
  static std::vector<PyObject*> v;
  return v;
}

class NumpyBufferAllocator : public cv::MatAllocator {
 public:
  /// New allocations (a Mat that owned a numpy buffer is re-created) are OpenCV's own.
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override {
    return cv::Mat::getStdAllocator()->allocate(dims, sizes, type, data, step, flags, usage);
  }
  bool allocate(cv::UMatData* u, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    return cv::Mat::getStdAllocator()->allocate(u, flags, usage);
  }
  void deallocate(cv::UMatData* u) const override {
    if (!u || u->refcount > 0 || u->urefcount > 0) return;
    PyObject* array = static_cast<PyObject*>(u->userdata);
    delete u;
    if (!array) return;
    if (Py_IsInitialized() && PyGILState_Check()) {
      Py_DECREF(array);
    } else {
      std::lock_guard<std::mutex> lock(parkedMutex());
      parkedArrays().push_back(array);
    }
  }
  /// A UMatData for the buffer of `array`, taking over one reference to it.
  cv::UMatData* wrap(PyObject* array, uchar* data, std::size_t bytes) const {
    auto* u = new cv::UMatData(this);
    u->data = u->origdata = data;
    u->size = bytes;
    u->userdata = array;
    return u;
  }
};

const NumpyBufferAllocator& numpyAllocator() {
  static const NumpyBufferAllocator allocator;
  return allocator;
}

/// The OpenCV depth of a numpy dtype, or -1.
int cvDepthOf(const py::dtype& dtype) {
  const char kind = dtype.kind();
  const auto size = dtype.itemsize();
  if (kind == 'u' && size == 1) return CV_8U;
  if (kind == 'i' && size == 1) return CV_8S;
  if (kind == 'u' && size == 2) return CV_16U;
  if (kind == 'i' && size == 2) return CV_16S;
  if (kind == 'i' && size == 4) return CV_32S;
  if (kind == 'f' && size == 4) return CV_32F;
  if (kind == 'f' && size == 8) return CV_64F;
  return -1;
}

py::dtype dtypeOfDepth(int depth) {
  switch (depth) {
    case CV_8U: return py::dtype::of<std::uint8_t>();
    case CV_8S: return py::dtype::of<std::int8_t>();
    case CV_16U: return py::dtype::of<std::uint16_t>();
    case CV_16S: return py::dtype::of<std::int16_t>();
    case CV_32S: return py::dtype::of<std::int32_t>();
    case CV_32F: return py::dtype::of<float>();
    case CV_64F: return py::dtype::of<double>();
    default: throw Error("cv::Mat of depth " + std::to_string(depth) + " has no numpy dtype");
  }
}

std::string shapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

cv::Mat matFromArray(const py::handle& object, const std::string& what) {
  if (object.is_none()) return cv::Mat();
  py::array array = py::array::ensure(object);
  if (!array) throw Error(what + ": expected a numpy array");
  if (array.ndim() != 2 && array.ndim() != 3)
    throw Error(what + ": expected an array of shape (height, width) or (height, width, channels), got shape " +
                shapeText(array));
  const int depth = cvDepthOf(array.dtype());
  if (depth < 0)
    throw Error(what + ": numpy dtype " + py::str(array.dtype()).cast<std::string>() + " has no OpenCV type");
  const int rows = static_cast<int>(array.shape(0)), cols = static_cast<int>(array.shape(1));
  const int channels = array.ndim() == 3 ? static_cast<int>(array.shape(2)) : 1;
  if (channels < 1 || channels > CV_CN_MAX)
    throw Error(what + ": " + std::to_string(channels) + " channels (1 to " + std::to_string(CV_CN_MAX) + " allowed)");
  if (rows == 0 || cols == 0) return cv::Mat();  // the library names an empty image in its own words
  const auto item = array.itemsize();
  // Zero copy when each row's pixels are contiguous and rows are a positive whole number of items apart.
  const bool rowsContiguous = (array.ndim() == 2 || array.strides(2) == item) && array.strides(1) == channels * item &&
                              array.strides(0) >= cols * channels * item && array.strides(0) % item == 0;
  if (!rowsContiguous) array = py::array::ensure(py::module_::import("numpy").attr("ascontiguousarray")(array));
  const std::size_t step = static_cast<std::size_t>(array.strides(0));
  auto* data = static_cast<uchar*>(const_cast<void*>(array.data()));
  cv::Mat mat(rows, cols, CV_MAKETYPE(depth, channels), data, step);
  mat.u = numpyAllocator().wrap(array.release().ptr(), data, step * static_cast<std::size_t>(rows));
  mat.addref();
  return mat;
}

py::object arrayFromMat(const cv::Mat& mat) {
  if (mat.empty()) return py::none();
  auto* keep = new cv::Mat(mat);
  py::capsule owner(keep, [](void* p) { delete static_cast<cv::Mat*>(p); });
  std::vector<py::ssize_t> shape{mat.rows, mat.cols};
  std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(mat.step[0]), static_cast<py::ssize_t>(mat.elemSize())};
  if (mat.channels() > 1) {
    shape.push_back(mat.channels());
    strides.push_back(static_cast<py::ssize_t>(mat.elemSize1()));
  }
  py::array array(dtypeOfDepth(mat.depth()), shape, strides, mat.data, owner);
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return std::move(array);
}

void releaseParkedArrays() {
  std::vector<PyObject*> drop;
  {
    std::lock_guard<std::mutex> lock(parkedMutex());
    drop.swap(parkedArrays());
  }
  for (PyObject* o : drop) Py_DECREF(o);
}

py::array_t<double> poseMatrix(const mrpt::poses::CPose3D& pose) {
  const auto H = pose.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  py::array_t<double> out({4, 4});
  auto r = out.mutable_unchecked<2>();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r(i, j) = H(i, j);
  return out;
}

py::array_t<double> trajectoryArray(const Trajectory& trajectory) {
  py::array_t<double> out({static_cast<py::ssize_t>(trajectory.size()), py::ssize_t{8}});
  auto r = out.mutable_unchecked<2>();
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    const StampedPose& p = trajectory[k];
    const auto i = static_cast<py::ssize_t>(k);
    r(i, 0) = p.timestamp;
    r(i, 1) = p.position.x();
    r(i, 2) = p.position.y();
    r(i, 3) = p.position.z();
    r(i, 4) = p.orientation.x();
    r(i, 5) = p.orientation.y();
    r(i, 6) = p.orientation.z();
    r(i, 7) = p.orientation.w();
  }
  return out;
}

Trajectory trajectoryFromArray(const py::handle& object, const std::string& what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  } catch (const py::error_already_set&) {
    a = {};
  }
  if (!a) throw Error(what + ": expected a TUM file path or an (N, 8) array of t x y z qx qy qz qw");
  if (a.ndim() != 2 || a.shape(1) != 8)
    throw Error(what + ": expected an (N, 8) array of t x y z qx qy qz qw, got shape " + shapeText(a));
  auto r = a.unchecked<2>();
  Trajectory out;
  out.reserve(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    for (int j = 0; j < 8; ++j)
      if (!std::isfinite(r(i, j))) throw Error(what + ": row " + std::to_string(i) + ": NaN or Inf value");
    StampedPose p;
    p.timestamp = r(i, 0);
    p.position = Eigen::Vector3d(r(i, 1), r(i, 2), r(i, 3));
    Eigen::Quaterniond q(r(i, 7), r(i, 4), r(i, 5), r(i, 6));
    if (q.norm() == 0.0) throw Error(what + ": row " + std::to_string(i) + ": zero quaternion");
    // Unit quaternions are kept as they are: normalizing one again can change its last bit, and the arrays this
    // module gives (read_trajectory, System.trajectory) must give the metrics of the files they came from.
    if (std::abs(q.squaredNorm() - 1.0) > 4.0 * std::numeric_limits<double>::epsilon()) q.normalize();
    p.orientation = q;
    out.push_back(p);
  }
  return out;
}

py::object toPython(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return py::none();
    case nlohmann::json::value_t::boolean: return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(j.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(j.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float: return py::float_(j.get<double>());
    case nlohmann::json::value_t::string: return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list l;
      for (const auto& e : j) l.append(toPython(e));
      return std::move(l);
    }
    case nlohmann::json::value_t::object: {
      py::dict d;
      for (const auto& [k, v] : j.items()) d[py::str(k)] = toPython(v);
      return std::move(d);
    }
    default: return py::none();
  }
}

void bindCommon(py::module_& m) {
  // pslam::Error and every other library exception become priorslam.Error with the one-line message the tools
  // print after "<tool>: error: ". Exceptions of Python's own (pybind11's casts, StopIteration, MemoryError) keep
  // their types.
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  error.doc() =
      "An error of the library: a bad config key, a missing or corrupt file, a wrong image, ... Its message is the "
      "one line the command-line tools print after '<tool>: error: '.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      error(e.what());
    } catch (const py::builtin_exception&) {
      throw;
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      error(oneLineMessage(e).c_str());
    }
  });

  using geometry::PinholeCamera;
  py::class_<PinholeCamera>(m, "Camera",
                            "A pinhole camera with OpenCV plumb-bob distortion (k1 k2 p1 p2 k3); pixel (0, 0) is the "
                            "centre of the top-left pixel.")
      .def(py::init([](double fx, double fy, double cx, double cy, int width, int height,
                       std::array<double, 5> distortion) {
             PinholeCamera c(fx, fy, cx, cy, width, height, distortion);
             c.check();
             return c;
           }),
           py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"), py::arg("width"), py::arg("height"),
           py::arg("distortion") = std::array<double, 5>{{0, 0, 0, 0, 0}},
           "Checks the values (raises priorslam.Error naming the field).")
      .def_static(
          "from_ini",
          [](const std::filesystem::path& path, const std::string& section) {
            return PinholeCamera::fromTCamera(datasets::loadCameraIni(path, section));
          },
          py::arg("path"), py::arg("section") = "CAMERA",
          "Reads an MRPT TCamera block (config/cameras/*.ini: resolution, fx, fy, cx, cy, dist, distortion_model).")
      .def_readonly("fx", &PinholeCamera::fx)
      .def_readonly("fy", &PinholeCamera::fy)
      .def_readonly("cx", &PinholeCamera::cx)
      .def_readonly("cy", &PinholeCamera::cy)
      .def_readonly("width", &PinholeCamera::width)
      .def_readonly("height", &PinholeCamera::height)
      .def_property_readonly(
          "distortion", [](const PinholeCamera& c) { return py::make_tuple(c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3], c.distortion[4]); },
          "(k1, k2, p1, p2, k3)")
      .def_property_readonly(
          "K",
          [](const PinholeCamera& c) {
            py::array_t<double> k({3, 3});
            auto r = k.mutable_unchecked<2>();
            const Eigen::Matrix3d K = c.K();
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) r(i, j) = K(i, j);
            return k;
          },
          "The 3x3 calibration matrix.")
      .def("__eq__",
           [](const PinholeCamera& a, const PinholeCamera& b) {
             return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width &&
                    a.height == b.height && a.distortion == b.distortion;
           })
      .def("__repr__", [](const PinholeCamera& c) {
        std::ostringstream os;
        os.precision(10);
        os << "Camera(fx=" << c.fx << ", fy=" << c.fy << ", cx=" << c.cx << ", cy=" << c.cy << ", width=" << c.width
           << ", height=" << c.height << ", distortion=(" << c.distortion[0] << ", " << c.distortion[1] << ", "
           << c.distortion[2] << ", " << c.distortion[3] << ", " << c.distortion[4] << "))";
        return os.str();
      });
}

}  // namespace pslam::python
