#include "residuals.h"

namespace poseonly {

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define POSEONLY_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define POSEONLY_SIMD_CLONES
#endif

POSEONLY_SIMD_CLONES
void sampson_block(const Mat3& E, const SoaPoints& S, int i0, int m, double* out) {
  const double *x1 = S.x1.data() + i0, *y1 = S.y1.data() + i0, *z1 = S.z1.data() + i0;
  const double *x2 = S.x2.data() + i0, *y2 = S.y2.data() + i0, *z2 = S.z2.data() + i0;
  const Mat3 Ec = E;  // a local copy: no aliasing with out
  for (int k = 0; k < m; ++k) out[k] = sampson_terms(Ec, x1[k], y1[k], z1[k], x2[k], y2[k], z2[k]);
}

POSEONLY_SIMD_CLONES
void chord2_block(const Mat3& R, const SoaPoints& S, int i0, int m, double* out) {
  const double *x1 = S.x1.data() + i0, *y1 = S.y1.data() + i0, *z1 = S.z1.data() + i0;
  const double *x2 = S.x2.data() + i0, *y2 = S.y2.data() + i0, *z2 = S.z2.data() + i0;
  const Mat3 Rc = R;
  for (int k = 0; k < m; ++k) out[k] = chord2_terms(Rc, x1[k], y1[k], z1[k], x2[k], y2[k], z2[k]);
}

}  // namespace poseonly
