// Bindings of the undistortion (poseonly.cameras), GIL released.
#include "arrays.h"
#include "cameras.h"
#include "register.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace poseonly {

static nb::tuple undistort_brown_py(const VectorIn& xd, const VectorIn& yd, const VectorIn& k, double tol, int max_iter) {
  const size_t n = xd.shape(0);
  if (yd.shape(0) != n) throw std::invalid_argument("xd and yd must have the same length");
  if (k.shape(0) != 8) throw std::invalid_argument("k must hold (k1, k2, p1, p2, k3, k4, k5, k6)");
  if (max_iter < 1) throw std::invalid_argument("max_iter must be >= 1");
  if (n > static_cast<size_t>(std::numeric_limits<int>::max())) throw std::invalid_argument("too many points");
  std::vector<double> u(n), v(n);
  std::vector<uint8_t> ok(n);
  {
    nb::gil_scoped_release release;
    undistort_brown(xd.data(), yd.data(), static_cast<int>(n), k.data(), tol, max_iter, u.data(), v.data(), ok.data());
  }
  return nb::make_tuple(to_numpy(std::move(u), {n}), to_numpy(std::move(v), {n}), to_numpy_t<uint8_t>(std::move(ok), {n}));
}

static nb::tuple undistort_fisheye_py(const VectorIn& rd, const VectorIn& k, double tol, int max_iter) {
  const size_t n = rd.shape(0);
  if (k.shape(0) != 4) throw std::invalid_argument("k must hold (k1, k2, k3, k4)");
  if (max_iter < 1) throw std::invalid_argument("max_iter must be >= 1");
  if (n > static_cast<size_t>(std::numeric_limits<int>::max())) throw std::invalid_argument("too many points");
  std::vector<double> theta(n);
  std::vector<uint8_t> ok(n);
  {
    nb::gil_scoped_release release;
    undistort_fisheye(rd.data(), static_cast<int>(n), k.data(), tol, max_iter, theta.data(), ok.data());
  }
  return nb::make_tuple(to_numpy(std::move(theta), {n}), to_numpy_t<uint8_t>(std::move(ok), {n}));
}

static nb::tuple undistort_prism_py(const VectorIn& xd, const VectorIn& yd, int kind, const VectorIn& k, double tol, int max_iter) {
  const size_t n = xd.shape(0);
  if (yd.shape(0) != n) throw std::invalid_argument("xd and yd must have the same length");
  if (kind != 0 && kind != 1) throw std::invalid_argument("kind must be 0 (THIN_PRISM_FISHEYE) or 1 (RAD_TAN_THIN_PRISM_FISHEYE)");
  if (k.shape(0) != 12) throw std::invalid_argument("k must hold 12 coefficients");
  if (max_iter < 1) throw std::invalid_argument("max_iter must be >= 1");
  if (n > static_cast<size_t>(std::numeric_limits<int>::max())) throw std::invalid_argument("too many points");
  std::vector<double> u(n), v(n);
  std::vector<uint8_t> ok(n);
  {
    nb::gil_scoped_release release;
    undistort_prism(xd.data(), yd.data(), static_cast<int>(n), kind, k.data(), tol, max_iter, u.data(), v.data(), ok.data());
  }
  return nb::make_tuple(to_numpy(std::move(u), {n}), to_numpy(std::move(v), {n}), to_numpy_t<uint8_t>(std::move(ok), {n}));
}

}  // namespace poseonly

POSEONLY_BIND(cameras) {
  using namespace poseonly;
  m.def("undistort_brown", &undistort_brown_py, nb::arg("xd"), nb::arg("yd"), nb::arg("k"), nb::arg("tol"), nb::arg("max_iter"),
        "Brown-Conrady undistortion of normalized (xd, yd) by Newton's method, k = (k1, k2, p1, p2, k3, k4, k5, k6): "
        "(u, v, ok as uint8).");
  m.def("undistort_fisheye", &undistort_fisheye_py, nb::arg("rd"), nb::arg("k"), nb::arg("tol"), nb::arg("max_iter"),
        "OpenCV fisheye: theta with theta (1 + k1 t^2 + ... + k4 t^8) = rd by Newton's method: (theta, ok as uint8).");
  m.def("undistort_prism", &undistort_prism_py, nb::arg("xd"), nb::arg("yd"), nb::arg("kind"), nb::arg("k"), nb::arg("tol"), nb::arg("max_iter"),
        "COLMAP's thin-prism fisheye undistortion (kind 0 THIN_PRISM_FISHEYE, 1 RAD_TAN_THIN_PRISM_FISHEYE; k: 12 coefficients) "
        "to equidistant coordinates: (uu, vv, ok as uint8).");
}
