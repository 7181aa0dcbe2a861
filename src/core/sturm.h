// Real roots of a univariate polynomial by a Sturm sequence: bisection on the sign-change count
// isolates every distinct real root in a bounded interval, then safeguarded Newton (bisection
// whenever a Newton step leaves the bracket) converges on each. Used for the degree-10
// polynomial of the five-point solver (fivept.cpp, Nister's construction).
//
// The caller gets false when the chain shows a (near-)multiple root: a remainder whose leading
// coefficient vanishes relative to its dividend. Its count is then not trustworthy and the caller
// takes a slower, backward-stable path (the action matrix's eigenvalues).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace poseonly {
namespace sturm {

// a remainder's leading coefficient below this fraction of its dividend's largest coefficient
// (both scaled to a unit leading coefficient) marks a near-multiple root
constexpr double kDegenerateTol = 1e-10;
constexpr int kMaxDepth = 64;       // bisection levels at most while isolating (then: false)
constexpr int kMaxIterations = 80;  // Newton / bisection steps per isolated root
// a root is returned when the last step is below this fraction of max(1, |x|): the five-point
// solver's callers polish every solution (Newton on the pose, Gauss-Newton on the template), so the
// last Newton step to rounding level here (~5 % of a five-point call) buys nothing
constexpr double kRootRelTol = 1e-11;

inline double horner(const double* c, int deg, double x) {
  double v = c[deg];
  for (int j = deg - 1; j >= 0; --j) v = v * x + c[j];
  return v;
}

// The Sturm chain of a polynomial of degree N (ascending coefficients, c[N] != 0).
template <int N>
struct Chain {
  double s[N + 1][N + 1];  // s[k]: degree N - k, ascending, leading coefficient +-1
  int len = 0;

  bool build(const double* c) {
    const double lead = c[N];
    if (!(std::abs(lead) > 0.0) || !std::isfinite(lead)) return false;
    for (int j = 0; j <= N; ++j) s[0][j] = c[j] / lead;
    for (int j = 0; j < N; ++j) s[1][j] = (j + 1) * s[0][j + 1] / N;
    len = 2;
    for (int k = 1; k < N; ++k) {
      // remainder of s[k-1] (degree m + 1) by s[k] (degree m), leading coefficients +-1: two
      // division steps
      const int m = N - k;
      double a[N + 1];
      for (int j = 0; j <= m + 1; ++j) a[j] = s[k - 1][j];
      const double* b = s[k];
      double amax = 0.0;
      for (int j = 0; j <= m + 1; ++j) amax = std::max(amax, std::abs(a[j]));
      const double q1 = a[m + 1] / b[m];
      for (int j = 0; j <= m; ++j) a[j + 1] -= q1 * b[j];
      const double q0 = a[m] / b[m];
      for (int j = 0; j <= m; ++j) a[j] -= q0 * b[j];
      const double lc = a[m - 1];
      if (!(std::abs(lc) > kDegenerateTol * amax) || !std::isfinite(lc)) return false;
      const double sc = -1.0 / std::abs(lc);  // -remainder, scaled (a positive factor keeps the signs)
      for (int j = 0; j < m; ++j) s[k + 1][j] = a[j] * sc;
      ++len;
    }
    return len == N + 1;
  }

  // sign changes of the chain at x (zeros skipped)
  int changes(double x) const {
    int n = 0;
    double prev = 0.0;
    for (int k = 0; k < len; ++k) {
      const double v = horner(s[k], N - k, x);
      if (v == 0.0) continue;
      if (prev != 0.0 && ((v < 0.0) != (prev < 0.0))) ++n;
      prev = v;
    }
    return n;
  }
};

// The root in [lo, hi] of p (degree N) where p(lo), p(hi) have opposite signs: Newton, bisecting
// whenever a step would leave the bracket or would not halve the previous step (Numerical Recipes'
// rtsafe: far from the root a degree-N polynomial's Newton steps shrink by only ~1/N).
template <int N>
double refine(const double* p, double lo, double hi, double plo) {
  double dp[N];
  for (int j = 0; j < N; ++j) dp[j] = (j + 1) * p[j + 1];
  if (plo > 0.0) std::swap(lo, hi);  // orient: p(lo) < 0 < p(hi)
  double x = 0.5 * (lo + hi), dx_old = std::abs(hi - lo), dx = dx_old;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double v = horner(p, N, x);
    if (v == 0.0) return x;
    if (v < 0.0) lo = x;
    else hi = x;
    const double d = horner(dp, N - 1, x);
    const double xn = x - v / d;
    const bool newton = d != 0.0 && std::isfinite(xn) && (xn - lo) * (xn - hi) < 0.0 && std::abs(2.0 * v) <= std::abs(dx_old * d);
    dx_old = dx;
    if (newton) {
      dx = v / d;
      x = xn;
    } else {
      dx = 0.5 * (hi - lo);
      x = lo + dx;
    }
    if (std::abs(dx) <= kRootRelTol * std::max(1.0, std::abs(x))) return x;
  }
  return x;
}

// The distinct real roots (ascending) of c[0] + c[1] x + ... + c[N] x^N; false when the chain shows
// a near-multiple root, the leading coefficient vanishes, or the isolation fails.
template <int N>
bool real_roots(const double* c, double* roots, int* count) {
  *count = 0;
  Chain<N> S;
  if (!S.build(c)) return false;
  const double* p = S.s[0];
  double bound = 0.0;  // Fujiwara's bound on the roots of the monic p
  for (int j = 1; j < N; ++j) bound = std::max(bound, std::pow(std::abs(p[j]), 1.0 / (N - j)));
  bound = std::max(bound, std::pow(0.5 * std::abs(p[0]), 1.0 / N));
  bound = 2.0 * bound * (1.0 + 1e-12) + 1e-300;
  if (!std::isfinite(bound)) return false;
  struct Span {
    double lo, hi;
    int vlo, vhi, depth;
  };
  Span stack[kMaxDepth * 2 + 4];
  int top = 0;
  stack[top++] = {-bound, bound, S.changes(-bound), S.changes(bound), 0};
  while (top > 0) {
    const Span sp = stack[--top];
    const int k = sp.vlo - sp.vhi;
    if (k < 0) return false;  // counts that increase: an inconsistent chain
    if (k == 0) continue;
    const double plo = horner(p, N, sp.lo), phi = horner(p, N, sp.hi);
    if (k == 1 && plo != 0.0 && phi != 0.0 && ((plo < 0.0) != (phi < 0.0))) {
      if (*count >= N) return false;
      roots[(*count)++] = refine<N>(p, sp.lo, sp.hi, plo);
      continue;
    }
    if (sp.depth >= kMaxDepth || top + 2 > kMaxDepth * 2 + 4) return false;
    const double mid = 0.5 * (sp.lo + sp.hi);
    const int vm = S.changes(mid);
    stack[top++] = {mid, sp.hi, vm, sp.vhi, sp.depth + 1};
    stack[top++] = {sp.lo, mid, sp.vlo, vm, sp.depth + 1};
  }
  std::sort(roots, roots + *count);
  return true;
}

}  // namespace sturm
}  // namespace poseonly
