#include "cameras.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

// The fallback where Newton's method from the distorted point fails (it can oscillate, or overshoot past
// the fold onto a later branch, on strong distortion; a SLAM user's trial: in-image pixels of a fisheye
// and of a rational camera refused): the root of an increasing map g on [0, hi] with g(0) <= target,
// Newton steps kept inside a shrinking bracket (bisection where a step leaves it); NaN where g(hi) <
// target (no root on the physical branch).
constexpr int kBracketIterations = 200;
constexpr double kRootValueTol = 1e-9;  // |g(x) - target| (relative) at which a tiny step ends the search

template <class G>
double bracketed_root(G g, double target, double hi, double tol) {
  double val, d;
  g(hi, &val, &d);
  if (!(val >= target)) return std::numeric_limits<double>::quiet_NaN();
  double a = 0.0, b = hi, x = std::min(target, hi);
  for (int it = 0; it < kBracketIterations; ++it) {
    g(x, &val, &d);
    if (val == target) return x;
    (val < target ? a : b) = x;
    double nx = x - (val - target) / d;
    // a tiny Newton step far from the target is no convergence (beside a rational model's pole the map's
    // slope is huge: a fuzz of random lenses stopped there, at the bracket's end): bisect instead
    const bool stalled = std::abs(nx - x) <= tol * std::max(1.0, nx) && !(std::abs(val - target) <= kRootValueTol * std::max(1.0, target));
    if (!(nx > a && nx < b) || stalled) nx = 0.5 * (a + b);
    if (std::abs(nx - x) <= tol * std::max(1.0, nx) || b - a <= tol * std::max(1.0, b)) return nx;
    x = nx;
  }
  return x;
}

// Brown's distortion residual F = distort(u, v) - (x, y) and its Jacobian (the Newton loop's terms).
inline void brown_residual(double u, double v, double x, double y, const double k[8], double* fu, double* fv, double J[4]) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  const double r2 = u * u + v * v;
  const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
  const double dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
  const double dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
  const double rad = num / den;
  const double drad = (dnum * den - num * dden) / (den * den);
  const double uv = u * v;
  *fu = u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u) - x;
  *fv = v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v) - y;
  J[0] = rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u;
  J[1] = 2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v;
  J[2] = 2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u;
  J[3] = rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v;
}

// The Brown fallback: the radial map's root on its first branch (tangential terms left out) as the start,
// then Newton steps halved until the residual decreases. True where the steps converged.
constexpr int kDampedHalvings = 40;

bool undistort_brown_fallback(double x, double y, const double k[8], double r_fold, double tol, int max_iter, double* u, double* v) {
  const double k1 = k[0], k2 = k[1], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  const double rd = std::hypot(x, y);
  if (!(rd > 0.0) || !std::isfinite(rd)) return false;
  double ru = bracketed_root(
      [&](double r, double* h, double* dh) {
        const double r2 = r * r;
        const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
        const double dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
        const double dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
        *h = r * num / den;
        *dh = num / den + 2.0 * r2 * (dnum * den - num * dden) / (den * den);
      },
      rd, std::min(r_fold, kBrownFoldMaxRadius), tol);
  // the tangential terms can carry a pixel past the radial map's largest value while its root lies
  // before the fold: damped Newton then starts at the fold
  if (!std::isfinite(ru) && r_fold < kBrownFoldMaxRadius) ru = r_fold;
  if (!std::isfinite(ru)) return false;
  double cu = x * (ru / rd), cv = y * (ru / rd);
  double fu, fv, J[4];
  brown_residual(cu, cv, x, y, k, &fu, &fv, J);
  double norm = std::hypot(fu, fv);
  for (int it = 0; it < max_iter; ++it) {
    const double det = J[0] * J[3] - J[1] * J[2];
    const double du = (J[3] * fu - J[1] * fv) / det, dv = (J[0] * fv - J[2] * fu) / det;
    if (!std::isfinite(du) || !std::isfinite(dv)) return false;
    double s = 1.0, nu = cu, nv = cv, nfu = fu, nfv = fv, nJ[4] = {J[0], J[1], J[2], J[3]};
    bool better = false;
    for (int h = 0; h <= kDampedHalvings && !better; ++h, s *= 0.5) {
      nu = cu - s * du;
      nv = cv - s * dv;
      brown_residual(nu, nv, x, y, k, &nfu, &nfv, nJ);
      better = std::hypot(nfu, nfv) < norm;
    }
    if (!better) break;  // no halving decreases the residual: the point stays where it is
    const double step = std::hypot(nu - cu, nv - cv);
    cu = nu;
    cv = nv;
    fu = nfu;
    fv = nfv;
    norm = std::hypot(fu, fv);
    for (int c = 0; c < 4; ++c) J[c] = nJ[c];
    if (step <= tol * std::max(1.0, std::hypot(cu, cv))) break;
  }
  *u = cu;
  *v = cv;
  return std::isfinite(cu) && std::isfinite(cv);
}

}  // namespace

