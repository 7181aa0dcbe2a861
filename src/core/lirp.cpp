// LiRP (Algorithm 1) and pose-only identification; see lirp.h and the paper's Section 5.
#include "lirp.h"

#include <algorithm>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <complex>

#include "linalg.h"
#include "residuals.h"

namespace poseonly {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
constexpr int kStackRows = 64;  // rows of A held on the stack (more: one heap buffer)

// monomial index of a^p b^q in y = (a^3, a^2 b, a b^2, b^3, a^2, ab, b^2, a, b, 1)
int monomial(int p, int q) {
  static const int table[4][4] = {{9, 8, 6, 3}, {7, 5, 2, -1}, {4, 1, -1, -1}, {0, -1, -1, -1}};
  return table[p][q];
}

// Null space basis q1, q2, q3 (columns 6, 7, 8 of V: q3 belongs to the smallest singular value).
void null_space(const Points& P, const double* w, Mat9* V, Vec9* s) {
  double wmax = 0.0;
  int m = 0;
  for (int i = 0; i < P.n; ++i) {
    const double wi = w ? w[i] : 1.0;
    if (wi > 0.0) ++m;
    wmax = std::max(wmax, wi);
  }
  // A column by column (col 3 c + rr = w_i f1_c f2_rr over the rows i): the layout householder_qr reads
  const int rows = std::max(m, 9);
  double local[9 * kStackRows];
  std::vector<double> heap;
  double* A = local;
  if (rows > kStackRows) {
    heap.resize(9 * static_cast<size_t>(rows));
    A = heap.data();
  }
  std::fill(A, A + 9 * rows, 0.0);
  int r = 0;
  const double inv = wmax > 0.0 ? 1.0 / wmax : 0.0;
  for (int i = 0; i < P.n; ++i) {
    const double wi = w ? w[i] * inv : 1.0;
    if (!(wi > 0.0)) continue;
    const auto a = P.a(i);
    const auto b = P.b(i);
    // A_i q = f2^T Q f1 with q = vec(Q) column-major: coefficient of Q(rr, c) is f1_c f2_rr
    for (int c = 0; c < 3; ++c) {
      const double wa = wi * a(c);
      for (int rr = 0; rr < 3; ++rr) A[(3 * c + rr) * rows + r] = wa * b(rr);
    }
    ++r;
  }
  Mat9 Rf;
  if (rows > 9) {
    Eigen::Matrix<double, 9, 9, Eigen::RowMajor> Rr = Eigen::Matrix<double, 9, 9, Eigen::RowMajor>::Zero();
    double tau[9];
    linalg::householder_qr<9>(A, rows, Rr.data(), tau);
    Rf = Rr.triangularView<Eigen::Upper>();
  } else {
    Rf = Eigen::Map<const Mat9>(A);
  }
  linalg::jacobi_svd_gram<9>(Rf, V, s);  // not converged in 30 sweeps: the last iterate (never seen)
  *s *= wmax;
}

// The 9 x 10 Demazure system B y = 0 of Q = a Q1 + b Q2 + Q3 (Eq. 14):
// 2 Q Q^T Q - tr(Q Q^T) Q = 0 expanded over the monomials y.
Eigen::Matrix<double, 9, 10> demazure(const std::array<Mat3, 3>& Q) {
  Eigen::Matrix<double, 9, 10> B = Eigen::Matrix<double, 9, 10>::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const Mat3 Pij = Q[i] * Q[j].transpose();
      const double tr = Pij.trace();
      for (int k = 0; k < 3; ++k) {
        const Mat3 T = 2.0 * Pij * Q[k] - tr * Q[k];
        const int p = (i == 0) + (j == 0) + (k == 0);
        const int q = (i == 1) + (j == 1) + (k == 1);
        B.col(monomial(p, q)) += Eigen::Map<const Vec9>(T.data());
      }
    }
  }
  return B;
}

double min_gap(const Eigen::Matrix<std::complex<double>, 6, 1>& lam) {
  double d = kInf;
  for (int i = 0; i < 6; ++i)
    for (int j = i + 1; j < 6; ++j) d = std::min(d, std::abs(lam(i) - lam(j)));
  return d;
}


