// Real eigenvalues of a small upper Hessenberg matrix through its characteristic polynomial and a
// Sturm sequence (the five-point solver's fast path; fivept.cpp). A Sturm count is exact for the
// computed polynomial, so a real root can only be missed when rounding moves it off the real line:
// when the polynomial has a near-multiple root (a near-double real root, or a complex pair close to
// the real axis, which the eigen-solver's kFiveptRealTol would keep). Such a polynomial makes p and p'
// nearly share a factor, which shows as a remainder of the Sturm chain that nearly vanishes; the
// functions then return false and the caller runs the Francis QR instead (linalg::hqr).
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

namespace poseonly {
namespace poly {

// A Sturm remainder whose leading coefficient is below this fraction of the dividend's largest
// coefficient (all members are scaled to a unit leading coefficient) marks a near-multiple root.
constexpr double kSturmDegenerateTol = 1e-8;
// ... and the product of those ratios over the chain below this: a cluster of roots shrinks every
// remainder a little (0.003 apart: ~1e-2 to 1e-4 a step) and its computed roots move or turn complex
// although no single step looks degenerate
constexpr double kSturmClusterTol = 0.0;
// a root of the characteristic polynomial is polished by Newton on det(H - x I) (Hyman's method:
// backward stable, unlike the coefficients); it must move by at most this fraction of the roots'
// scale, or the coefficients were not accurate enough (clustered eigenvalues) and the caller's QR runs
constexpr double kRootMoveTol = 1e-9;
constexpr int kHymanSteps = 3;
// the characteristic polynomial's error bound on [-2, 2], relative to sum |c_j| 2^j (the recurrence's
// rounding, with a margin): the real-root count must survive a shift of p by it
constexpr double kCountTol = 1e-12;
// the largest |H_ij| must lie within [this, 1 / this] (the N-fold products of the recurrence stay normal)
constexpr double kHessenbergMinScale = 1e-25;
// bisection levels at most when isolating the roots (a cluster still unresolved after them: false)
constexpr int kSturmMaxDepth = 80;
constexpr int kRootMaxIterations = 100;
// bracket width (of the scaled variable, roots in [-2, 2]) below which refine_root turns to Newton
constexpr double kRootBracket = 1.0 / 64.0;

// det(x I - H) of an upper Hessenberg N x N matrix: c[0..N] (c[j] the coefficient of x^j, c[N] = 1),
// by the recurrence over the leading principal submatrices (Hyman / La Budde), O(N^3):
// p_k = (x - h_kk) p_{k-1} - sum_{i<k} h_ik (prod_{m=i+1..k} h_{m,m-1}) p_{i-1} (1-based indices).
template <int N>
void charpoly_hessenberg(const Eigen::Matrix<double, N, N>& H, double c[N + 1]) {
  double P[N + 1][N + 1];
  for (auto& row : P) std::fill(row, row + N + 1, 0.0);
  P[0][0] = 1.0;
  for (int k = 1; k <= N; ++k) {
    const double hkk = H(k - 1, k - 1);
    for (int j = 0; j <= k; ++j) P[k][j] = (j > 0 ? P[k - 1][j - 1] : 0.0) - (j < k ? hkk * P[k - 1][j] : 0.0);
    double prod = 1.0;
    for (int i = k - 1; i >= 1; --i) {
      prod *= H(i, i - 1);
      const double f = H(i - 1, k - 1) * prod;
      if (f != 0.0)
        for (int j = 0; j < i; ++j) P[k][j] -= f * P[i - 1][j];
    }
  }
  for (int j = 0; j <= N; ++j) c[j] = P[N][j];
}

// The Sturm chain s_0 = p, s_1 = p' / N, s_{k+1} = -rem(s_{k-1}, s_k) / sigma_k (sigma_k > 0 scaling
// s_{k+1} to a unit leading coefficient; member k has degree N - k in a normal chain). Each member is
// evaluated by Horner from its own coefficients (the three-term recurrence of the quotients amplifies
// rounding by 1 / sigma_k and flipped signs far from the roots).
template <int N>
struct Sturm {
  double s[N + 1][N + 1];  // s[k][0..N-k]
  int len = 0;             // members (N + 1 for a normal chain)

  const double* p() const { return s[0]; }

  // false: a near-multiple root (a remainder nearly vanishes) or a non-finite chain
  bool build(const double* c) {
    double prod = 1.0;
    for (int j = 0; j <= N; ++j) s[0][j] = c[j];
    for (int j = 0; j < N; ++j) s[1][j] = (j + 1) * c[j + 1] / N;
    len = 2;
    double a[N + 1];
    for (int m = N - 1; m >= 1; --m) {  // divide s_{k-1} (degree m + 1) by s_k (degree m, |lc| = 1)
      const int k = N - m;
      const double* b = s[k];
      std::copy(s[k - 1], s[k - 1] + m + 2, a);
      double amax = 0.0;
      for (int j = 0; j <= m + 1; ++j) amax = std::max(amax, std::abs(a[j]));
      const double u1 = a[m + 1] / b[m];
      for (int j = m + 1; j >= 1; --j) a[j] -= u1 * b[j - 1];
      const double u0 = a[m] / b[m];
      for (int j = m; j >= 0; --j) a[j] -= u0 * b[j];
      const double lc = a[m - 1];  // the remainder a[0 .. m-1]
      if (!(std::abs(lc) > kSturmDegenerateTol * amax) || !std::isfinite(lc)) return false;
      prod *= std::abs(lc) / amax;
      if (!(prod > kSturmClusterTol)) return false;
      const double sc = -1.0 / std::abs(lc);
      for (int j = 0; j < m; ++j) s[k + 1][j] = a[j] * sc;
      ++len;
    }
    return true;
  }

