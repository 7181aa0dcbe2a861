// PythonSignals: Python's signal handlers from a loop that runs with the GIL released (the robust
// loops' and GNC-IRLS's interrupt hooks), shared by the binding files.
#pragma once

#include <nanobind/nanobind.h>

namespace poseonly {
namespace nb = nanobind;

// Python's signal handlers from a loop that runs with the GIL released (RansacOptions::interrupted): takes
// the GIL, runs them (in the main thread; elsewhere Python runs none), and keeps the exception a handler
// raised (KeyboardInterrupt, a SIGTERM handler's SystemExit) to raise it once the loop has returned
class PythonSignals {
 public:
  PythonSignals() = default;
  PythonSignals(const PythonSignals&) = delete;
  PythonSignals& operator=(const PythonSignals&) = delete;
  ~PythonSignals() {
    if (type_) {
      nb::gil_scoped_acquire acq;
      Py_XDECREF(type_), Py_XDECREF(value_), Py_XDECREF(tb_);
    }
  }
  bool operator()() {
    nb::gil_scoped_acquire acq;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Fetch(&type_, &value_, &tb_);
    return true;
  }
  // with the GIL held, after the loop: raises the kept exception, if any
  void rethrow() {
    if (!type_) return;
    PyErr_Restore(type_, value_, tb_);
    type_ = value_ = tb_ = nullptr;
    throw nb::python_error();
  }

 private:
  PyObject* type_ = nullptr;
  PyObject* value_ = nullptr;
  PyObject* tb_ = nullptr;
};

}  // namespace poseonly
