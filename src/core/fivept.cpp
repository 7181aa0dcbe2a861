// Five-point solver: Nister polynomial + Sturm, Stewenius action-matrix fallback (see fivept.h).
#include "fivept.h"

#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>

#include "linalg.h"
#include "sturm.h"
#include "residuals.h"

namespace poseonly {
namespace {

using Mat10 = Eigen::Matrix<double, 10, 10>;
using Vec10 = Eigen::Matrix<double, 10, 1>;

// Monomials of (x, y, z, 1): linear (4: x, y, z, 1), quadratic (10: x^2, xy, y^2, xz, yz, z^2, x, y,
// z, 1) and cubic (20: poseonly.solvers.fivept.MONOMIALS: the ten cubic terms, then the quadratic
// ones).
constexpr int kCubic[20][3] = {{3, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 3, 0}, {2, 0, 1}, {1, 1, 1}, {0, 2, 1},
                               {1, 0, 2}, {0, 1, 2}, {0, 0, 3}, {2, 0, 0}, {1, 1, 0}, {0, 2, 0}, {1, 0, 1},
                               {0, 1, 1}, {0, 0, 2}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};

using P1 = std::array<double, 4>;
using P2 = std::array<double, 10>;
using P3 = std::array<double, 20>;

// a * b (linear x linear -> quadratic) and q * b (quadratic x linear -> cubic) scaled by s, added to
// out: the products of the monomial tables above written out (the table-driven loops scattered every
// term through an index and cost ~3x more)
inline void mul11_add(const P1& a, const P1& b, double s, P2* out) {
  P2& o = *out;
  o[0] += s * (a[0] * b[0]);
  o[1] += s * (a[0] * b[1] + a[1] * b[0]);
  o[2] += s * (a[1] * b[1]);
  o[3] += s * (a[0] * b[2] + a[2] * b[0]);
  o[4] += s * (a[1] * b[2] + a[2] * b[1]);
  o[5] += s * (a[2] * b[2]);
  o[6] += s * (a[0] * b[3] + a[3] * b[0]);
  o[7] += s * (a[1] * b[3] + a[3] * b[1]);
  o[8] += s * (a[2] * b[3] + a[3] * b[2]);
  o[9] += s * (a[3] * b[3]);
}

inline void mul21_add(const P2& q, const P1& b, double s, P3* out) {
  P3& o = *out;
  o[0] += s * (q[0] * b[0]);
  o[1] += s * (q[0] * b[1] + q[1] * b[0]);
  o[2] += s * (q[1] * b[1] + q[2] * b[0]);
  o[3] += s * (q[2] * b[1]);
  o[4] += s * (q[0] * b[2] + q[3] * b[0]);
  o[5] += s * (q[1] * b[2] + q[3] * b[1] + q[4] * b[0]);
  o[6] += s * (q[2] * b[2] + q[4] * b[1]);
  o[7] += s * (q[3] * b[2] + q[5] * b[0]);
  o[8] += s * (q[4] * b[2] + q[5] * b[1]);
  o[9] += s * (q[5] * b[2]);
  o[10] += s * (q[0] * b[3] + q[6] * b[0]);
  o[11] += s * (q[1] * b[3] + q[6] * b[1] + q[7] * b[0]);
  o[12] += s * (q[2] * b[3] + q[7] * b[1]);
  o[13] += s * (q[3] * b[3] + q[6] * b[2] + q[8] * b[0]);
  o[14] += s * (q[4] * b[3] + q[7] * b[2] + q[8] * b[1]);
  o[15] += s * (q[5] * b[3] + q[8] * b[2]);
  o[16] += s * (q[6] * b[3] + q[9] * b[0]);
  o[17] += s * (q[7] * b[3] + q[9] * b[1]);
  o[18] += s * (q[8] * b[3] + q[9] * b[2]);
  o[19] += s * (q[9] * b[3]);
}

// The 10 x 20 template of E = x X + y Y + z Z + W (rows: Demazure cubic (a, c) -> 3 c + a, det).
void build_template(const Mat3 basis[4], Eigen::Matrix<double, 10, 20>* A) {
  P1 e[3][3];
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 4; ++k) e[a][c][k] = basis[k](a, c);
  P2 eet[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      P2 s{};
      for (int d = 0; d < 3; ++d) mul11_add(e[a][d], e[b][d], 1.0, &s);
      eet[a][b] = s;
      eet[b][a] = s;
    }
  P2 tr{};
  for (int q = 0; q < 10; ++q) tr[q] = eet[0][0][q] + eet[1][1][q] + eet[2][2][q];
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      P3 d{};
      for (int b = 0; b < 3; ++b) mul21_add(eet[a][b], e[b][c], 2.0, &d);
      mul21_add(tr, e[a][c], -1.0, &d);
      for (int m = 0; m < 20; ++m) (*A)(3 * c + a, m) = d[m];
    }
  // det E by the first row's cofactors
  P2 m0{}, m1{}, m2{};
  mul11_add(e[1][1], e[2][2], 1.0, &m0);
  mul11_add(e[1][2], e[2][1], -1.0, &m0);
  mul11_add(e[1][2], e[2][0], 1.0, &m1);
  mul11_add(e[1][0], e[2][2], -1.0, &m1);
  mul11_add(e[1][0], e[2][1], 1.0, &m2);
  mul11_add(e[1][1], e[2][0], -1.0, &m2);
  P3 det{};
  mul21_add(m0, e[0][0], 1.0, &det);
  mul21_add(m1, e[0][1], 1.0, &det);
  mul21_add(m2, e[0][2], 1.0, &det);
  for (int m = 0; m < 20; ++m) (*A)(9, m) = det[m];
}

