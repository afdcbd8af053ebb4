// The extension module behind the Python package `priorslam` (python/priorslam/__init__.py re-exports it;
// doc/python.md).
#include "Common.h"

#ifndef PRIORSLAM_VERSION
#error "PRIORSLAM_VERSION is set by python/CMakeLists.txt"
#endif

PYBIND11_MODULE(_core, m) {
  m.doc() = "priorslam: monocular SLAM with semantic and geometric priors (the C++ library's System façade, its "
            "rawlog reader and the evaluation metrics).";
  m.attr("__version__") = PRIORSLAM_VERSION;
  pslam::python::bindCommon(m);
  pslam::python::bindRawlog(m);
  pslam::python::bindSystem(m);
  pslam::python::bindEval(m);
}