using Cd = std::complex<double>;
using Vec3c = Eigen::Matrix<Cd, 3, 1>;

// Eigenpairs of an action matrix. Eigenvalues by the real Schur form without its vectors; each
// eigenvector from the three unit rows of the matrix, which fix half of g in terms of the other
// half: for C1 (a g): g3 = a g5, g0 = a^2 g5, g1 = a g4, leaving (g2, g4, g5) as the null vector of
// a 3x3 complex matrix N(a) (cross product of its two most independent rows); for C2 (b g): g4 = b g5,
// g2 = b^2 g5, g1 = b g3, leaving (g0, g3, g5). Falls back to the full eigen-decomposition where
// N(lambda) has no well-defined 1-D null space (repeated eigenvalues).
bool action_eigen(const Mat6& C, int which, Eigen::Matrix<Cd, 6, 1>* lam, Eigen::Matrix<Cd, 6, 6>* G) {
  double wr[6], wi[6];
  if (!linalg::eigenvalues<6>(C, wr, wi)) return false;
  for (int e = 0; e < 6; ++e) (*lam)(e) = Cd(wr[e], wi[e]);
  for (int e = 0; e < 6; ++e) {
    const Cd l = (*lam)(e);
    Eigen::Matrix<Cd, 3, 3> N;
    for (int r = 0; r < 3; ++r) {
      if (which == 0) {  // unknowns (g2, g4, g5)
        N(r, 0) = C(r, 2) - (r == 2 ? l : Cd(0.0));
        N(r, 1) = C(r, 1) * l + C(r, 4) - (r == 1 ? l * l : Cd(0.0));
        N(r, 2) = C(r, 0) * l * l + C(r, 3) * l + C(r, 5) - (r == 0 ? l * l * l : Cd(0.0));
      } else {  // unknowns (g0, g3, g5)
        N(r, 0) = C(r, 0) - (r == 0 ? l : Cd(0.0));
        N(r, 1) = C(r, 1) * l + C(r, 3) - (r == 1 ? l * l : Cd(0.0));
        N(r, 2) = C(r, 2) * l * l + C(r, 4) * l + C(r, 5) - (r == 2 ? l * l * l : Cd(0.0));
      }
    }
    Vec3c best = Vec3c::Zero();
    double bn = -1.0;
    for (int p = 0; p < 3; ++p) {
      const Vec3c x = N.row(p).transpose(), y = N.row((p + 1) % 3).transpose();
      const Vec3c z(x(1) * y(2) - x(2) * y(1), x(2) * y(0) - x(0) * y(2), x(0) * y(1) - x(1) * y(0));
      const double zn = z.norm();
      if (zn > bn) {
        bn = zn;
        best = z;
      }
    }
    const double scale = N.norm();
    if (!(bn > 1e-10 * scale * scale)) {  // no clear 1-D null space: the general solver
      Eigen::EigenSolver<Mat6> full(C, true);
      if (full.info() != Eigen::Success) return false;
      *lam = full.eigenvalues();
      *G = full.eigenvectors();
      return true;
    }
    Eigen::Matrix<Cd, 6, 1> g;
    if (which == 0) {
      const Cd g2 = best(0), g4 = best(1), g5 = best(2);
      g << l * l * g5, l * g4, g2, l * g5, g4, g5;
    } else {
      const Cd g0 = best(0), g3 = best(1), g5 = best(2);
      g << g0, l * g3, l * l * g5, g3, l * g5, g5;
    }
    G->col(e) = g / g.norm();
  }
  return true;
}

Mat3 unit_or(const Vec9& v, const Vec9& fallback) {
  const double nv = v.norm();
  const Vec9 u = (nv > 0.0 && std::isfinite(nv)) ? Vec9(v / nv) : fallback;
  return Eigen::Map<const Mat3>(u.data());
}

}  // namespace

