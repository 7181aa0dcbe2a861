// Bindings of the neighbour search (poseonly.robust.consistency), GIL released.
#include "arrays.h"
#include "neighbours.h"
#include "register.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace poseonly {

static void check_k(size_t n, int k) {
  if (n > static_cast<size_t>(std::numeric_limits<int32_t>::max())) throw std::invalid_argument("too many bearings");
  if (k < 1 || static_cast<size_t>(k) >= n) throw std::invalid_argument("k must be in [1, n - 1]");
}

static void check_finite(const double* f, size_t n) {
  for (size_t i = 0; i < 3 * n; ++i)
    if (!std::isfinite(f[i])) throw std::invalid_argument("bearings must be finite");
}

static NpInt nearest_neighbours_py(const BearingsIn& f, int k) {
  const size_t n = f.shape(0);
  if (f.shape(1) != 3) throw std::invalid_argument("bearings must have shape (n, 3)");
  check_k(n, k);
  check_finite(f.data(), n);
  std::vector<int32_t> idx(n * k);
  {
    nb::gil_scoped_release release;
    nearest_neighbours(f.data(), static_cast<int>(n), k, idx.data());
  }
  return to_numpy_t<int64_t>(std::vector<int64_t>(idx.begin(), idx.end()), {n, static_cast<size_t>(k)});
}

static NpInt neighbour_consistency_py(const BearingsIn& f1, const BearingsIn& f2, int k) {
  if (f1.shape(0) > static_cast<size_t>(std::numeric_limits<int32_t>::max())) throw std::invalid_argument("too many bearings");
  const Points P = points_of(f1, f2);
  const size_t n = static_cast<size_t>(P.n);
  check_k(n, k);
  check_finite(P.f1, n);
  check_finite(P.f2, n);
  std::vector<int64_t> out(n);
  {
    nb::gil_scoped_release release;
    neighbour_consistency(P.f1, P.f2, P.n, k, out.data());
  }
  return to_numpy_t<int64_t>(std::move(out), {n});
}

static nb::object distinct_matches_py(const BearingsIn& f1, const BearingsIn& f2, double tol) {
  if (f1.shape(0) > static_cast<size_t>(std::numeric_limits<int32_t>::max())) throw std::invalid_argument("too many bearings");
  const Points P = points_of(f1, f2);
  if (!(tol >= 0.0) || !std::isfinite(tol)) throw std::invalid_argument("tol must be finite and >= 0");
  check_finite(P.f1, static_cast<size_t>(P.n));
  check_finite(P.f2, static_cast<size_t>(P.n));
  std::vector<int64_t> kept;
  {
    GilRelease release(10.0 * P.n);  // ~0.3 ms at n = 1000
    kept = distinct_matches(P.f1, P.f2, P.n, tol);
  }
  if (kept.size() == static_cast<size_t>(P.n)) return nb::none();
  const size_t m = kept.size();
  return nb::cast(to_numpy_t<int64_t>(std::move(kept), {m}));
}

using MaskIn = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

static nb::ndarray<nb::numpy, uint8_t> locally_supported_py(const BearingsIn& f1, const MaskIn& extra, const MaskIn& explained, int k_max,
                                                            int min_count) {
  const size_t n = f1.shape(0);
  if (n > static_cast<size_t>(std::numeric_limits<int32_t>::max())) throw std::invalid_argument("too many bearings");
  if (f1.shape(1) != 3) throw std::invalid_argument("bearings must have shape (n, 3)");
  if (extra.shape(0) != n || explained.shape(0) != n) throw std::invalid_argument("masks must have shape (n,)");
  if (k_max < 1 || min_count < 0) throw std::invalid_argument("k_max must be >= 1 and min_count >= 0");
  check_finite(f1.data(), n);
  static_assert(sizeof(bool) == 1, "numpy bool is one byte");
  std::vector<uint8_t> out(n);
  {
    nb::gil_scoped_release release;
    locally_supported(f1.data(), static_cast<int>(n), reinterpret_cast<const uint8_t*>(extra.data()),
                      reinterpret_cast<const uint8_t*>(explained.data()), k_max, min_count, out.data());
  }
  return to_numpy_t<uint8_t>(std::move(out), {n});
}

}  // namespace poseonly

POSEONLY_BIND(neighbours) {
  using namespace poseonly;
  m.def("nearest_neighbours", &nearest_neighbours_py, nb::arg("f"), nb::arg("k"),
        "(n, k) int64: each unit bearing's k nearest other bearings (chord distance, nearest first, ties by index); 1 <= k < n.");
  m.def("neighbour_consistency", &neighbour_consistency_py, nb::arg("f1"), nb::arg("f2"), nb::arg("k"),
        "(n,) int64: for each match, how many of its k nearest matches in view 1 are among its k nearest in view 2; 1 <= k < n.");
  m.def("distinct_matches", &distinct_matches_py, nb::arg("f1"), nb::arg("f2"), nb::arg("tol"),
        "(m,) int64 ascending: the first match of each group of repeated matches (identical rows, or within tol of each other "
        "in both views, chord distance; connected components), or None where every match is distinct.");
  m.def("locally_supported", &locally_supported_py, nb::arg("f1"), nb::arg("extra"), nb::arg("explained"), nb::arg("k_max"),
        nb::arg("min_count"),
        "(n,) uint8: extra kept where at least min(min_count, k) of the k = min(k_max, m - 1) nearest view-1 bearings among "
        "the m matches in extra | explained are extra and not the same bearing.");
}