  static double horner(const double* c, int deg, double x) {
    double v = c[deg];
    for (int j = deg - 1; j >= 0; --j) v = v * x + c[j];
    return v;
  }

  // sign changes of the chain at x (zeros skipped)
  int changes(double x) const {
    int ch = 0;
    double last = 0.0;
    for (int k = 0; k < len; ++k) {
      const double w = horner(s[k], N - k, x);
      if (w == 0.0) continue;
      if (last != 0.0 && ((w < 0.0) != (last < 0.0))) ++ch;
      last = w;
    }
    return ch;
  }

  // sign changes at -inf (negative = true) or +inf: the leading coefficients' signs (exact)
  int changes_at_infinity(bool negative) const {
    int ch = 0;
    double last = 0.0;
    for (int k = 0; k < len; ++k) {
      double w = s[k][N - k];
      if (negative && ((N - k) & 1)) w = -w;
      if (last != 0.0 && ((w < 0.0) != (last < 0.0))) ++ch;
      last = w;
    }
    return ch;
  }
};

// The root of the monic p in (lo, hi) where p changes sign (p(lo) = plo, p(hi) = phi): Newton steps,
// each replaced by an Illinois (modified regula falsi) step of the bracket when it leaves the
// bracket, to rounding level.
template <int N>
double refine_root(const double* p, double lo, double hi, double plo, double phi) {
  // bisection on the sign of p down to kRootBracket (Newton from a wide bracket crawls on a degree-N
  // polynomial: ~(1 - 1/N) per step far from the root)
  while (hi - lo > kRootBracket) {
    const double m = 0.5 * (lo + hi);
    const double v = Sturm<N>::horner(p, N, m);
    if (v == 0.0) return m;
    if ((v < 0.0) == (plo < 0.0)) {
      lo = m;
      plo = v;
    } else {
      hi = m;
      phi = v;
    }
  }
  double x = lo - plo * (hi - lo) / (phi - plo);
  int side = 0;  // which end the last bracket update kept (Illinois halves that end's value)
  for (int it = 0; it < kRootMaxIterations; ++it) {
    double v = p[N], dv = 0.0, mag = std::abs(p[N]);
    const double ax = std::abs(x);
    for (int j = N - 1; j >= 0; --j) {
      dv = dv * x + v;
      v = v * x + p[j];
      mag = mag * ax + std::abs(p[j]);
    }
    // |p(x)| within Horner's rounding error bound (~2N eps sum |c_j| |x|^j): x is a root to rounding
    if (std::abs(v) <= 2.0 * N * std::numeric_limits<double>::epsilon() * mag) return x;
    if ((v < 0.0) == (plo < 0.0)) {
      lo = x;
      plo = v;
      if (side == -1) phi *= 0.5;
      side = -1;
    } else {
      hi = x;
      phi = v;
      if (side == 1) plo *= 0.5;
      side = 1;
    }
    double xn = dv != 0.0 ? x - v / dv : lo;
    if (!(xn > lo && xn < hi)) xn = lo - plo * (hi - lo) / (phi - plo);
    if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
    const double tol = 4.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(xn));
    if (std::abs(xn - x) <= tol || !(hi - lo > tol)) return xn;
    x = xn;
  }
  return x;
}

// Newton on det(H - x I) of an upper Hessenberg H by Hyman's method (the first row's residual of the
// solution of rows 2..N with x_N = 1, and its derivative): false when a subdiagonal entry is zero or
// the iteration breaks down. x is updated in place.
template <int N>
bool hyman_newton(const Eigen::Matrix<double, N, N>& H, double* x) {
  for (int it = 0; it < kHymanSteps; ++it) {
    double v[N], d[N];
    v[N - 1] = 1.0;
    d[N - 1] = 0.0;
    for (int i = N - 1; i >= 1; --i) {
      const double b = H(i, i - 1);
      if (b == 0.0) return false;
      double sv = 0.0, sd = 0.0;
      for (int j = i; j < N; ++j) {
        const double a = H(i, j) - (i == j ? *x : 0.0);
        sv += a * v[j];
        sd += a * d[j];
      }
      sd -= v[i];
      v[i - 1] = -sv / b;
      d[i - 1] = -sd / b;
    }
    double r = 0.0, dr = 0.0;
    for (int j = 0; j < N; ++j) {
      const double a = H(0, j) - (j == 0 ? *x : 0.0);
      r += a * v[j];
      dr += a * d[j];
    }
    dr -= v[0];
    if (!(std::isfinite(r) && std::isfinite(dr))) return false;
    if (r == 0.0) return true;
    if (dr == 0.0) return false;
    const double step = r / dr;
    *x -= step;
    if (std::abs(step) <= 4.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(*x))) return true;
  }
  return true;
}