// Gauss-Newton polish of a solution (x, y, z) of the ten template equations A m(x, y, z) = 0 (m the
// 20 cubic monomials): the eigenvalue/eigenvector pair is accurate to ~1e-10 relative; two steps bring
// the solution to rounding level. A step is kept only if it lowers |A m|.
constexpr int kPolishSteps = 2;

double template_residual(const Eigen::Matrix<double, 10, 20>& A, const double p[3], Eigen::Matrix<double, 10, 3>* J,
                         Eigen::Matrix<double, 10, 1>* F) {
  double pw[3][4];
  for (int d = 0; d < 3; ++d) {
    pw[d][0] = 1.0;
    for (int e = 1; e < 4; ++e) pw[d][e] = pw[d][e - 1] * p[d];
  }
  Eigen::Matrix<double, 20, 1> m;
  Eigen::Matrix<double, 20, 3> dm;
  for (int k = 0; k < 20; ++k) {
    const int* e = kCubic[k];
    m(k) = pw[0][e[0]] * pw[1][e[1]] * pw[2][e[2]];
    dm(k, 0) = e[0] ? e[0] * pw[0][e[0] - 1] * pw[1][e[1]] * pw[2][e[2]] : 0.0;
    dm(k, 1) = e[1] ? e[1] * pw[0][e[0]] * pw[1][e[1] - 1] * pw[2][e[2]] : 0.0;
    dm(k, 2) = e[2] ? e[2] * pw[0][e[0]] * pw[1][e[1]] * pw[2][e[2] - 1] : 0.0;
  }
  *F = A * m;
  if (J) *J = A * dm;
  return F->squaredNorm();
}

void polish(const Eigen::Matrix<double, 10, 20>& A, double p[3]) {
  Eigen::Matrix<double, 10, 3> J;
  Eigen::Matrix<double, 10, 1> F;
  double f = template_residual(A, p, &J, &F);
  for (int it = 0; it < kPolishSteps && f > 0.0; ++it) {
    const Vec3 dp = J.householderQr().solve(-F);
    if (!dp.allFinite()) return;
    double q[3] = {p[0] + dp(0), p[1] + dp(1), p[2] + dp(2)};
    Eigen::Matrix<double, 10, 3> Jn;
    Eigen::Matrix<double, 10, 1> Fn;
    const double fn = template_residual(A, q, &Jn, &Fn);
    if (!(fn < f)) return;
    std::copy(q, q + 3, p);
    f = fn;
    J = Jn;
    F = Fn;
  }
}