namespace {

// the radial map r -> r rad(r^2) must increase from the centre to the root (its first fold bounds the
// physical branch; the local checks cannot see a root on a later rising branch)
double brown_fold(const double k[8]) {
  const double k1 = k[0], k2 = k[1], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  return first_fold(
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
}

constexpr double kFisheyePi = 3.141592653589793;

double fisheye_fold(const double k[4]) {
  const double k1 = k[0], k2 = k[1], k3 = k[2], k4 = k[3];
  return first_fold(
      [=](double th) {
        const double t2 = th * th;
        return 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
      },
      kFisheyePi);
}

}  // namespace

void undistort_brown(const double* xd, const double* yd, int n, const double k[8], double tol, int max_iter, double* u_out, double* v_out,
                     uint8_t* ok) {
  const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], k5 = k[6], k6 = k[7];
  const double r_fold = brown_fold(k);
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
    if (!good && undistort_brown_fallback(x, y, k, r_fold, tol, max_iter, &u, &v)) {  // the same checks
      fold_terms(u, v, k, &rad, &det);
      distort_brown(u, v, k, &ru, &rv);
      good = rad > 0.0 && det > 0.0 && (r_fold >= kBrownFoldMaxRadius || std::hypot(u, v) < r_fold) &&
             std::hypot(ru - x, rv - y) <= 1e-9 * std::max(1.0, std::hypot(x, y));
    }
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
  const double th_max = fisheye_fold(k);
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
    bool good = done && std::isfinite(th) && th >= 0.0 && th < th_max && dg > 0.0 && std::abs(g - r) <= 1e-9 * std::max(1.0, r);
    if (!good && r >= 0.0 && std::isfinite(r)) {  // the fallback: the polynomial increases on [0, th_max]
      th = bracketed_root(poly, r, th_max, tol);
      poly(th, &g, &dg);
      good = std::isfinite(th) && th >= 0.0 && th < th_max && dg > 0.0 && std::abs(g - r) <= 1e-9 * std::max(1.0, r);
    }
    theta_out[i] = th;
    ok[i] = good;
  }
}