void lirp_candidates(const Points& P, const double* w, LirpCandidates* out) {
  Mat9 V;
  null_space(P, w, &V, &out->singular_values);
  const Vec9 q1 = V.col(6), q2 = V.col(7), q3 = V.col(8);
  const std::array<Mat3, 3> Q = {Eigen::Map<const Mat3>(q1.data()), Eigen::Map<const Mat3>(q2.data()),
                                 Eigen::Map<const Mat3>(q3.data())};
  // Case 1 (c = 1): M = B1^+ B2 and the action matrices C1 g = a g, C2 g = b g,
  // g = (a^2, ab, b^2, a, b, 1); least squares by a complete orthogonal decomposition (= pinv)
  const Eigen::Matrix<double, 9, 10> B = demazure(Q);
  const Eigen::Matrix<double, 9, 4> B1 = B.leftCols<4>();
  const Eigen::Matrix<double, 9, 6> B2 = B.rightCols<6>();
  const Eigen::Matrix<double, 4, 6> M = B1.completeOrthogonalDecomposition().solve(B2);
  Mat6 C[2];
  C[0].setZero();
  C[1].setZero();
  C[0].topRows<3>() = -M.topRows<3>();
  C[0](3, 0) = C[0](4, 1) = C[0](5, 3) = 1.0;  // a * (a^2, ab, a) = (g0, g1, g3)
  C[1].topRows<3>() = -M.bottomRows<3>();
  C[1](3, 1) = C[1](4, 2) = C[1](5, 4) = 1.0;  // b * (ab, b^2, b) = (g1, g2, g4)
  int c = 0;
  for (int m = 0; m < 2; ++m) {
    Eigen::Matrix<std::complex<double>, 6, 1> lam;
    Eigen::Matrix<std::complex<double>, 6, 6> G;
    const bool ok = C[m].allFinite() && action_eigen(C[m], m, &lam, &G);
    if (ok) (m == 0 ? out->d_min : out->d_min_C2) = min_gap(lam);
    for (int e = 0; e < 6; ++e, ++c) {
      if (!ok) {
        out->E[c] = unit_or(q3, q3);
        continue;
      }
      const auto g = G.col(e);
      // homogeneous reading of (a, b, 1) = (g3, g4, g5) / g5: real parts, no division by g5
      const std::complex<double> g5c = std::conj(g(5));
      const double ca = std::real(g(3) * g5c), cb = std::real(g(4) * g5c), cc = std::norm(g(5));
      out->E[c] = unit_or(ca * q1 + cb * q2 + cc * q3, q3);
    }
  }
  // Case 2 (c = 0, b = 1): det(a Q1 + Q2) = d3 a^3 + d2 a^2 + d1 a + d0 (Eq. 15), solved in a or in
  // 1/a, whichever has the larger leading coefficient
  const double d3 = Q[0].determinant(), d0 = Q[1].determinant();
  const double sp = (Q[0] + Q[1]).determinant(), sm = (Q[1] - Q[0]).determinant();
  const double d2 = 0.5 * (sp + sm) - d0, d1 = 0.5 * (sp - sm) - d3;
  const bool use_a = std::abs(d3) >= std::abs(d0);
  const double c3 = use_a ? d3 : d0, c2 = use_a ? d2 : d1, c1 = use_a ? d1 : d2, c0 = use_a ? d0 : d3;
  Mat3 comp = Mat3::Zero();
  const double inv = 1.0 / (c3 == 0.0 ? kTiny : c3);
  comp(0, 0) = -c2 * inv;
  comp(0, 1) = -c1 * inv;
  comp(0, 2) = -c0 * inv;
  comp(1, 0) = comp(2, 1) = 1.0;
  double roots[3] = {0.0, 0.0, 0.0}, roots_im[3];
  if (!(comp.allFinite() && linalg::eigenvalues<3>(comp, roots, roots_im))) std::fill(roots, roots + 3, 0.0);
  for (int k = 0; k < 3; ++k, ++c) {
    const double r = roots[k];
    out->E[c] = unit_or(use_a ? Vec9(r * q1 + q2) : Vec9(q1 + r * q2), q3);
  }
  out->E[c++] = unit_or(q1, q3);
  out->E[c++] = unit_or(q2, q3);
  out->E[c++] = unit_or(q3, q3);
  const Vec9& sv = out->singular_values;
  for (int k = 0; k < kLirpCandidates; ++k) {
    const Eigen::Map<const Vec9> e(out->E[k].data());
    const double a1 = e.dot(q1) * sv(6), a2 = e.dot(q2) * sv(7), a3 = e.dot(q3) * sv(8);
    out->algebraic[k] = a1 * a1 + a2 * a2 + a3 * a3;
  }
}