constexpr double kPolishMinV9 = 1e-8;  // |v9| / |v| below which (x, y, z) = v[6:9] / v9 is not formed

constexpr int kActionRows[6] = {0, 1, 2, 4, 5, 7};  // template rows of x * b_0 .. x * b_5
constexpr int kUnitCols[4] = {0, 1, 3, 6};          // x * (x, y, z, 1) = b_0, b_1, b_3, b_6
constexpr double kRankTol = 1e-12;                   // relative diagonal of R in the null-space QR

// cofactor matrix of a 3 x 3 matrix (rows: cross products of the other two rows)
inline Mat3 cofactor(const Mat3& E) {
  Mat3 C;
  C.row(0) = E.row(1).cross(E.row(2));
  C.row(1) = E.row(2).cross(E.row(0));
  C.row(2) = E.row(0).cross(E.row(1));
  return C;
}

// E at unit Frobenius norm with its largest entry positive, appended (nothing if E is 0 or not finite)
void push_essential(Mat3 Ee, std::vector<Mat3>* E) {
  const double ne = Ee.norm();
  if (!(ne > 0.0 && std::isfinite(ne))) return;
  Ee /= ne;
  Eigen::Index ir, ic;
  Ee.cwiseAbs().maxCoeff(&ir, &ic);
  if (Ee(ir, ic) < 0.0) Ee = -Ee;
  E->push_back(Ee);
}

// The real solutions from the eigenvalues of the action matrix of multiplication by x (Stewenius):
// backward stable, used when the Sturm chain of Nister's polynomial shows a near-multiple root.
void action_matrix_candidates(const Eigen::Matrix<double, 10, 20>& A, const Mat3 basis[4], bool polish_roots, std::vector<Mat3>* E) {
  // G = A1^-1 A2 by Gauss-Jordan elimination with partial pivoting on the row-major template (the
  // rows of [A1 | A2] are contiguous, so each update is one vectorised row operation)
  Eigen::Matrix<double, 10, 20, Eigen::RowMajor> T = A;
  if (!linalg::gauss_jordan<10, 20>(&T)) return;  // singular template
  Mat10 M = Mat10::Zero();
  for (int rr = 0; rr < 6; ++rr) M.row(rr) = -T.row(kActionRows[rr]).tail<10>();
  for (int rr = 0; rr < 4; ++rr) M(6 + rr, kUnitCols[rr]) = 1.0;
  if (!M.allFinite()) return;
  // --- eigenvalues: balancing, Hessenberg reduction, Francis QR; eigenvectors by inverse iteration
  double wr[10], wi[10];
  if (!linalg::eigenvalues<10>(M, wr, wi)) return;
  const double mnorm = M.cwiseAbs().maxCoeff();
  for (int e = 0; e < 10; ++e) {
    const double lr = wr[e], li = wi[e];
    if (!(std::abs(li) <= kFiveptRealTol * (1.0 + std::sqrt(lr * lr + li * li)))) continue;
    // the eigenvector v ~ b: the unit rows give v0 = lr^2 v9, v1 = lr v7, v3 = lr v8, v6 = lr v9, so
    // rows 0..5 of (M - lr I) v = 0 are a 6 x 6 homogeneous system in (v2, v4, v5, v7, v8, v9)
    Eigen::Matrix<double, 6, 6> K;
    const double l2 = lr * lr;
    for (int r = 0; r < 6; ++r) {
      K(r, 0) = M(r, 2) - (r == 2 ? lr : 0.0);
      K(r, 1) = M(r, 4) - (r == 4 ? lr : 0.0);
      K(r, 2) = M(r, 5) - (r == 5 ? lr : 0.0);
      K(r, 3) = M(r, 7) + lr * M(r, 1) - (r == 1 ? l2 : 0.0);
      K(r, 4) = M(r, 8) + lr * M(r, 3) - (r == 3 ? l2 : 0.0);
      K(r, 5) = M(r, 9) + lr * M(r, 6) + l2 * M(r, 0) - (r == 0 ? l2 * lr : 0.0);
    }
    int piv6[6];
    linalg::lu_inplace<6>(&K, piv6, 1e-300 + 1e-15 * (mnorm * (1.0 + l2 + l2 * std::abs(lr))));
    double u[6];
    std::fill(u, u + 6, 1.0);
    bool ok = true;
    for (int it = 0; it < 2 && ok; ++it) {  // two steps of inverse iteration
      linalg::lu_solve<6>(K, piv6, u);
      double nu = 0.0;
      for (double x : u) nu += x * x;
      nu = std::sqrt(nu);
      if (!(nu > 0.0 && std::isfinite(nu))) {
        ok = false;
        break;
      }
      for (double& x : u) x /= nu;
    }
    if (!ok) continue;
    double v[10];
    v[7] = u[3];
    v[8] = u[4];
    v[9] = u[5];
    v[6] = lr * u[5];
    Mat3 Ee;
    if (polish_roots && std::abs(v[9]) > kPolishMinV9 * std::sqrt(v[6] * v[6] + v[7] * v[7] + v[8] * v[8] + v[9] * v[9])) {
      double xyz[3] = {v[6] / v[9], v[7] / v[9], v[8] / v[9]};
      polish(A, xyz);
      Ee = xyz[0] * basis[0] + xyz[1] * basis[1] + xyz[2] * basis[2] + basis[3];
    } else {
      Ee = v[6] * basis[0] + v[7] * basis[1] + v[8] * basis[2] + v[9] * basis[3];
    }
    push_essential(Ee, E);
  }
}

