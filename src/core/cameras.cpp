#include "cameras.h"

#include <algorithm>
#include <cmath>

namespace poseonly {

namespace {

// The radial factor and the Jacobian's determinant of the distortion at (u, v) (the fold checks).
inline void fold_terms(double u, double v, const double k[8], double* rad, double* det) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  const double r2 = u * u + v * v;
  const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
  const double dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
  const double dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
  *rad = num / den;
  const double drad = (dnum * den - num * dden) / (den * den);
  const double j11 = *rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u;
  const double j12 = 2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v;
  const double j21 = 2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u;
  const double j22 = *rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v;
  *det = j11 * j22 - j12 * j21;
}

inline void distort_brown(double u, double v, const double k[8], double* xd, double* yd) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  const double r2 = u * u + v * v;
  const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
  const double rad = num / den;
  const double uv = u * v;
  *xd = u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u);
  *yd = v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v);
}

// The first x in (0, hi] where an increasing radial map stops increasing (its derivative dh(x) <= 0,
// or not finite): a grid of kFoldSteps points, quadratically spaced (fine near the centre, where a
// strong distortion folds first), then bisection to the last x where it still increases; hi when it
// increases throughout. A root beyond it lies on a later branch of the map (rising again after a fall),
// which Newton's method may find while the point has no preimage on the first, physical branch.
constexpr int kFoldSteps = 1024;
constexpr int kFoldBisections = 60;

template <class D>
double first_fold(D dh, double hi) {
  auto grid = [hi](int s) {
    const double q = static_cast<double>(s) / kFoldSteps;
    return hi * (q * q);
  };
  for (int s = 1; s <= kFoldSteps; ++s) {
    const double x = grid(s);
    if (dh(x) > 0.0) continue;
    double a = grid(s - 1), b = x;
    for (int it = 0; it < kFoldBisections; ++it) {
      const double m = 0.5 * (a + b);
      (dh(m) > 0.0 ? a : b) = m;
    }
    return a;
  }
  return hi;
}

// the largest undistorted radius tan(theta) whose fold a Brown model is checked for (89.9 deg off-axis)
constexpr double kBrownFoldMaxRadius = 573.0;

}  // namespace

void undistort_brown(const double* xd, const double* yd, int n, const double k[8], double tol, int max_iter, double* u_out, double* v_out,
                     uint8_t* ok) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  // the radial map r -> r rad(r^2) must increase from the centre to the root (its first fold bounds
  // the physical branch; the local checks below cannot see a root on a later rising branch)
  const double r_fold = first_fold(
      [&](double r) {
        const double r2 = r * r;
        const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
        const double dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
        const double dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
        if (!(den > 0.0)) return -1.0;  // the rational model's pole: the map's branch ends there
        return num / den + 2.0 * r2 * (dnum * den - num * dden) / (den * den);
      },
      kBrownFoldMaxRadius);
  for (int i = 0; i < n; ++i) {
    const double x = xd[i], y = yd[i];
    double u = x, v = y;
    bool done = false;
    for (int it = 0; it < max_iter && !done; ++it) {
      const double r2 = u * u + v * v;
      const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
      const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
      const double dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
      const double dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
      const double rad = num / den;
      const double drad = (dnum * den - num * dden) / (den * den);
      const double uv = u * v;
      const double fu = u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u) - x;
      const double fv = v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v) - y;
      const double j11 = rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u;
      const double j12 = 2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v;
      const double j21 = 2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u;
      const double j22 = rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v;
      const double det = j11 * j22 - j12 * j21;
      const double du = (j22 * fu - j12 * fv) / det;
      const double dv = (j11 * fv - j21 * fu) / det;
      u = u - du;
      v = v - dv;
      done = std::hypot(du, dv) <= tol * std::max(1.0, std::hypot(u, v));
    }
    // the root is the physical one only where the map is locally invertible and preserves orientation
    // (det J > 0) and the radial factor does not flip the point through the centre, both at the root
    double rad, det;
    fold_terms(u, v, k, &rad, &det);
    bool good = done && std::isfinite(u) && std::isfinite(v) && rad > 0.0 && det > 0.0 && (r_fold >= kBrownFoldMaxRadius || std::hypot(u, v) < r_fold);
    double ru, rv;
    distort_brown(u, v, k, &ru, &rv);
    good = good && std::hypot(ru - x, rv - y) <= 1e-9 * std::max(1.0, std::hypot(x, y));
    u_out[i] = u;
    v_out[i] = v;
    ok[i] = good;
  }
}

void undistort_fisheye(const double* rd, int n, const double k[4], double tol, int max_iter, double* theta_out, uint8_t* ok) {
  const double k1 = k[0], k2 = k[1], k3 = k[2], k4 = k[3];
  auto poly = [=](double th, double* g, double* dg) {
    const double t2 = th * th;
    *g = th * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
    *dg = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
  };
  // theta must lie before the polynomial's first fold and below pi (a direction past 180 deg folds back
  // onto one below it)
  constexpr double kPi = 3.141592653589793;
  const double th_max = first_fold(
      [&](double th) {
        double g, dg;
        poly(th, &g, &dg);
        return dg;
      },
      kPi);
  for (int i = 0; i < n; ++i) {
    const double r = rd[i];
    double th = r, g, dg;
    bool done = false;
    for (int it = 0; it < max_iter && !done; ++it) {
      poly(th, &g, &dg);
      const double step = (g - r) / dg;
      th = th - step;
      done = std::abs(step) <= tol * std::max(1.0, th);
    }
    poly(th, &g, &dg);
    theta_out[i] = th;
    ok[i] = done && std::isfinite(th) && th >= 0.0 && th < th_max && dg > 0.0 && std::abs(g - r) <= 1e-9 * std::max(1.0, r);
  }
}

}  // namespace poseonly