namespace {

// The thin-prism fisheye distortions of COLMAP's models.h on the equidistant coordinates (u, v): the
// distorted point (x, y) and the Jacobian J = d(x, y) / d(u, v) (row-major).
inline void prism_distort(int kind, const double k[12], double u, double v, double* x, double* y, double J[4]) {
  if (kind == 0) {  // THIN_PRISM_FISHEYE: (k1, k2, p1, p2, k3, k4, sx1, sy1)
    const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4], k4 = k[5], sx1 = k[6], sy1 = k[7];
    const double r2 = u * u + v * v;
    const double radial = r2 * (k1 + r2 * (k2 + r2 * (k3 + r2 * k4)));
    const double dradial = k1 + r2 * (2.0 * k2 + r2 * (3.0 * k3 + r2 * 4.0 * k4));  // d radial / d r2
    *x = u + u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u) + sx1 * r2;
    *y = v + v * radial + 2.0 * p2 * u * v + p1 * (r2 + 2.0 * v * v) + sy1 * r2;
    J[0] = 1.0 + radial + 2.0 * u * u * dradial + 2.0 * p1 * v + 6.0 * p2 * u + 2.0 * sx1 * u;
    J[1] = 2.0 * u * v * dradial + 2.0 * p1 * u + 2.0 * p2 * v + 2.0 * sx1 * v;
    J[2] = 2.0 * u * v * dradial + 2.0 * p2 * v + 2.0 * p1 * u + 2.0 * sy1 * u;
    J[3] = 1.0 + radial + 2.0 * v * v * dradial + 2.0 * p2 * u + 6.0 * p1 * v + 2.0 * sy1 * v;
    return;
  }
  // RAD_TAN_THIN_PRISM_FISHEYE: (k0, ..., k5, p0, p1, s0, s1, s2, s3)
  const double p0 = k[6], p1 = k[7], s0 = k[8], s1 = k[9], s2 = k[10], s3 = k[11];
  const double t2 = u * u + v * v;
  double th = 0.0, dth = 0.0;  // th_radial - 1 and its derivative in t2, by Horner
  for (int i = 5; i >= 0; --i) {
    dth = dth * t2 + (i + 1) * k[i];
    th = th * t2 + k[i];
  }
  th = 1.0 + th * t2;
  const double a = th * u, b = th * v;  // the radially distorted point
  // d(a, b) / d(u, v) = th I + 2 dth (u, v)^T (u, v)
  const double A00 = th + 2.0 * dth * u * u, A01 = 2.0 * dth * u * v, A11 = th + 2.0 * dth * v * v;
  const double r2 = a * a + b * b;
  const double cx = s0 + 2.0 * s1 * r2, cy = s2 + 2.0 * s3 * r2;  // d(prism) / d r2
  *x = a + 2.0 * p1 * a * b + p0 * (r2 + 2.0 * a * a) + r2 * (s0 + s1 * r2);
  *y = b + 2.0 * p0 * a * b + p1 * (r2 + 2.0 * b * b) + r2 * (s2 + s3 * r2);
  const double B00 = 1.0 + 2.0 * p1 * b + 6.0 * p0 * a + 2.0 * a * cx;
  const double B01 = 2.0 * p1 * a + 2.0 * p0 * b + 2.0 * b * cx;
  const double B10 = 2.0 * p0 * b + 2.0 * p1 * a + 2.0 * a * cy;
  const double B11 = 1.0 + 2.0 * p0 * a + 6.0 * p1 * b + 2.0 * b * cy;
  J[0] = B00 * A00 + B01 * A01;
  J[1] = B00 * A01 + B01 * A11;
  J[2] = B10 * A00 + B11 * A01;
  J[3] = B10 * A01 + B11 * A11;
}

// The radial part of a thin-prism model, theta -> theta (1 + sum), and its derivative (the fold and the
// fallback's start).
inline void prism_radial(int kind, const double k[12], double t, double* h, double* dh) {
  const double t2 = t * t;
  double s = 0.0, ds = 0.0;
  if (kind == 0) {
    const double c[4] = {k[0], k[1], k[4], k[5]};
    for (int i = 3; i >= 0; --i) {
      s = s * t2 + c[i];
      ds = ds * t2 + (2 * i + 3) * c[i];
    }
  } else {
    for (int i = 5; i >= 0; --i) {
      s = s * t2 + k[i];
      ds = ds * t2 + (2 * i + 3) * k[i];
    }
  }
  *h = t * (1.0 + s * t2);
  *dh = 1.0 + ds * t2;
}

bool prism_good(int kind, const double k[12], double u, double v, double x, double y, double th_max) {
  if (!std::isfinite(u) || !std::isfinite(v)) return false;
  double px, py, J[4];
  prism_distort(kind, k, u, v, &px, &py, J);
  const double t = std::hypot(u, v);
  return t < th_max && J[0] * J[3] - J[1] * J[2] > 0.0 && std::hypot(px - x, py - y) <= 1e-9 * std::max(1.0, std::hypot(x, y));
}

}  // namespace

// Damped Newton on the thin-prism distortion from (cu, cv): steps halved until the residual decreases
// (as Brown's fallback); the last point in (u, v).
constexpr int kPrismStarts = 8;