// Nister's column order of the cubic monomials (indices into kCubic): the ten eliminated ones
// x^3, y^3, x^2 y, x y^2, x^2 z, x^2, y^2 z, y^2, x y z, x y, then x z^2, x z, x, y z^2, y z, y, z^3,
// z^2, z, 1
constexpr int kNisterCols[20] = {0, 3, 1, 2, 4, 10, 6, 12, 5, 11, 7, 13, 16, 8, 14, 17, 9, 15, 18, 19};
// a null vector of B(z) whose last entry is below this fraction of its norm gives no (x, y)
constexpr double kNisterMinW = 1e-12;
// Gauss-Jordan pivots in Nister's column order whose smallest is below this fraction of the largest:
// the polynomial's coefficients are then unreliable (measured on noise-free samples: at a baseline of
// 1/400 of the depth 4 % of the samples lost the true root, nearly all with a ratio below 1e-2; at
// ordinary parallax 6 % of the samples fall below it) and the action matrix is used
constexpr double kNisterMinPivotRatio = 1e-2;

inline void polymul(const double* a, int da, const double* b, int db, double s, double* out) {
  for (int i = 0; i <= da; ++i)
    for (int j = 0; j <= db; ++j) out[i + j] += s * a[i] * b[j];
}

// The real solutions by Nister's construction (CVPR 2003 / PAMI 2004): Gauss-Jordan elimination of
// the template in Nister's column order; rows (x^2 z, x^2), (y^2 z, y^2), (x y z, x y) give
// k = e - z f, l = g - z h, m = i - z j, linear in x, y with coefficients polynomial in z (cubic,
// cubic, quartic), i.e. B(z) (x, y, 1)^T = 0; the real roots of the degree-10 det B(z) by a Sturm
// sequence (sturm.h); (x, y, 1) from the cross product of two rows of B(z). False when elimination
// or the Sturm chain breaks down (a near-multiple root): the caller then takes the action matrix.
using NisterTemplate = Eigen::Matrix<double, 10, 20, Eigen::RowMajor>;

// Gauss-Jordan elimination of the template in Nister's column order; the smallest pivot over the
// largest (0 where the elimination breaks down)
double nister_eliminate(const Eigen::Matrix<double, 10, 20>& A, NisterTemplate* T) {
  for (int c = 0; c < 20; ++c) T->col(c) = A.col(kNisterCols[c]);
  double pivot_ratio = 0.0;
  if (!linalg::gauss_jordan<10, 20>(T, &pivot_ratio)) return 0.0;
  return pivot_ratio;
}