Vec9 epipolar_singular_values(const Points& P) {
  Mat9 V;
  Vec9 s;
  null_space(P, nullptr, &V, &s);
  return s;
}

double ppo_cost(const Pose& pose, const Points& P, const double* w) {
  const PoseTerms pt(pose);
  double s = 0.0, ws = 0.0;
  for (int i = 0; i < P.n; ++i) {
    const double wi = w ? w[i] : 1.0;
    if (!(wi > 0.0)) continue;
    s += wi * ppo(pt, P.a(i), P.b(i));
    ws += wi;
  }
  const double cost = s / std::max(ws, kTiny);
  return std::isfinite(cost) ? cost : kInf;
}

namespace {

// SVD-free decomposition of E (geometry.essential_frames): v3 the right singular vector of the
// smallest singular value, u3 = cof(E) v3 / |cof(E) v3| (E = U diag(s1, s2, s3') V^T, det U = det V
// = 1), F = [u3]x U V^T; the two rotations are u3 v3^T +- F and t = +-u3.
struct Frames {
  Vec3 u3, v3;
  Mat3 F, G;  // G = [u3]x F: e = f2^T [t]x R f1 = +- f2^T G f1
};

// The eigenvector of the smallest eigenvalue of a symmetric positive semi-definite 3 x 3 matrix G:
// the eigenvalue by Newton's method on det(G - x I) from x = 0 (left of every root, where the
// characteristic cubic is convex and decreasing, so the iterates rise monotonically to the smallest
// root), the vector as the largest cross product of two rows of G - x I (as Eigen's computeDirect,
// without its trigonometric eigenvalue formula). An essential matrix's Gram has eigenvalues
// (s^2, s^2, ~0): one or two Newton steps.
constexpr int kCubicNewtonMax = 100;

Vec3 smallest_eigenvector(const Mat3& G) {
  const double scale = G.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) return Vec3::UnitZ();
  const Mat3 A = G / scale;
  // det(A - x I) = -x^3 + c2 x^2 - c1 x + c0
  const double c2 = A.trace();
  const double c1 = A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0) + A(0, 0) * A(2, 2) - A(0, 2) * A(2, 0) + A(1, 1) * A(2, 2) - A(1, 2) * A(2, 1);
  const double c0 = A.determinant();
  double x = 0.0;
  for (int it = 0; it < kCubicNewtonMax; ++it) {
    const double p = ((-x + c2) * x - c1) * x + c0;
    const double dp = (-3.0 * x + 2.0 * c2) * x - c1;
    if (!(dp < 0.0) || !(p > 0.0)) break;  // at (or, by rounding, past) the root
    const double xn = x - p / dp;
    if (!(xn > x)) break;
    x = xn;
  }
  Mat3 M = A;
  M.diagonal().array() -= x;
  const Vec3 r0 = M.row(0), r1 = M.row(1), r2 = M.row(2);
  Vec3 best = r0.cross(r1);
  double bn = best.squaredNorm();
  for (const Vec3& c : {Vec3(r0.cross(r2)), Vec3(r1.cross(r2))}) {
    const double cn = c.squaredNorm();
    if (cn > bn) {
      bn = cn;
      best = c;
    }
  }
  if (!(bn > 0.0)) {  // M of rank <= 1: any unit vector orthogonal to its largest row
    Eigen::Index k;
    M.rowwise().squaredNorm().maxCoeff(&k);
    const Vec3 r = M.row(k);
    if (!(r.squaredNorm() > 0.0)) return Vec3::UnitZ();
    Eigen::Index j;
    r.cwiseAbs().minCoeff(&j);
    return r.cross(Vec3::Unit(j)).normalized();
  }
  return best / std::sqrt(bn);
}

