// numpy <-> core conversions for the binding files (nanobind ndarrays, C-contiguous float64).
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common.h"

namespace poseonly {
namespace nb = nanobind;

using BearingsIn = nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using VectorIn = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using ArrayIn = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using NpArray = nb::ndarray<nb::numpy, double>;
using NpBool = nb::ndarray<nb::numpy, bool>;
using NpInt = nb::ndarray<nb::numpy, int64_t>;

// The GIL is released only for a call of at least this much work (matches times passes over them, about
// 20-50 ns each: ~0.5-1 ms). Why: where another Python thread runs, taking the GIL back waits up to the
// interpreter's switch interval (5 ms), and an estimate makes ~40 short calls (a VO trial: 20 -> 212 ms a
// pair beside a busy thread); a call that short gains nothing from running beside other threads.
constexpr double kReleaseGilMinWork = 20000.0;

// `GilRelease release(work);` releases the GIL for the scope where `work` >= kReleaseGilMinWork.
class GilRelease {
 public:
  explicit GilRelease(double work) {
    if (work >= kReleaseGilMinWork) r_.emplace();
  }

 private:
  std::optional<nb::gil_scoped_release> r_;
};

inline Points points_of(const BearingsIn& f1, const BearingsIn& f2) {
  if (f1.shape(1) != 3 || f2.shape(1) != 3) throw std::invalid_argument("bearings must have shape (n, 3)");
  if (f1.shape(0) != f2.shape(0)) throw std::invalid_argument("f1 and f2 must have the same number of rows");
  return Points{f1.data(), f2.data(), static_cast<int>(f1.shape(0))};
}

inline const double* weights_of(const std::optional<VectorIn>& w, int n) {
  if (!w) return nullptr;
  if (static_cast<int>(w->shape(0)) != n) throw std::invalid_argument("weights must have shape (n,)");
  return w->data();
}

// A new numpy float64 array of the given shape owning `data` (moved in).
template <size_t N>
NpArray to_numpy(std::vector<double>&& data, const size_t (&shape)[N]) {
  auto* heap = new std::vector<double>(std::move(data));
  nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<double>*>(p); });
  return NpArray(heap->data(), N, shape, owner);
}

template <typename T, size_t N>
nb::ndarray<nb::numpy, T> to_numpy_t(std::vector<T>&& data, const size_t (&shape)[N]) {
  auto* heap = new std::vector<T>(std::move(data));
  nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(heap->data(), N, shape, owner);
}

inline Pose pose_of(const ArrayIn& R, const ArrayIn& t) {
  if (R.size() != 9 || t.size() != 3) throw std::invalid_argument("R must be (3, 3) and t (3,)");
  Pose p;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) p.R(i, j) = R.data()[3 * i + j];
  for (int i = 0; i < 3; ++i) p.t(i) = t.data()[i];
  return p;
}

inline void put_pose(const Pose& p, double* R, double* t) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R[3 * i + j] = p.R(i, j);
  for (int i = 0; i < 3; ++i) t[i] = p.t(i);
}

// The pose as numpy arrays (R (3, 3), t (3,)), the elements the bindings return.
inline std::pair<NpArray, NpArray> pose_arrays(const Pose& p) {
  std::vector<double> R(9), t(3);
  put_pose(p, R.data(), t.data());
  return {to_numpy(std::move(R), {3, 3}), to_numpy(std::move(t), {3})};
}

}  // namespace poseonly