// The solutions from an eliminated template (nister_eliminate); false where the Sturm chain breaks down.
bool nister_solve(const Eigen::Matrix<double, 10, 20>& A, const NisterTemplate& T, const Mat3 basis[4], bool polish_roots, std::vector<Mat3>* E) {
  // rows: [x-poly (deg 3), y-poly (deg 3), 1-poly (deg 4)], ascending powers of z; the right block
  // of a row holds the coefficients of x z^2, x z, x, y z^2, y z, y, z^3, z^2, z, 1
  double Bp[3][3][5] = {};
  for (int r = 0; r < 3; ++r) {
    const auto e = T.row(4 + 2 * r).tail<10>();
    const auto f = T.row(5 + 2 * r).tail<10>();
    for (int v = 0; v < 2; ++v) {  // x (v = 0) and y (v = 1) blocks: 3 coefficients each
      const int o = 3 * v;
      double* q = Bp[r][v];
      q[0] = e(o + 2);
      q[1] = e(o + 1) - f(o + 2);
      q[2] = e(o + 0) - f(o + 1);
      q[3] = -f(o + 0);
    }
    double* q = Bp[r][2];
    q[0] = e(9);
    q[1] = e(8) - f(9);
    q[2] = e(7) - f(8);
    q[3] = e(6) - f(7);
    q[4] = -f(6);
  }
  // det B by the first row's cofactors: 2 x 2 minors of rows 1, 2 (degree 7 with the 1-column)
  double m0[8] = {}, m1[8] = {}, m2[7] = {};
  polymul(Bp[1][1], 3, Bp[2][2], 4, 1.0, m0);
  polymul(Bp[1][2], 4, Bp[2][1], 3, -1.0, m0);
  polymul(Bp[1][2], 4, Bp[2][0], 3, 1.0, m1);
  polymul(Bp[1][0], 3, Bp[2][2], 4, -1.0, m1);
  polymul(Bp[1][0], 3, Bp[2][1], 3, 1.0, m2);
  polymul(Bp[1][1], 3, Bp[2][0], 3, -1.0, m2);
  double c[11] = {};
  polymul(Bp[0][0], 3, m0, 7, 1.0, c);
  polymul(Bp[0][1], 3, m1, 7, 1.0, c);
  polymul(Bp[0][2], 4, m2, 6, 1.0, c);
  for (double v : c)
    if (!std::isfinite(v)) return false;
  double roots[10];
  int nr = 0;
  if (!sturm::real_roots<10>(c, roots, &nr)) return false;
  for (int k = 0; k < nr; ++k) {
    const double z = roots[k];
    Mat3 B;
    for (int r = 0; r < 3; ++r) {
      B(r, 0) = sturm::horner(Bp[r][0], 3, z);
      B(r, 1) = sturm::horner(Bp[r][1], 3, z);
      B(r, 2) = sturm::horner(Bp[r][2], 4, z);
    }
    Vec3 w = B.row(0).cross(B.row(1));
    for (const Vec3& u : {Vec3(B.row(1).cross(B.row(2))), Vec3(B.row(2).cross(B.row(0)))})
      if (u.squaredNorm() > w.squaredNorm()) w = u;
    if (!(std::abs(w(2)) > kNisterMinW * w.norm())) continue;
    double xyz[3] = {w(0) / w(2), w(1) / w(2), z};
    if (polish_roots) polish(A, xyz);
    push_essential(xyz[0] * basis[0] + xyz[1] * basis[1] + xyz[2] * basis[2] + basis[3], E);
  }
  return true;
}