Frames essential_frames(const Mat3& E) {
  Frames fr;
  fr.v3 = smallest_eigenvector(E.transpose() * E);
  Mat3 cof;
  cof.col(0) = E.col(1).cross(E.col(2));
  cof.col(1) = E.col(2).cross(E.col(0));
  cof.col(2) = E.col(0).cross(E.col(1));
  const Vec3 u = cof * fr.v3;
  const double s12 = u.norm();
  fr.u3 = s12 > 0.0 ? Vec3(u / s12) : fr.v3;
  const double s3 = fr.u3.dot(E * fr.v3);
  double sp = std::sqrt(std::max(E.squaredNorm() - s3 * s3 + 2.0 * s12, 0.0));  // s1 + s2
  if (!(sp > 0.0)) sp = 1.0;
  const Mat3 Su = skew(fr.u3), Sv = skew(fr.v3);
  const Mat3 Ep = (E - Su * E * Sv - s3 * fr.u3 * fr.v3.transpose()) / sp;
  fr.F = Su * Ep;
  fr.G = Su * fr.F;
  return fr;
}

inline double sgn(double x) { return static_cast<double>((x > 0.0) - (x < 0.0)); }

}  // namespace

namespace {

// The points as coordinate arrays (built once per LiRP call, read by the 18 identifications) and
// the effective weights (w_i where w_i > 0, else 0: such points add nothing).
struct IdPoints {
  int n = 0;
  std::vector<double> buf;  // one allocation for the seven arrays
  double *x1, *y1, *z1, *x2, *y2, *z2, *w;
  double ws = 0.0;  // the weights' sum, in point order
  IdPoints(const Points& P, const double* wts) : n(P.n), buf(7 * static_cast<size_t>(P.n)) {
    double* b = buf.data();
    x1 = b, y1 = b + n, z1 = b + 2 * n, x2 = b + 3 * n, y2 = b + 4 * n, z2 = b + 5 * n, w = b + 6 * n;
    for (int i = 0; i < n; ++i) {
      x1[i] = P.f1[3 * i], y1[i] = P.f1[3 * i + 1], z1[i] = P.f1[3 * i + 2];
      x2[i] = P.f2[3 * i], y2[i] = P.f2[3 * i + 1], z2[i] = P.f2[3 * i + 2];
      w[i] = wts ? (wts[i] > 0.0 ? wts[i] : 0.0) : 1.0;
      ws += w[i];
    }
  }
  IdPoints(const IdPoints&) = delete;  // the pointers point into buf
  IdPoints& operator=(const IdPoints&) = delete;
};

// Loop 1 of identify, per point of [i0, i0 + m): w sgn(h h'), w h h', w sgn(h) for both rotations
// r (out[(3 r + j) kIdBlock + k]); branch-free, so the loop runs on SIMD lanes.
inline double sgn_select(double x) { return (x > 0.0 ? 1.0 : 0.0) - (x < 0.0 ? 1.0 : 0.0); }

constexpr int kIdBlock = 32;

POSEONLY_SIMD_CLONES
void sign_terms(const Frames& fr, const IdPoints& S, int i0, int m, double* out) {
  const double v0 = fr.v3(0), v1 = fr.v3(1), v2 = fr.v3(2), u0 = fr.u3(0), u1 = fr.u3(1), u2 = fr.u3(2);
  const double F00 = fr.F(0, 0), F01 = fr.F(0, 1), F02 = fr.F(0, 2), F10 = fr.F(1, 0), F11 = fr.F(1, 1), F12 = fr.F(1, 2),
               F20 = fr.F(2, 0), F21 = fr.F(2, 1), F22 = fr.F(2, 2);
  const double *X1 = S.x1 + i0, *Y1 = S.y1 + i0, *Z1 = S.z1 + i0;
  const double *X2 = S.x2 + i0, *Y2 = S.y2 + i0, *Z2 = S.z2 + i0, *W = S.w + i0;
  double *m1a = out, *rwa = out + kIdBlock, *m2a = out + 2 * kIdBlock;
  double *m1b = out + 3 * kIdBlock, *rwb = out + 4 * kIdBlock, *m2b = out + 5 * kIdBlock;
  for (int k = 0; k < m; ++k) {
    const double a0 = X1[k], a1 = Y1[k], a2 = Z1[k], b0 = X2[k], b1 = Y2[k], b2 = Z2[k], wi = W[k];
    const double at = v0 * a0 + v1 * a1 + v2 * a2, bt = u0 * b0 + u1 * b1 + u2 * b2;
    const double x = b0 * (F00 * a0 + F01 * a1 + F02 * a2) + b1 * (F10 * a0 + F11 * a1 + F12 * a2) + b2 * (F20 * a0 + F21 * a1 + F22 * a2);
    const bool on = wi > 0.0;
    // r = 0: ab = bt at + x; r = 1: ab = bt at - x
    const double abA = bt * at + x, hA = abA * bt - at, hpA = bt - at * abA, hhA = hA * hpA;
    const double abB = bt * at + -x, hB = abB * bt - at, hpB = bt - at * abB, hhB = hB * hpB;
    m1a[k] = on ? wi * sgn_select(hhA) : 0.0;
    rwa[k] = on ? wi * hhA : 0.0;
    m2a[k] = on ? wi * sgn_select(hA) : 0.0;
    m1b[k] = on ? wi * sgn_select(hhB) : 0.0;
    rwb[k] = on ? wi * hhB : 0.0;
    m2b[k] = on ? wi * sgn_select(hB) : 0.0;
  }
}

// The identification sums (loop 1), accumulated in point order.
struct SignSums {
  double m1[2] = {0.0, 0.0}, raw[2] = {0.0, 0.0}, m2[2] = {0.0, 0.0};
};

SignSums sign_sums(const Frames& fr, const IdPoints& S) {
  SignSums T;
  double buf[6 * kIdBlock];
  for (int i0 = 0; i0 < S.n; i0 += kIdBlock) {
    const int m = std::min(kIdBlock, S.n - i0);
    sign_terms(fr, S, i0, m, buf);
    for (int k = 0; k < m; ++k) {
      for (int r = 0; r < 2; ++r) {
        T.m1[r] += buf[(3 * r) * kIdBlock + k];
        T.raw[r] += buf[(3 * r + 1) * kIdBlock + k];
        T.m2[r] += buf[(3 * r + 2) * kIdBlock + k];
      }
    }
  }
  return T;
}

// v_PPO from the bilinear forms ab = f2.R f1, bt = t.f2, h = h^T t and |e| = |f2^T [t]x R f1| (unit t):
// with alpha = |t x f2|, beta = |f2 x R f1| (h^2 + e^2 = alpha^2 beta^2), |eps x f2|^2 =
// 2 alpha^2 beta^2 (1 - cos gamma), eps . f2 = alpha ab + beta bt, both 1 - cos by half-angle forms
// (an exact fit keeps a residual ~1e-16). Equal to residuals.h's ppo() to ~1e-15.
// Per point of [i0, i0 + m): w_i v_PPO for the rotation sign s and translation sign sigma (loop 2),
// the branches as selects (both sides computed; -fno-trapping-math lets the compiler do so).
POSEONLY_SIMD_CLONES
void ppo_terms(const Frames& fr, const IdPoints& S, double s, double sigma, int i0, int m, double* out) {
  const double v0 = fr.v3(0), v1 = fr.v3(1), v2 = fr.v3(2), u0 = fr.u3(0), u1 = fr.u3(1), u2 = fr.u3(2);
  const Mat3 F = s * fr.F;
  const double F00 = F(0, 0), F01 = F(0, 1), F02 = F(0, 2), F10 = F(1, 0), F11 = F(1, 1), F12 = F(1, 2), F20 = F(2, 0),
               F21 = F(2, 1), F22 = F(2, 2);
  const Mat3& G = fr.G;
  const double G00 = G(0, 0), G01 = G(0, 1), G02 = G(0, 2), G10 = G(1, 0), G11 = G(1, 1), G12 = G(1, 2), G20 = G(2, 0),
               G21 = G(2, 1), G22 = G(2, 2);
  for (int k = 0; k < m; ++k) {
    const int i = i0 + k;
    const double a0 = S.x1[i], a1 = S.y1[i], a2 = S.z1[i], b0 = S.x2[i], b1 = S.y2[i], b2 = S.z2[i], wi = S.w[i];
    const double at = v0 * a0 + v1 * a1 + v2 * a2, bt0 = u0 * b0 + u1 * b1 + u2 * b2;
    const double x = b0 * (F00 * a0 + F01 * a1 + F02 * a2) + b1 * (F10 * a0 + F11 * a1 + F12 * a2) + b2 * (F20 * a0 + F21 * a1 + F22 * a2);
    const double e = b0 * (G00 * a0 + G01 * a1 + G02 * a2) + b1 * (G10 * a0 + G11 * a1 + G12 * a2) + b2 * (G20 * a0 + G21 * a1 + G22 * a2);
    const double ab = bt0 * at + x;
    // the forms of the pose (s, sigma): ab, bt' = sigma bt, h = sigma (ab bt - at), |e|
    const double bt = sigma * bt0, h = sigma * (ab * bt0 - at), e_abs = std::abs(e);
    const double alpha = std::sqrt(std::max((1.0 - bt) * (1.0 + bt), 0.0));
    const double beta = std::sqrt(std::max((1.0 - ab) * (1.0 + ab), 0.0));
    const double p = alpha * ab + beta * bt;
    const double rho = alpha * beta;
    // each 1 - cos is one division of selected operands (the same rounding as dividing in both
    // branches and selecting the quotient, at half the divisions)
    const double omc = (h > 0.0 ? e_abs * e_abs : rho - h) / (h > 0.0 ? rho * (rho + h) : rho);
    const double q2 = rho > 0.0 ? 2.0 * rho * rho * omc : 0.0;
    const double r = std::sqrt(p * p + q2);
    const double omc2 = (p > 0.0 ? q2 : r - p) / (p > 0.0 ? r * (r + p) : r);
    const double v = r > 0.0 ? std::sqrt(2.0 * omc2) : 1.0;  // eps = 0: normalize(eps) = 0, |0 - f2| = 1
    out[k] = wi > 0.0 ? wi * v : 0.0;
  }
}

// Blocks of the PPO sum: small, so that a candidate that cannot win stops early (8 points: two
// AVX2 vectors; the sum runs in point order whatever the block, so the result does not depend on it).
constexpr int kPpoBlock = 8;

// The weighted mean v_PPO, sum * norm; kInf as soon as a running mean exceeds `bound` (the terms are
// non-negative and each is added in point order, so the running sum never decreases and the full
// mean would exceed `bound` too: an exact bail-out, as the scorers' in ransac.h).
double ppo_mean(const Frames& fr, const IdPoints& S, double s, double sigma, double norm, double bound) {
  double c = 0.0, buf[kPpoBlock];
  for (int i0 = 0; i0 < S.n; i0 += kPpoBlock) {
    const int m = std::min(kPpoBlock, S.n - i0);
    ppo_terms(fr, S, s, sigma, i0, m, buf);
    for (int k = 0; k < m; ++k) c += buf[k];
    if (c * norm > bound) return kInf;
  }
  const double cost = c * norm;
  return std::isfinite(cost) ? cost : kInf;
}

// A candidate after the pose-only depth conditions, before its cost: the frames and signs of its pose.
struct Signed {
  Frames fr;
  double s = 1.0, sigma = 1.0, norm = 1.0;
};

Signed identify_signs(const Mat3& E, const IdPoints& S, Identified* out) {
  Signed c;
  c.fr = essential_frames(E);
  // per point, with a = R f1: a.t = v3.f1 and b.t = u3.f2 for both rotations, a.b = bt at +- f2^T F f1;
  // h = (a x b).(b x t) = ab bt - at, h' = (a x b).(a x t) = bt - at ab (Lagrange identity)
  const SignSums T = sign_sums(c.fr, S);
  c.norm = 1.0 / std::max(S.ws, kTiny);
  // the twisted pair makes every depth product negative: keep the rotation with the larger M1
  // (tie: the larger raw sum of h h')
  const int pick = (T.m1[1] > T.m1[0] || (T.m1[1] == T.m1[0] && T.raw[1] > T.raw[0])) ? 1 : 0;
  c.s = pick ? -1.0 : 1.0;
  out->M1 = T.m1[pick] * c.norm;
  const double M2 = T.m2[pick] * c.norm;
  c.sigma = M2 < 0.0 ? -1.0 : 1.0;
  out->pose.R = c.fr.u3 * c.fr.v3.transpose() + c.s * c.fr.F;
  out->pose.t = c.sigma * c.fr.u3;
  out->valid = out->M1 > 0.0 && std::abs(M2) > 0.0;
  out->cost = kInf;
  return c;
}

void identify_points(const Mat3& E, const IdPoints& S, CostMode mode, Identified* out) {
  const Signed c = identify_signs(E, S, out);
  if (mode == CostMode::Never || (mode == CostMode::IfValid && !out->valid)) return;
  out->cost = ppo_mean(c.fr, S, c.s, c.sigma, c.norm, kInf);
}

}  // namespace