static void prism_damped(int kind, const double k[12], double x, double y, double cu, double cv, double tol, int max_iter, double* u,
                         double* v) {
  double px, py, J[4];
  prism_distort(kind, k, cu, cv, &px, &py, J);
  double fu = px - x, fv = py - y, norm = std::hypot(fu, fv);
  for (int it = 0; it < max_iter; ++it) {
    const double det = J[0] * J[3] - J[1] * J[2];
    const double du = (J[3] * fu - J[1] * fv) / det, dv = (J[0] * fv - J[2] * fu) / det;
    if (!std::isfinite(du) || !std::isfinite(dv)) break;
    double s = 1.0, nu = cu, nv = cv, nJ[4];
    bool better = false;
    for (int h = 0; h <= kDampedHalvings && !better; ++h, s *= 0.5) {
      nu = cu - s * du;
      nv = cv - s * dv;
      prism_distort(kind, k, nu, nv, &px, &py, nJ);
      better = std::hypot(px - x, py - y) < norm;
    }
    if (!better) break;
    const double step = std::hypot(nu - cu, nv - cv);
    cu = nu;
    cv = nv;
    fu = px - x;
    fv = py - y;
    norm = std::hypot(fu, fv);
    for (int c = 0; c < 4; ++c) J[c] = nJ[c];
    if (step <= tol * std::max(1.0, std::hypot(cu, cv))) break;
  }
  *u = cu;
  *v = cv;
}

static double prism_fold(int kind, const double k[12]) {
  return first_fold(
      [&](double t) {
        double h, dh;
        prism_radial(kind, k, t, &h, &dh);
        return dh;
      },
      kFisheyePi);
}

void undistort_prism(const double* xd, const double* yd, int n, int kind, const double k[12], double tol, int max_iter, double* uu_out,
                     double* vv_out, uint8_t* ok) {
  const double th_max = prism_fold(kind, k);
  for (int i = 0; i < n; ++i) {
    const double x = xd[i], y = yd[i];
    double u = x, v = y;
    bool done = false;
    for (int it = 0; it < max_iter && !done; ++it) {
      double px, py, J[4];
      prism_distort(kind, k, u, v, &px, &py, J);
      const double fu = px - x, fv = py - y;
      const double det = J[0] * J[3] - J[1] * J[2];
      const double du = (J[3] * fu - J[1] * fv) / det, dv = (J[0] * fv - J[2] * fu) / det;
      u -= du;
      v -= dv;
      done = std::hypot(du, dv) <= tol * std::max(1.0, std::hypot(u, v));
    }
    bool good = done && prism_good(kind, k, u, v, x, y, th_max);
    const double rd = std::hypot(x, y);
    if (!good && rd > 0.0 && std::isfinite(rd)) {  // the fallback: the radial root, then damped Newton
      double t0 = bracketed_root([&](double t, double* h, double* dh) { prism_radial(kind, k, t, h, dh); }, rd, th_max, tol);
      // the tangential and prism terms can carry a pixel past the radial part's largest radius while its
      // root lies before the fold (a review): damped Newton then starts at the fold
      if (!std::isfinite(t0) && th_max < kFisheyePi) t0 = th_max;
      if (std::isfinite(t0)) {
        prism_damped(kind, k, x, y, x * (t0 / rd), y * (t0 / rd), tol, max_iter, &u, &v);
        good = prism_good(kind, k, u, v, x, y, th_max);
      }
      // strong tangential / prism terms can leave damped Newton in a local minimum of the residual (a
      // review's fuzz of Fisheye624 lenses): more starts along the pixel's direction, inside the fold
      for (int s = 1; !good && s < kPrismStarts; ++s) {
        const double ts = th_max * s / kPrismStarts;
        prism_damped(kind, k, x, y, x * (ts / rd), y * (ts / rd), tol, max_iter, &u, &v);
        good = prism_good(kind, k, u, v, x, y, th_max);
      }
    }
    uu_out[i] = u;
    vv_out[i] = v;
    ok[i] = good;
  }
}

}  // namespace poseonly
