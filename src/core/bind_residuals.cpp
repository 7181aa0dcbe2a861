// Bindings of the residuals: (k poses) x (n points) in one call, GIL released.
#include <nanobind/stl/optional.h>

#include "arrays.h"
#include "bearings.h"
#include "register.h"
#include "residuals.h"

#include <algorithm>
#include <cmath>

namespace poseonly {

// Residuals of k stacked poses R (k, 3, 3), unit t (k, 3) on n points: (k, n).
static NpArray residual_matrix(int kind, const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2) {
  if (kind < 0 || kind >= kNumResiduals) throw std::invalid_argument("unknown residual kind");
  const Points P = points_of(f1, f2);
  if (R.size() % 9 != 0 || t.size() * 3 != R.size()) throw std::invalid_argument("R must be (k, 3, 3) and t (k, 3)");
  const size_t k = R.size() / 9;
  std::vector<double> out(k * static_cast<size_t>(P.n));
  {
    GilRelease release(static_cast<double>(k) * P.n);
    for (size_t h = 0; h < k; ++h) {
      Pose p;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) p.R(i, j) = R.data()[9 * h + 3 * i + j];
        p.t(i) = t.data()[3 * h + i];
      }
      const PoseTerms pt(p);
      double* row = out.data() + h * P.n;
      for (int i = 0; i < P.n; ++i) row[i] = residual(static_cast<Residual>(kind), pt, P.a(i), P.b(i));
    }
  }
  return to_numpy(std::move(out), {k, static_cast<size_t>(P.n)});
}

// Rows of a (n, 3) scaled to unit length (unit_rows_into): (unit rows, number of zero rows, number of
// rows with a NaN or inf component; such rows count as neither zero nor plain and come out non-finite).
static nb::tuple unit_rows(const BearingsIn& a, double zero) {
  if (a.shape(1) != 3) throw std::invalid_argument("a must have shape (n, 3)");
  const size_t n = a.shape(0);
  std::vector<double> out(3 * n);
  int64_t zeros = 0, nonfinite = 0;
  {
    GilRelease release(static_cast<double>(n));
    unit_rows_into(a.data(), n, zero, out.data(), &zeros, &nonfinite);
  }
  return nb::make_tuple(to_numpy(std::move(out), {n, static_cast<size_t>(3)}), zeros, nonfinite);
}

// Pixels a (n, 2) to unit bearings through an upper-triangular K with K[2][2] = 1 (as
// poseonly.geometry.check_intrinsics returns it; its lower-left entries are ignored): the rays
// K^-1 [u, v, 1] with the operations of geometry.solve_intrinsics (LAPACK's back-substitution order and
// reciprocals), then unit_rows_into. Returns None when a pixel's largest |coordinate| reaches 1e150
// (the caller's overflow-safe path), else (bearings (n, 3), rows with a NaN or inf pixel, rows whose
// ray is not finite, zero rows); with non-finite pixels or rays the bearings are not computed.
static nb::object pixel_bearings(const BearingsIn& a, const ArrayIn& K, double zero) {
  if (a.shape(1) != 2) throw std::invalid_argument("a must have shape (n, 2)");
  if (K.size() != 9) throw std::invalid_argument("K must be (3, 3)");
  const size_t n = a.shape(0);
  const double* k = K.data();
  std::vector<double> rays(3 * n), out(3 * n);
  int64_t bad_pixels = 0, bad_rays = 0, zeros = 0, nonfinite = 0;
  bool huge = false;
  {
    GilRelease release(static_cast<double>(n));
    const double* x = a.data();
    for (size_t i = 0; i < n; ++i) {
      const double u = x[2 * i], v = x[2 * i + 1];
      if (!(std::isfinite(u) && std::isfinite(v))) {
        ++bad_pixels;
        continue;
      }
      huge = huge || !(std::max(std::abs(u), std::abs(v)) < 1e150);
    }
    if (!bad_pixels && !huge) {
      const double i22 = 1.0 / k[8], i11 = 1.0 / k[4], i00 = 1.0 / k[0];
      for (size_t i = 0; i < n; ++i) {
        const double r2 = 1.0 * i22;
        const double b1 = x[2 * i + 1] - k[5] * r2, b0 = x[2 * i] - k[2] * r2;
        const double r1 = b1 * i11, r0 = (b0 - k[1] * r1) * i00;
        rays[3 * i] = r0, rays[3 * i + 1] = r1, rays[3 * i + 2] = r2;
      }
      unit_rows_into(rays.data(), n, zero, out.data(), &zeros, &nonfinite);
      bad_rays = nonfinite;
    }
  }
  if (huge && !bad_pixels) return nb::none();
  return nb::make_tuple(to_numpy(std::move(out), {n, static_cast<size_t>(3)}), bad_pixels, bad_rays, zeros);
}

}  // namespace poseonly

POSEONLY_BIND(residuals) {
  using namespace poseonly;
  m.def("residual_matrix", &residual_matrix, nb::arg("kind"), nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        "Residuals (k, n) of k poses R (k,3,3), unit t (k,3) on bearings f1, f2 (n,3); kind: 0 sampson, "
        "1 sampson-chiral, 2 ligt, 3 coplanar, 4 ppo, 5 ba, 6 opengv, 7 opengv-symmetric (the order of RESIDUAL_KINDS).");
  m.def("unit_rows", &unit_rows, nb::arg("a"), nb::arg("zero"),
        "Rows of a (n, 3) scaled to unit length without overflow or underflow: (unit rows (n, 3), number of rows shorter than `zero`, "
        "number of rows with NaN or inf; when it is > 0 the rows are not computed).");
  m.def("pixel_bearings", &pixel_bearings, nb::arg("a"), nb::arg("K"), nb::arg("zero"),
        "Pixels a (n, 2) -> unit bearings through upper-triangular K (K[2, 2] = 1): None when a coordinate reaches 1e150, "
        "else (bearings (n, 3), rows with NaN / inf pixels, rows with a non-finite ray, zero rows).");
  m.attr("RESIDUAL_KINDS") = nb::make_tuple("sampson", "sampson-chiral", "ligt", "coplanar", "ppo", "ba", "opengv", "opengv-symmetric");
}
