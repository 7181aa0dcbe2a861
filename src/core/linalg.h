// Small dense numerics shared by the solvers (fixed sizes, no allocation): partial-pivot LU,
// balancing, Hessenberg reduction and Francis double-shift QR eigenvalues (EISPACK / Numerical
// Recipes), and the R factor of a tall Householder QR. Written out because Eigen's general-purpose
// versions of these cost several times more instructions at these sizes (measured with callgrind).
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace poseonly {
namespace linalg {

// In-place LU with partial pivoting of an N x N matrix (full rows swapped: P A = L U); zero pivots
// are floored at `floor` (inverse iteration on a singular matrix then still yields the null vector).
// Returns false if a pivot is exactly zero and floor == 0.
template <int N>
bool lu_inplace(Eigen::Matrix<double, N, N>* L, int piv[N], double floor) {
  for (int k = 0; k < N; ++k) {
    int pk = k;
    double big = std::abs((*L)(k, k));
    for (int i = k + 1; i < N; ++i)
      if (std::abs((*L)(i, k)) > big) {
        big = std::abs((*L)(i, k));
        pk = i;
      }
    piv[k] = pk;
    if (pk != k) L->row(k).swap(L->row(pk));
    if ((*L)(k, k) == 0.0) {
      if (floor == 0.0) return false;
      (*L)(k, k) = floor;
    }
    const double inv = 1.0 / (*L)(k, k);
    for (int i = k + 1; i < N; ++i) {
      const double f = ((*L)(i, k) *= inv);
      if (f != 0.0)
        for (int j = k + 1; j < N; ++j) (*L)(i, j) -= f * (*L)(k, j);
    }
  }
  return true;
}

template <int N>
void lu_solve(const Eigen::Matrix<double, N, N>& L, const int piv[N], double* b) {
  for (int k = 0; k < N; ++k)  // the row interchanges first (full rows were swapped)
    if (piv[k] != k) std::swap(b[k], b[piv[k]]);
  for (int k = 0; k < N; ++k)
    for (int i = k + 1; i < N; ++i) b[i] -= L(i, k) * b[k];
  for (int k = N - 1; k >= 0; --k) {
    double s = b[k];
    for (int j = k + 1; j < N; ++j) s -= L(k, j) * b[j];
    b[k] = s / L(k, k);
  }
}

// Gauss-Jordan elimination with partial pivoting of a row-major N x C matrix [A1 | A2] (C >= N):
// on return the left N x N block is the identity and the right block A1^-1 A2. False if a pivot is
// exactly zero or not finite (singular A1). pivot_ratio: the smallest pivot over the largest.
template <int N, int C>
bool gauss_jordan(Eigen::Matrix<double, N, C, Eigen::RowMajor>* T, double* pivot_ratio = nullptr) {
  Eigen::Matrix<double, N, C, Eigen::RowMajor>& a = *T;
  double pmin = kInf, pmax = 0.0;
  for (int k = 0; k < N; ++k) {
    int pk = k;
    double big = std::abs(a(k, k));
    for (int i = k + 1; i < N; ++i)
      if (std::abs(a(i, k)) > big) {
        big = std::abs(a(i, k));
        pk = i;
      }
    if (!(big > 0.0) || !std::isfinite(big)) return false;
    pmin = std::min(pmin, big);
    pmax = std::max(pmax, big);
    if (pk != k) a.row(k).swap(a.row(pk));
    a.row(k) *= 1.0 / a(k, k);
    for (int i = 0; i < N; ++i) {
      if (i == k) continue;
      const double f = a(i, k);
      if (f != 0.0) a.row(i) -= f * a.row(k);
    }
  }
  if (pivot_ratio) *pivot_ratio = pmin / pmax;
  return true;
}

// Parlett-Reinsch balancing in place (Numerical Recipes balanc; powers of 2, no rounding).
template <int N>
void balance(Eigen::Matrix<double, N, N>* A) {
  constexpr double radix = 2.0, sqrdx = radix * radix;
  Eigen::Matrix<double, N, N>& a = *A;
  bool done = false;
  while (!done) {
    done = true;
    for (int i = 0; i < N; ++i) {
      double r = 0.0, c = 0.0;
      for (int j = 0; j < N; ++j)
        if (j != i) {
          c += std::abs(a(j, i));
          r += std::abs(a(i, j));
        }
      if (c != 0.0 && r != 0.0) {
        double g = r / radix, f = 1.0;
        const double s = c + r;
        while (c < g) {
          f *= radix;
          c *= sqrdx;
        }
        g = r * radix;
        while (c > g) {
          f /= radix;
          c /= sqrdx;
        }
        if ((c + r) / f < 0.95 * s) {
          done = false;
          g = 1.0 / f;
          a.row(i) *= g;
          a.col(i) *= f;
        }
      }
    }
  }
}

// Reduction to upper Hessenberg form by stabilised elementary similarity transformations (NR elmhes).
template <int N>
void hessenberg(Eigen::Matrix<double, N, N>* A) {
  constexpr int n = N;
  Eigen::Matrix<double, N, N>& a = *A;
  for (int m = 1; m < n - 1; ++m) {
    double x = 0.0;
    int i = m;
    for (int j = m; j < n; ++j)
      if (std::abs(a(j, m - 1)) > std::abs(x)) {
        x = a(j, m - 1);
        i = j;
      }
    if (i != m) {
      for (int j = m - 1; j < n; ++j) std::swap(a(i, j), a(m, j));
      for (int j = 0; j < n; ++j) std::swap(a(j, i), a(j, m));
    }
    if (x != 0.0) {
      for (int i2 = m + 1; i2 < n; ++i2) {
        double y = a(i2, m - 1);
        if (y != 0.0) {
          y /= x;
          a(i2, m - 1) = y;
          for (int j = m; j < n; ++j) a(i2, j) -= y * a(m, j);
          for (int j = 0; j < n; ++j) a(j, m) += y * a(j, i2);
        }
      }
    }
  }
  for (int i = 2; i < n; ++i)
    for (int j = 0; j < i - 1; ++j) a(i, j) = 0.0;
}

// Eigenvalues of an upper Hessenberg matrix by the Francis double-shift QR algorithm (EISPACK hqr as
// in Numerical Recipes; 1-based h[1..N][1..N], destroyed; wr, wi 1-based). False if it did not converge.
template <int N>
bool hqr(double (*h)[N + 1], double* wr, double* wi) {
  constexpr int n = N;
  double anorm = 0.0;
  for (int i = 1; i <= n; ++i)
    for (int j = std::max(i - 1, 1); j <= n; ++j) anorm += std::abs(h[i][j]);
  int nn = n, l = 1;
  double t = 0.0, x = 0.0, y = 0.0, z = 0.0, w = 0.0, p = 0.0, q = 0.0, r = 0.0, s = 0.0;
  while (nn >= 1) {
    int its = 0;
    do {
      l = 1;
      for (int ll = nn; ll >= 2; --ll) {
        s = std::abs(h[ll - 1][ll - 1]) + std::abs(h[ll][ll]);
        if (s == 0.0) s = anorm;
        if (std::abs(h[ll][ll - 1]) + s == s) {
          h[ll][ll - 1] = 0.0;
          l = ll;
          break;
        }
      }
      x = h[nn][nn];
      if (l == nn) {
        wr[nn] = x + t;
        wi[nn--] = 0.0;
      } else {
        y = h[nn - 1][nn - 1];
        w = h[nn][nn - 1] * h[nn - 1][nn];
        if (l == nn - 1) {
          p = 0.5 * (y - x);
          q = p * p + w;
          z = std::sqrt(std::abs(q));
          x += t;
          if (q >= 0.0) {
            z = p + (p >= 0.0 ? z : -z);
            wr[nn - 1] = wr[nn] = x + z;
            if (z != 0.0) wr[nn] = x - w / z;
            wi[nn - 1] = wi[nn] = 0.0;
          } else {
            wr[nn - 1] = wr[nn] = x + p;
            wi[nn - 1] = -z;
            wi[nn] = z;
          }
          nn -= 2;
        } else {
          if (its == 60) return false;
          if (its == 10 || its == 20 || its == 40) {  // exceptional shift
            t += x;
            for (int i = 1; i <= nn; ++i) h[i][i] -= x;
            s = std::abs(h[nn][nn - 1]) + std::abs(h[nn - 1][nn - 2]);
            y = x = 0.75 * s;
            w = -0.4375 * s * s;
          }
          ++its;
          int m = nn - 2;
          for (; m >= l; --m) {
            z = h[m][m];
            r = x - z;
            s = y - z;
            p = (r * s - w) / h[m + 1][m] + h[m][m + 1];
            q = h[m + 1][m + 1] - z - r - s;
            r = h[m + 2][m + 1];
            s = std::abs(p) + std::abs(q) + std::abs(r);
            p /= s;
            q /= s;
            r /= s;
            if (m == l) break;
            const double u = std::abs(h[m][m - 1]) * (std::abs(q) + std::abs(r));
            const double v = std::abs(p) * (std::abs(h[m - 1][m - 1]) + std::abs(z) + std::abs(h[m + 1][m + 1]));
            if (u + v == v) break;
          }
          for (int i = m + 2; i <= nn; ++i) {
            h[i][i - 2] = 0.0;
            if (i != m + 2) h[i][i - 3] = 0.0;
          }
          for (int k = m; k <= nn - 1; ++k) {
            if (k != m) {
              p = h[k][k - 1];
              q = h[k + 1][k - 1];
              r = 0.0;
              if (k != nn - 1) r = h[k + 2][k - 1];
              if ((x = std::abs(p) + std::abs(q) + std::abs(r)) != 0.0) {
                p /= x;
                q /= x;
                r /= x;
              }
            }
            s = std::sqrt(p * p + q * q + r * r);
            if (p < 0.0) s = -s;
            if (s != 0.0) {
              if (k == m) {
                if (l != m) h[k][k - 1] = -h[k][k - 1];
              } else {
                h[k][k - 1] = -s * x;
              }
              p += s;
              x = p / s;
              y = q / s;
              z = r / s;
              q /= p;
              r /= p;
              for (int j = k; j <= nn; ++j) {
                p = h[k][j] + q * h[k + 1][j];
                if (k != nn - 1) {
                  p += r * h[k + 2][j];
                  h[k + 2][j] -= p * z;
                }
                h[k + 1][j] -= p * y;
                h[k][j] -= p * x;
              }
              const int mmin = nn < k + 3 ? nn : k + 3;
              for (int i = l; i <= mmin; ++i) {
                p = x * h[i][k] + y * h[i][k + 1];
                if (k != nn - 1) {
                  p += z * h[i][k + 2];
                  h[i][k + 2] -= p * r;
                }
                h[i][k + 1] -= p * q;
                h[i][k] -= p;
              }
            }
          }
        }
      }
    } while (l < nn - 1);
  }
  return true;
}

// Eigenvalues wr[k] + i wi[k] (k = 0 .. N - 1) of a general real matrix: balancing, Hessenberg
// reduction, Francis double-shift QR. False if the QR iteration did not converge.
template <int N>
bool eigenvalues(Eigen::Matrix<double, N, N> M, double* wr, double* wi) {
  balance<N>(&M);
  hessenberg<N>(&M);
  double h[N + 1][N + 1], r1[N + 1], i1[N + 1];
  for (int r = 0; r < N; ++r)
    for (int c = 0; c < N; ++c) h[r + 1][c + 1] = M(r, c);
  if (!hqr<N>(h, r1, i1)) return false;
  for (int k = 0; k < N; ++k) {
    wr[k] = r1[k + 1];
    wi[k] = i1[k + 1];
  }
  return true;
}

// SVD A = U diag(s) V^T of a square N x N matrix by one-sided (Hestenes) Jacobi with de Rijk's column
// pivoting (de Rijk 1989, "A one-sided Jacobi algorithm for computing the SVD on a vector computer"): plane rotations
// on the right orthogonalise A's columns, accumulated into V (orthogonal to rounding, so the right
// singular vectors of small singular values are as accurate as their gaps allow); s_j = |column j|,
// sorted descending with V's columns. U is not formed. Sweeps stop when every pair of columns is
// orthogonal to kJacobiTol relative to their norms; false if kJacobiMaxSweeps did not suffice.
constexpr double kJacobiTol = 4.0 * std::numeric_limits<double>::epsilon();
constexpr int kJacobiMaxSweeps = 30;

// `V` holds the starting right factor: W is A V on entry (V = I: A itself), and the rotations
// accumulate into it.
template <int N>
bool jacobi_svd_from(Eigen::Matrix<double, N, N> W, Eigen::Matrix<double, N, N>* V, Eigen::Matrix<double, N, 1>* s) {
  Eigen::Matrix<double, N, 1> nrm;  // squared column norms, refreshed after each rotation
  for (int j = 0; j < N; ++j) nrm(j) = W.col(j).squaredNorm();
  bool converged = false;
  for (int sweep = 0; sweep < kJacobiMaxSweeps && !converged; ++sweep) {
    converged = true;
    for (int i = 0; i < N - 1; ++i) {
      // de Rijk's pivoting: the largest remaining column goes to position i first (a quarter fewer
      // rotations here: 8 -> 6 sweeps on LiRP's 9 x 9 triangles)
      int kmax = i;
      for (int q = i + 1; q < N; ++q)
        if (nrm(q) > nrm(kmax)) kmax = q;
      if (kmax != i) {
        W.col(i).swap(W.col(kmax));
        V->col(i).swap(V->col(kmax));
        std::swap(nrm(i), nrm(kmax));
      }
      for (int j = i + 1; j < N; ++j) {
        const double g = W.col(i).dot(W.col(j));
        const double a = nrm(i), b = nrm(j);
        if (!(std::abs(g) > kJacobiTol * std::sqrt(a) * std::sqrt(b))) continue;
        converged = false;
        const double zeta = (b - a) / (2.0 * g);
        const double t = (zeta >= 0.0 ? 1.0 : -1.0) / (std::abs(zeta) + std::sqrt(1.0 + zeta * zeta));
        const double c = 1.0 / std::sqrt(1.0 + t * t), sn = c * t;
        for (int k = 0; k < N; ++k) {
          const double wi = W(k, i), wj = W(k, j);
          W(k, i) = c * wi - sn * wj;
          W(k, j) = sn * wi + c * wj;
          const double vi = (*V)(k, i), vj = (*V)(k, j);
          (*V)(k, i) = c * vi - sn * vj;
          (*V)(k, j) = sn * vi + c * vj;
        }
        nrm(i) = W.col(i).squaredNorm();
        nrm(j) = W.col(j).squaredNorm();
      }
    }
  }
  for (int j = 0; j < N; ++j) (*s)(j) = std::sqrt(nrm(j));
  for (int j = 0; j < N - 1; ++j) {  // selection sort, descending
    int k = j;
    for (int i = j + 1; i < N; ++i)
      if ((*s)(i) > (*s)(k)) k = i;
    if (k != j) {
      std::swap((*s)(j), (*s)(k));
      V->col(j).swap(V->col(k));
    }
  }
  return converged;
}

template <int N>
bool jacobi_svd(const Eigen::Matrix<double, N, N>& A, Eigen::Matrix<double, N, N>* V, Eigen::Matrix<double, N, 1>* s) {
  V->setIdentity();
  return jacobi_svd_from<N>(A, V, s);
}

// Eigen-decomposition of a symmetric N x N matrix (only its lower triangle is read): Householder
// tridiagonalisation with the transformations accumulated, then the implicit QL iteration with
// Wilkinson's shift (EISPACK tred2 / tql2, the algorithm of Eigen's SelfAdjointEigenSolver and
// LAPACK dsteqr), fixed-size loops on a row-major array. z's columns are the eigenvectors of the
// eigenvalues d (unsorted). False if an eigenvalue took more than kQlMaxIterations iterations.
constexpr int kQlMaxIterations = 30;

template <int N>
bool symmetric_eigen(const Eigen::Matrix<double, N, N>& A, double (*z)[N], double* d) {
  double e[N];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j <= i; ++j) z[i][j] = A(i, j);
  // tred2: rows N-1 .. 1 reduced by Householder reflections; z holds the reflectors, then Q
  for (int i = N - 1; i > 0; --i) {
    const int l = i - 1;
    double h = 0.0;
    if (l > 0) {
      double scale = 0.0;
      for (int k = 0; k <= l; ++k) scale += std::abs(z[i][k]);
      if (scale == 0.0) {
        e[i] = z[i][l];
      } else {
        for (int k = 0; k <= l; ++k) {
          z[i][k] /= scale;
          h += z[i][k] * z[i][k];
        }
        double f = z[i][l];
        double g = f >= 0.0 ? -std::sqrt(h) : std::sqrt(h);
        e[i] = scale * g;
        h -= f * g;
        z[i][l] = f - g;
        f = 0.0;
        for (int j = 0; j <= l; ++j) {
          z[j][i] = z[i][j] / h;
          g = 0.0;
          for (int k = 0; k <= j; ++k) g += z[j][k] * z[i][k];
          for (int k = j + 1; k <= l; ++k) g += z[k][j] * z[i][k];
          e[j] = g / h;
          f += e[j] * z[i][j];
        }
        const double hh = f / (h + h);
        for (int j = 0; j <= l; ++j) {
          f = z[i][j];
          e[j] = g = e[j] - hh * f;
          for (int k = 0; k <= j; ++k) z[j][k] -= f * e[k] + g * z[i][k];
        }
      }
    } else {
      e[i] = z[i][l];
    }
    d[i] = h;
  }
  d[0] = 0.0;
  e[0] = 0.0;
  for (int i = 0; i < N; ++i) {  // accumulate Q
    const int l = i - 1;
    if (d[i] != 0.0) {
      for (int j = 0; j <= l; ++j) {
        double g = 0.0;
        for (int k = 0; k <= l; ++k) g += z[i][k] * z[k][j];
        for (int k = 0; k <= l; ++k) z[k][j] -= g * z[k][i];
      }
    }
    d[i] = z[i][i];
    z[i][i] = 1.0;
    for (int j = 0; j <= l; ++j) z[j][i] = z[i][j] = 0.0;
  }
  // tql2 on the tridiagonal (d, e): e shifted so that e[i] couples d[i] and d[i + 1]
  for (int i = 1; i < N; ++i) e[i - 1] = e[i];
  e[N - 1] = 0.0;
  constexpr double eps = std::numeric_limits<double>::epsilon();
  auto pythag = [](double a, double b) {
    const double aa = std::abs(a), ab = std::abs(b);
    if (aa > 1e150 || ab > 1e150) return std::hypot(a, b);
    return std::sqrt(a * a + b * b);
  };
  for (int l = 0; l < N; ++l) {
    int iter = 0, m;
    do {
      for (m = l; m < N - 1; ++m) {
        const double dd = std::abs(d[m]) + std::abs(d[m + 1]);
        if (std::abs(e[m]) <= eps * dd) break;
      }
      if (m != l) {
        if (iter++ == kQlMaxIterations) return false;
        double g = (d[l + 1] - d[l]) / (2.0 * e[l]);
        double r = pythag(g, 1.0);
        g = d[m] - d[l] + e[l] / (g + (g >= 0.0 ? std::abs(r) : -std::abs(r)));
        double s = 1.0, c = 1.0, p = 0.0;
        int i;
        for (i = m - 1; i >= l; --i) {
          double f = s * e[i];
          const double b = c * e[i];
          e[i + 1] = (r = pythag(f, g));
          if (r == 0.0) {  // underflow: deflate
            d[i + 1] -= p;
            e[m] = 0.0;
            break;
          }
          s = f / r;
          c = g / r;
          g = d[i + 1] - p;
          r = (d[i] - g) * s + 2.0 * c * b;
          d[i + 1] = g + (p = s * r);
          g = c * r - b;
          for (int k = 0; k < N; ++k) {
            f = z[k][i + 1];
            z[k][i + 1] = s * z[k][i] + c * f;
            z[k][i] = c * z[k][i] - s * f;
          }
        }
        if (r == 0.0 && i >= l) continue;
        d[l] -= p;
        e[l] = g;
        e[m] = 0.0;
      }
    } while (m != l);
  }
  return true;
}

// The same SVD, with the Jacobi sweeps started from the eigenvectors V0 of the Gram matrix A^T A
// (symmetric_eigen): the columns of A V0 are orthogonal to ~eps |A|^2 / (s_i s_j), so the
// sweeps (same rotations, same stopping rule, V accumulated from V0) only repair the small singular
// values' directions, which the squared condition number blurred: 1-3 sweeps instead of ~6, and
// the same accuracy as from V = I (the stopping test is on the columns of A V, not on A^T A).
// V0's own accuracy therefore only sets the number of sweeps.
template <int N>
bool jacobi_svd_gram(const Eigen::Matrix<double, N, N>& A, Eigen::Matrix<double, N, N>* V, Eigen::Matrix<double, N, 1>* s) {
  Eigen::Matrix<double, N, N> G;
  for (int i = 0; i < N; ++i)  // lower triangle of A^T A, column dot products
    for (int j = 0; j <= i; ++j) G(i, j) = A.col(i).dot(A.col(j));
  double z[N][N], d[N];
  if (!symmetric_eigen<N>(G, z, d)) return jacobi_svd<N>(A, V, s);
  int order[N];
  for (int k = 0; k < N; ++k) order[k] = k;
  std::sort(order, order + N, [&d](int a, int b) { return d[a] > d[b]; });  // descending eigenvalues first
  for (int c = 0; c < N; ++c)
    for (int r = 0; r < N; ++r) (*V)(r, c) = z[r][order[c]];
  if (!V->allFinite()) return jacobi_svd<N>(A, V, s);
  return jacobi_svd_from<N>(A * *V, V, s);
}

// Householder QR of an m x N matrix stored column by column (col j = a[j * m .. j * m + m - 1]),
// m >= N, with the reflections of LAPACK dgeqrf / Eigen's HouseholderQR (beta = -sign(alpha) |x|):
// R (upper triangle, row-major r[i * N + j]) to r, the reflectors' essential parts left below a's
// diagonal and their factors to tau (H_k = I - tau_k v_k v_k^T, v_k = (0, .., 1, a[k m + k + 1 ..])).
template <int N>
void householder_qr(double* a, int m, double* r, double* tau) {
  for (int k = 0; k < N; ++k) {
    double* ak = a + k * m;
    double tail = 0.0;
    for (int i = k + 1; i < m; ++i) tail += ak[i] * ak[i];
    const double alpha = ak[k];
    if (tail == 0.0) {  // nothing below the diagonal: identity reflection
      tau[k] = 0.0;
      r[k * N + k] = alpha;
      for (int j = k + 1; j < N; ++j) r[k * N + j] = a[j * m + k];
      continue;
    }
    const double nrm = std::sqrt(alpha * alpha + tail);
    const double beta = alpha >= 0.0 ? -nrm : nrm;
    const double t = (beta - alpha) / beta;
    const double s = 1.0 / (alpha - beta);
    for (int i = k + 1; i < m; ++i) ak[i] *= s;
    tau[k] = t;
    r[k * N + k] = beta;
    for (int j = k + 1; j < N; ++j) {
      double* aj = a + j * m;
      double d = aj[k];
      for (int i = k + 1; i < m; ++i) d += ak[i] * aj[i];
      d *= t;
      aj[k] -= d;
      for (int i = k + 1; i < m; ++i) aj[i] -= d * ak[i];
      r[k * N + j] = aj[k];
    }
  }
}

// x <- Q x for the Q of householder_qr (x of length m).
template <int N>
void householder_apply_q(const double* a, int m, const double* tau, double* x) {
  for (int k = N - 1; k >= 0; --k) {
    if (tau[k] == 0.0) continue;
    const double* ak = a + k * m;
    double d = x[k];
    for (int i = k + 1; i < m; ++i) d += ak[i] * x[i];
    d *= tau[k];
    x[k] -= d;
    for (int i = k + 1; i < m; ++i) x[i] -= d * ak[i];
  }
}

}  // namespace linalg
}  // namespace poseonly
