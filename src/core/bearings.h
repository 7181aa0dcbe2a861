// Bearing rows scaled to unit length: the one implementation behind poseonly.geometry._unit_rows,
// the pixel bearings and the public LiRP's fast path.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace poseonly {

// Rows x (n, 3) scaled to unit length into out (poseonly.geometry._unit_rows): when every row's largest
// |component| m lies in (1e-150, 1e150), the plain norm sqrt(x x + y y + z z) and zero rows those of
// norm < zero; otherwise plain rows as before and the others divided by m first (no overflow or
// underflow), zero rows those with m < zero / sqrt(3). Counts the zero rows and the rows with a NaN or
// inf component; when there is one of the latter, no row is computed.
inline void unit_rows_into(const double* x, size_t n, double zero, double* out, int64_t* zeros, int64_t* nonfinite) {
  constexpr double kHuge = 1e150, kTiny = 1e-150;
  bool plain = true;
  *zeros = *nonfinite = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!(std::isfinite(x[3 * i]) && std::isfinite(x[3 * i + 1]) && std::isfinite(x[3 * i + 2]))) {
      ++*nonfinite;
      continue;
    }
    const double m = std::max({std::abs(x[3 * i]), std::abs(x[3 * i + 1]), std::abs(x[3 * i + 2])});
    plain = plain && m < kHuge && m > kTiny;
  }
  for (size_t i = 0; i < n && !*nonfinite; ++i) {
    const double* r = x + 3 * i;
    double* o = out + 3 * i;
    const double m = std::max({std::abs(r[0]), std::abs(r[1]), std::abs(r[2])});
    if (plain || (m < kHuge && m > kTiny)) {
      const double nrm = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
      if (plain ? nrm < zero : m < zero / std::sqrt(3.0)) ++*zeros;
      for (int c = 0; c < 3; ++c) o[c] = r[c] / nrm;
    } else {
      if (m < zero / std::sqrt(3.0)) ++*zeros;
      const double b0 = r[0] / m, b1 = r[1] / m, b2 = r[2] / m;
      const double nb_ = std::sqrt(b0 * b0 + b1 * b1 + b2 * b2);
      o[0] = b0 / nb_, o[1] = b1 / nb_, o[2] = b2 / nb_;
    }
  }
}

}  // namespace poseonly