// fivept_essentials; polish: the Gauss-Newton polish of (x, y, z) on the template (fivept_poses
// skips it: its Newton polish of the pose on the epipolar equations reaches rounding level anyway)
// (`used`: the construction that produced E, kNone where the sample is rank-deficient or the one
// construction asked for failed its test)
int essentials_impl(const Points& p, std::vector<Mat3>* E, bool polish_roots, FiveptPath path = FiveptPath::kAuto, FiveptPath* used = nullptr) {
  if (used) *used = FiveptPath::kNone;
  E->clear();
  if (p.n != 5) return 0;
  // --- null space of the epipolar rows: A^T (9 x 5), column i = kron(f1_i, f2_i) (E column-major)
  Eigen::Matrix<double, 9, 5> At;
  for (int i = 0; i < 5; ++i) {
    const auto a = p.a(i);
    const auto b = p.b(i);
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) At(3 * c + r, i) = a(c) * b(r);
  }
  double R5[25], tau[5];
  linalg::householder_qr<5>(At.data(), 9, R5, tau);
  double dmax = 0.0, dmin = kInf;
  for (int i = 0; i < 5; ++i) {
    dmax = std::max(dmax, std::abs(R5[6 * i]));
    dmin = std::min(dmin, std::abs(R5[6 * i]));
  }
  if (!(dmin > kRankTol * dmax)) return 0;  // rank-deficient sample (coincident or NaN points)
  Mat3 basis[4];  // columns 5..8 of Q: column-major E
  for (int k = 0; k < 4; ++k) {
    Vec9 q = Vec9::Zero();
    q(5 + k) = 1.0;
    linalg::householder_apply_q<5>(At.data(), 9, tau, q.data());
    basis[k] = Eigen::Map<const Mat3>(q.data());
  }
  Eigen::Matrix<double, 10, 20> A;
  build_template(basis, &A);
  NisterTemplate T;
  if (path != FiveptPath::kAction) {
    if (nister_eliminate(A, &T) >= kNisterMinPivotRatio && nister_solve(A, T, basis, polish_roots, E)) {
      if (used) *used = FiveptPath::kNister;
      return static_cast<int>(E->size());
    }
    E->clear();
    if (path == FiveptPath::kNister) return 0;  // the construction asked for failed its test
  }
  action_matrix_candidates(A, basis, polish_roots, E);
  if (used) *used = FiveptPath::kAction;
  return static_cast<int>(E->size());
}

// +1 when every point of p is in front of both cameras of (R, t), -1 when of (R, -t), 0 otherwise
// (it stops at the first point whose depths' signs differ from each other or from the first point's)
int chiral_sign(const Mat3& R, const Vec3& t, const Points& p) {
  int sign = 0;
  for (int i = 0; i < p.n; ++i) {
    double h, hp;
    depth_numerators(R, t, p.a(i), p.b(i), &h, &hp);
    const int si = (h > 0.0 && hp > 0.0) ? 1 : (h < 0.0 && hp < 0.0) ? -1 : 0;
    if (!si || (sign && si != sign)) return 0;
    sign = si;
  }
  return sign;
}

}  // namespace

int fivept_essentials(const Points& p, std::vector<Mat3>* E) { return essentials_impl(p, E, true); }

FiveptPath fivept_essentials_path(const Points& p, FiveptPath path, std::vector<Mat3>* E) {
  FiveptPath used;
  essentials_impl(p, E, true, path, &used);
  return used;
}

bool decompose_chiral(const Mat3& E0, const Points& p, Pose* pose) {
  const double ne = E0.norm();
  if (!(ne > 0.0 && std::isfinite(ne))) return false;
  const Mat3 E = E0 * (std::sqrt(2.0) / ne);  // |[t]x R|_F = sqrt(2) for unit t
  // t spans the left null space of E: the largest cross product of two columns
  Vec3 t = E.col(0).cross(E.col(1));
  for (const Vec3& c : {Vec3(E.col(1).cross(E.col(2))), Vec3(E.col(2).cross(E.col(0)))})
    if (c.squaredNorm() > t.squaredNorm()) t = c;
  const double nt = t.norm();
  if (!(nt > 0.0)) return false;
  t /= nt;
  // E = [s t]x R with s = +-1: R = cof(E) - s [t]x E (cof([t]x) = t t^T, cof(R) = R)
  const Mat3 C = cofactor(E);
  const Mat3 TE = skew(t) * E;
  for (int s = 0; s < 2; ++s) {
    Mat3 R = s == 0 ? Mat3(C - TE) : Mat3(C + TE);
    // the points' cheirality on the unpolished R first (a rotation to the solver's rounding): most
    // candidates of a contaminated sample fail on their first points, before the polish is paid
    const int sign = chiral_sign(R, t, p);
    if (!sign) continue;
    for (int it = 0; it < 2; ++it) {  // Newton steps of the polar decomposition: R <- (R + R^-T) / 2
      const double d = R.determinant();
      if (!(std::abs(d) > 0.0)) break;
      R = 0.5 * (R + cofactor(R) / d);
    }
    if (chiral_sign(R, t, p) != sign) continue;  // the returned pose passes on its own R
    pose->R = R;
    pose->t = sign > 0 ? t : Vec3(-t);
    return true;
  }
  return false;
}

