// Shared types of poseonly's compiled core (C++17, Eigen).
//
// Conventions (as in the Python package): a point X1 in camera 1 maps to X2 = R X1 + t in camera 2,
// E = [t]x R, f2^T E f1 = 0 for unit bearings f1, f2; t has unit norm.
// Bearings arrive from numpy as C-contiguous (n, 3) float64 arrays and are read in place through
// `Points` (no copy); weights as (n,) float64 or nullptr (all ones).
#pragma once

#include <Eigen/Core>
#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

// Hot point loops (blocks over coordinate arrays) get an AVX2 clone chosen at load time where GCC
// on x86-64 Linux builds them (no FMA: every clone rounds as the scalar code).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define POSEONLY_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define POSEONLY_SIMD_CLONES
#endif

namespace poseonly {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Mat9 = Eigen::Matrix<double, 9, 9>;
using Vec9 = Eigen::Matrix<double, 9, 1>;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTiny = 1e-300;  // floor of divisors that may vanish

// A relative pose X2 = R X1 + t (unit t).
struct Pose {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
};

// Two views' bearings, read in place: point i of view v is data_v[3 i .. 3 i + 2].
struct Points {
  const double* f1 = nullptr;
  const double* f2 = nullptr;
  int n = 0;
  Eigen::Map<const Vec3> a(int i) const { return Eigen::Map<const Vec3>(f1 + 3 * i); }
  Eigen::Map<const Vec3> b(int i) const { return Eigen::Map<const Vec3>(f2 + 3 * i); }
};

// Owned bearings (samples, inlier subsets): the same layout as Points.
struct PointBuffer {
  std::vector<double> f1, f2;
  void clear() { f1.clear(); f2.clear(); }
  void push(const double* a, const double* b) {
    f1.insert(f1.end(), a, a + 3);
    f2.insert(f2.end(), b, b + 3);
  }
  Points view() const { return Points{f1.data(), f2.data(), static_cast<int>(f1.size() / 3)}; }
};

inline Mat3 skew(const Vec3& v) {
  Mat3 S;
  S << 0.0, -v(2), v(1), v(2), 0.0, -v(0), -v(1), v(0), 0.0;
  return S;
}

inline Mat3 essential(const Pose& p) { return skew(p.t) * p.R; }

// Robust loss of the refinements and of GNC/LO (one family, as PoseLib's robust/optim).
enum class Loss : int { Trivial = 0, Truncated = 1, Huber = 2, Cauchy = 3, TruncatedLeZach = 4 };

}  // namespace poseonly