void identify(const Mat3& E, const Points& P, const double* w, CostMode mode, Identified* out) {
  identify_points(E, IdPoints(P, w), mode, out);
}

int rank_best(const std::array<Identified, kLirpCandidates>& id) {
  int best = 0;
  double key_best = kInf;
  for (int k = 0; k < kLirpCandidates; ++k) {
    const double key = id[k].valid ? id[k].cost : id[k].cost + 10.0;
    if (key < key_best) {
      key_best = key;
      best = k;
    }
  }
  return best;
}

void lirp(const Points& P, const double* w, bool all_costs, LirpResult* out) {
  lirp_candidates(P, w, &out->cand);
  const IdPoints S(P, w);
  if (all_costs) {
    for (int k = 0; k < kLirpCandidates; ++k) identify_points(out->cand.E[k], S, CostMode::Always, &out->id[k]);
    out->best = rank_best(out->id);
    return;
  }
  // Best only. Every candidate's signs first; then the valid candidates' costs, the least algebraic
  // error first (a good bound early), each stopped once its running mean exceeds the least cost so far
  // (ppo_mean). A stopped candidate's full cost is larger than a computed one's, so rank_best (least
  // cost, the first of equal costs) picks what it picks with every cost computed; stopped candidates
  // keep cost kInf.
  std::array<Signed, kLirpCandidates> sg;
  std::array<int, kLirpCandidates> order;
  for (int k = 0; k < kLirpCandidates; ++k) {
    sg[k] = identify_signs(out->cand.E[k], S, &out->id[k]);
    order[k] = k;
  }
  const auto key = [&](int k) { return std::isnan(out->cand.algebraic[k]) ? kInf : out->cand.algebraic[k]; };  // a strict weak order
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  bool any_valid_cost = false;
  double least = kInf;
  for (int k : order) {
    if (!out->id[k].valid) continue;
    const Signed& c = sg[k];
    out->id[k].cost = ppo_mean(c.fr, S, c.s, c.sigma, c.norm, least);
    if (std::isfinite(out->id[k].cost)) {
      any_valid_cost = true;
      least = std::min(least, out->id[k].cost);
    }
  }
  if (!any_valid_cost)  // no valid candidate: rank every candidate by its cost
    for (int k = 0; k < kLirpCandidates; ++k) out->id[k].cost = ppo_cost(out->id[k].pose, P, w);
  out->best = rank_best(out->id);
}

}  // namespace poseonly
