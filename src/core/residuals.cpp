#include "residuals.h"

namespace poseonly {

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

POSEONLY_SIMD_CLONES
void chiral_block(const Mat3& R, const Vec3& t, const SoaPoints& S, int i0, int m, double* out) {
  const double *x1 = S.x1.data() + i0, *y1 = S.y1.data() + i0, *z1 = S.z1.data() + i0;
  const double *x2 = S.x2.data() + i0, *y2 = S.y2.data() + i0, *z2 = S.z2.data() + i0;
  const Mat3 Rc = R;
  const double t0 = t(0), t1 = t(1), t2 = t(2);
  for (int k = 0; k < m; ++k) {  // depth_numerators in scalars, the same operations in the same order
    const double a0 = Rc(0, 0) * x1[k] + Rc(0, 1) * y1[k] + Rc(0, 2) * z1[k];
    const double a1 = Rc(1, 0) * x1[k] + Rc(1, 1) * y1[k] + Rc(1, 2) * z1[k];
    const double a2 = Rc(2, 0) * x1[k] + Rc(2, 1) * y1[k] + Rc(2, 2) * z1[k];
    const double c0 = a1 * z2[k] - a2 * y2[k], c1 = a2 * x2[k] - a0 * z2[k], c2 = a0 * y2[k] - a1 * x2[k];
    const double d0 = y2[k] * t2 - z2[k] * t1, d1 = z2[k] * t0 - x2[k] * t2, d2 = x2[k] * t1 - y2[k] * t0;
    const double e0 = a1 * t2 - a2 * t1, e1 = a2 * t0 - a0 * t2, e2 = a0 * t1 - a1 * t0;
    const double h = c0 * d0 + c1 * d1 + c2 * d2, hp = c0 * e0 + c1 * e1 + c2 * e2;
    out[k] = (h > 0.0 && hp > 0.0) ? out[k] : kChiralPenalty;
  }
}

}  // namespace poseonly
