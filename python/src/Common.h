#pragma once
// Shared pieces of the `priorslam` Python module (doc/python.md): numpy <-> cv::Mat without copies, poses and
// trajectories as numpy arrays, JSON as Python objects, and the error type.
#include <string>

#include <mrpt/poses/CPose3D.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "pslam/core/Trajectory.h"

namespace pslam::python {

namespace py = pybind11;

/// A cv::Mat over the buffer of a numpy array, or an empty Mat for None. No copy when each row's pixels are
/// contiguous (C-contiguous arrays and row ranges of them): the Mat then holds a reference to the array, so the
/// buffer lives as long as any Mat that shares it (the tracker keeps images of past frames). Other layouts are
/// copied once into a contiguous array. Shapes (H, W) and (H, W, C); dtypes with an OpenCV depth (uint8, int8,
/// uint16, int16, int32, float32, float64): whether the type suits the call is checked by the library, with its
/// own message. `what` names the argument in errors.
cv::Mat matFromArray(const py::handle& object, const std::string& what);

/// A numpy array over a cv::Mat's pixels (no copy; the array keeps the pixels alive), or None for an empty Mat.
/// Shape (H, W) for one channel, else (H, W, C). Read-only: the pixels may be shared with the library.
py::object arrayFromMat(const cv::Mat& mat);

/// Drops the references to numpy arrays whose last cv::Mat was released on a thread that did not hold the GIL
/// (the mapping thread, or a call that released the GIL). Call with the GIL held.
void releaseParkedArrays();

/// T (4x4, float64) of a pose.
py::array_t<double> poseMatrix(const mrpt::poses::CPose3D& pose);
/// (N, 8) float64: t, x, y, z, qx, qy, qz, qw per row (the TUM columns).
py::array_t<double> trajectoryArray(const Trajectory& trajectory);
/// An (N, 8) array-like in the TUM columns as a trajectory; quaternions normalized as the TUM reader does. Throws
/// pslam::Error naming `what` and the row for a wrong shape, a non-finite value or a zero quaternion.
Trajectory trajectoryFromArray(const py::handle& object, const std::string& what);

/// JSON as Python objects (dict, list, str, int, float, bool, None).
py::object toPython(const nlohmann::json& json);

/// The module's parts (one function per source file).
void bindCommon(py::module_& m);
void bindRawlog(py::module_& m);
void bindSystem(py::module_& m);
void bindEval(py::module_& m);

}  // namespace pslam::python