namespace {

constexpr int kPoseNewtonSteps = 4;  // at most; stops when a step no longer lowers the residual
constexpr double kPoseStepTol = 1e-15;  // |dx| below which the iteration has converged
// largest epipolar residual (a triple product of unit vectors) at which the pose is exact to rounding:
// a further step could not lower it measurably
constexpr double kPoseResidualTol = 1e-15;

double epipolar_residuals(const Pose& P, const Points& p, double r[5]) {
  double m = 0.0;
  for (int i = 0; i < 5; ++i) {
    r[i] = (P.R * p.a(i)).dot(p.b(i).cross(P.t));
    m = std::max(m, std::abs(r[i]));
  }
  return m;
}

// Newton steps on the five epipolar equations f2_i^T [t]x R f1_i = 0 in the 5 pose parameters
// (R <- exp([dw]x) R, t <- normalize(t + B dv)). The linear null space of the epipolar rows is
// ill-conditioned when the parallax is small (it nearly contains every [t]x R); the pose equations
// have the geometric conditioning, so this removes the algebraic error amplification. A step is kept
// only if the largest residual decreases and the chirality of all five points is unchanged.
void polish_pose(const Points& p, Pose* pose) {
  double r[5];
  double f = epipolar_residuals(*pose, p, r);
  for (int it = 0; it < kPoseNewtonSteps && f > kPoseResidualTol; ++it) {
    Eigen::Index k;
    pose->t.cwiseAbs().minCoeff(&k);
    Vec3 e = Vec3::Zero();
    e(k) = 1.0;
    const Vec3 b1 = pose->t.cross(e).normalized();
    const Vec3 b2 = pose->t.cross(b1);
    Eigen::Matrix<double, 5, 5> J;
    Eigen::Matrix<double, 5, 1> rv;
    for (int i = 0; i < 5; ++i) {
      const Vec3 a = pose->R * p.a(i);
      const Vec3 g = a.cross(p.b(i).cross(pose->t));  // d r / d w
      const Vec3 h = a.cross(p.b(i));                 // d r / d t
      J.row(i) << g(0), g(1), g(2), h.dot(b1), h.dot(b2);
      rv(i) = r[i];
    }
    int piv[5];
    if (!linalg::lu_inplace<5>(&J, piv, 0.0)) return;
    Eigen::Matrix<double, 5, 1> dx = -rv;
    linalg::lu_solve<5>(J, piv, dx.data());
    if (!dx.allFinite()) return;
    Pose q;
    const Vec3 w = dx.head<3>();
    const double th = w.norm();
    q.R = (th > 0.0 ? Mat3(Eigen::AngleAxisd(th, w / th).toRotationMatrix()) : Mat3::Identity()) * pose->R;
    q.t = (pose->t + dx(3) * b1 + dx(4) * b2).normalized();
    double rq[5];
    const double fq = epipolar_residuals(q, p, rq);
    if (!(fq < f)) return;
    for (int i = 0; i < p.n; ++i) {
      double h0, hp0;
      depth_numerators(q.R, q.t, p.a(i), p.b(i), &h0, &hp0);
      if (!(h0 > 0.0 && hp0 > 0.0)) return;
    }
    *pose = q;
    f = fq;
    std::copy(rq, rq + 5, r);
    if (dx.norm() < kPoseStepTol) return;
  }
}

}  // namespace

void fivept_poses(const Points& p, std::vector<Pose>* out) {
  out->clear();
  std::vector<Mat3> E;
  E.reserve(10);
  essentials_impl(p, &E, false);
  for (const Mat3& e : E) {
    Pose pose;
    if (decompose_chiral(e, p, &pose)) {
      polish_pose(p, &pose);
      out->push_back(pose);
    }
  }
}

}  // namespace poseonly