// Real eigenvalues (ascending, each distinct root once) of an upper Hessenberg N x N matrix H; false
// when the Sturm chain shows a near-multiple root or the isolation fails (the caller falls back to an
// eigen-solver). The variable is scaled by a power of two, x = rho y with |c_j| < rho^(N - j), so that
// every coefficient of the polynomial in y is below 1 (the chain's tolerance is then scale-free) and,
// by Fujiwara's bound, every root |y| <= 2.
template <int N>
bool hessenberg_real_eigenvalues(const Eigen::Matrix<double, N, N>& H, double* roots, int* count) {
  *count = 0;
  if (!H.allFinite()) return false;
  // far from 1 the recurrence's products under- or overflow (the caller's QR balances its own way)
  const double hmax = H.cwiseAbs().maxCoeff();
  if (!(hmax > kHessenbergMinScale && hmax < 1.0 / kHessenbergMinScale)) return false;
  double c[N + 1];
  charpoly_hessenberg<N>(H, c);
  int e = -1022;
  for (int j = 0; j < N; ++j)
    if (c[j] != 0.0) {
      if (!std::isfinite(c[j])) return false;
      const int m = N - j, b = std::ilogb(c[j]) + 1;  // |c_j| < 2^b
      e = std::max(e, b >= 0 ? (b + m - 1) / m : -((-b) / m));  // ceil(b / m)
    }
  if (e == -1022) {  // x^N: every eigenvalue is zero (a multiple root)
    return false;
  }
  double cy[N + 1];
  for (int j = 0; j <= N; ++j) cy[j] = std::ldexp(c[j], -e * (N - j));
  Sturm<N> S;
  if (!S.build(cy)) return false;
  // the count must not depend on the coefficients' rounding: on each half [0, 2] and [-2, 0] of the
  // roots' range, p - e and p + e, e(y) = kCountTol sum |c_j| |y|^j (a bound of p's error there),
  // must have as many real roots as p, or a cluster of roots may have turned complex (a pair lost
  // without a near-zero remainder) or a near-real pair real
  for (const double side : {1.0, -1.0}) {
    double q[N + 1];  // p(side y), y in [0, 2]
    for (int j = 0; j <= N; ++j) q[j] = (side < 0.0 && (j & 1)) ? -cy[j] : cy[j];
    Sturm<N> Q;
    if (!Q.build(q)) return false;
    const int n0 = Q.changes(0.0) - Q.changes(2.0);
    for (const double sign : {-1.0, 1.0}) {
      double cs[N + 1];
      for (int j = 0; j <= N; ++j) cs[j] = q[j] + sign * kCountTol * std::abs(q[j]);
      Sturm<N> T;
      if (!T.build(cs) || T.changes(0.0) - T.changes(2.0) != n0) return false;
    }
  }
  constexpr double B = 2.0 + 1e-9;
  struct Span {
    double lo, hi;
    int vlo, vhi, depth;
  };
  Span stack[kSturmMaxDepth + N + 2];
  int top = 0;
  stack[top++] = {-B, B, S.changes_at_infinity(true), S.changes_at_infinity(false), 0};
  while (top > 0) {
    const Span s = stack[--top];
    const int k = s.vlo - s.vhi;
    if (k < 0) return false;  // counts that increase: an inconsistent chain
    if (k == 0) continue;
    if (k == 1) {
      const double plo = Sturm<N>::horner(S.p(), N, s.lo), phi = Sturm<N>::horner(S.p(), N, s.hi);
      if (!((plo < 0.0) != (phi < 0.0)) || plo == 0.0 || phi == 0.0) return false;
      if (*count >= N) return false;
      const double x0 = std::ldexp(refine_root<N>(S.p(), s.lo, s.hi, plo, phi), e);
      double x = x0;
      if (!hyman_newton<N>(H, &x) || !(std::abs(x - x0) <= kRootMoveTol * std::ldexp(1.0, e))) return false;
      roots[(*count)++] = x;
      continue;
    }
    if (s.depth >= kSturmMaxDepth || top + 2 > static_cast<int>(sizeof(stack) / sizeof(stack[0]))) return false;
    const double mid = 0.5 * (s.lo + s.hi);
    const int vm = S.changes(mid);
    stack[top++] = {mid, s.hi, vm, s.vhi, s.depth + 1};
    stack[top++] = {s.lo, mid, s.vlo, vm, s.depth + 1};
  }
  std::sort(roots, roots + *count);
  return true;
}

}  // namespace poly
}  // namespace poseonly
