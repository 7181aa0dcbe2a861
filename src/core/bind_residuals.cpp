// Bindings of the residuals: (k poses) x (n points) in one call, GIL released.
#include <nanobind/stl/optional.h>

#include "arrays.h"
#include "register.h"
#include "residuals.h"

namespace poseonly {

// Residuals of k stacked poses R (k, 3, 3), unit t (k, 3) on n points: (k, n).
static NpArray residual_matrix(int kind, const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2) {
  if (kind < 0 || kind >= kNumResiduals) throw std::invalid_argument("unknown residual kind");
  const Points P = points_of(f1, f2);
  if (R.size() % 9 != 0 || t.size() * 3 != R.size()) throw std::invalid_argument("R must be (k, 3, 3) and t (k, 3)");
  const size_t k = R.size() / 9;
  std::vector<double> out(k * static_cast<size_t>(P.n));
  {
    nb::gil_scoped_release release;
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

}  // namespace poseonly

POSEONLY_BIND(residuals) {
  using namespace poseonly;
  m.def("residual_matrix", &residual_matrix, nb::arg("kind"), nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        "Residuals (k, n) of k poses R (k,3,3), unit t (k,3) on bearings f1, f2 (n,3); kind: 0 sampson, "
        "1 sampson-chiral, 2 ligt, 3 coplanar, 4 ppo, 5 ba, 6 opengv, 7 opengv-symmetric (the order of RESIDUAL_KINDS).");
  m.attr("RESIDUAL_KINDS") = nb::make_tuple("sampson", "sampson-chiral", "ligt", "coplanar", "ppo", "ba", "opengv", "opengv-symmetric");
}
