// Stewenius five-point solver (see fivept.h for the construction).
#include "fivept.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>

#include "residuals.h"

namespace poseonly {
namespace {

using Mat10 = Eigen::Matrix<double, 10, 10>;
using Vec10 = Eigen::Matrix<double, 10, 1>;

// Monomials of (x, y, z, 1): linear (4: x, y, z, 1), quadratic (10: x^2, xy, y^2, xz, yz, z^2, x, y,
// z, 1) and cubic (20: poseonly.solvers.fivept.MONOMIALS: the ten cubic terms, then the quadratic
// ones). Tables of the products linear x linear -> quadratic and quadratic x linear -> cubic.
struct MonomialTables {
  int q11[4][4];
  int c21[10][4];
  MonomialTables() {
    // exponents (x, y, z) of the quadratic and cubic bases
    static const int quad[10][3] = {{2, 0, 0}, {1, 1, 0}, {0, 2, 0}, {1, 0, 1}, {0, 1, 1},
                                    {0, 0, 2}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    static const int cub[20][3] = {{3, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 3, 0}, {2, 0, 1}, {1, 1, 1}, {0, 2, 1},
                                   {1, 0, 2}, {0, 1, 2}, {0, 0, 3}, {2, 0, 0}, {1, 1, 0}, {0, 2, 0}, {1, 0, 1},
                                   {0, 1, 1}, {0, 0, 2}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    auto unit = [](int i, int e[3]) {
      e[0] = e[1] = e[2] = 0;
      if (i < 3) e[i] = 1;
    };
    auto find = [](const int (*tab)[3], int m, const int e[3]) {
      for (int k = 0; k < m; ++k)
        if (tab[k][0] == e[0] && tab[k][1] == e[1] && tab[k][2] == e[2]) return k;
      return -1;
    };
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        int a[3], b[3], e[3];
        unit(i, a);
        unit(j, b);
        for (int d = 0; d < 3; ++d) e[d] = a[d] + b[d];
        q11[i][j] = find(quad, 10, e);
      }
    for (int q = 0; q < 10; ++q)
      for (int j = 0; j < 4; ++j) {
        int b[3], e[3];
        unit(j, b);
        for (int d = 0; d < 3; ++d) e[d] = quad[q][d] + b[d];
        c21[q][j] = find(cub, 20, e);
      }
  }
};

const MonomialTables& tables() {
  static const MonomialTables t;
  return t;
}

using P1 = std::array<double, 4>;
using P2 = std::array<double, 10>;
using P3 = std::array<double, 20>;

inline void mul11_add(const P1& a, const P1& b, double s, P2* out, const MonomialTables& T) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) (*out)[T.q11[i][j]] += s * a[i] * b[j];
}

inline void mul21_add(const P2& a, const P1& b, double s, P3* out, const MonomialTables& T) {
  for (int q = 0; q < 10; ++q)
    for (int j = 0; j < 4; ++j) (*out)[T.c21[q][j]] += s * a[q] * b[j];
}

// The 10 x 20 template of E = x X + y Y + z Z + W (rows: Demazure cubic (a, c) -> 3 c + a, det).
void build_template(const Mat3 basis[4], Eigen::Matrix<double, 10, 20>* A) {
  const MonomialTables& T = tables();
  P1 e[3][3];
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 4; ++k) e[a][c][k] = basis[k](a, c);
  P2 eet[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      P2 s{};
      for (int d = 0; d < 3; ++d) mul11_add(e[a][d], e[b][d], 1.0, &s, T);
      eet[a][b] = s;
      eet[b][a] = s;
    }
  P2 tr{};
  for (int q = 0; q < 10; ++q) tr[q] = eet[0][0][q] + eet[1][1][q] + eet[2][2][q];
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      P3 d{};
      for (int b = 0; b < 3; ++b) mul21_add(eet[a][b], e[b][c], 2.0, &d, T);
      mul21_add(tr, e[a][c], -1.0, &d, T);
      for (int m = 0; m < 20; ++m) (*A)(3 * c + a, m) = d[m];
    }
  // det E by the first row's cofactors
  P2 m0{}, m1{}, m2{};
  mul11_add(e[1][1], e[2][2], 1.0, &m0, T);
  mul11_add(e[1][2], e[2][1], -1.0, &m0, T);
  mul11_add(e[1][2], e[2][0], 1.0, &m1, T);
  mul11_add(e[1][0], e[2][2], -1.0, &m1, T);
  mul11_add(e[1][0], e[2][1], 1.0, &m2, T);
  mul11_add(e[1][1], e[2][0], -1.0, &m2, T);
  P3 det{};
  mul21_add(m0, e[0][0], 1.0, &det, T);
  mul21_add(m1, e[0][1], 1.0, &det, T);
  mul21_add(m2, e[0][2], 1.0, &det, T);
  for (int m = 0; m < 20; ++m) (*A)(9, m) = det[m];
}

// In-place LU with partial pivoting; zero pivots are floored at `floor` (inverse iteration on a
// singular matrix then still yields the null vector). Returns false if a pivot is exactly zero and
// floor == 0.
bool lu10(Mat10* L, int piv[10], double floor) {
  for (int k = 0; k < 10; ++k) {
    int pk = k;
    double big = std::abs((*L)(k, k));
    for (int i = k + 1; i < 10; ++i)
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
    for (int i = k + 1; i < 10; ++i) {
      const double f = ((*L)(i, k) *= inv);
      if (f != 0.0)
        for (int j = k + 1; j < 10; ++j) (*L)(i, j) -= f * (*L)(k, j);
    }
  }
  return true;
}

void lu10_solve(const Mat10& L, const int piv[10], double* b) {
  for (int k = 0; k < 10; ++k)  // the row interchanges (full rows were swapped: P A = L U)
    if (piv[k] != k) std::swap(b[k], b[piv[k]]);
  for (int k = 0; k < 10; ++k)
    for (int i = k + 1; i < 10; ++i) b[i] -= L(i, k) * b[k];
  for (int k = 9; k >= 0; --k) {
    double s = b[k];
    for (int j = k + 1; j < 10; ++j) s -= L(k, j) * b[j];
    b[k] = s / L(k, k);
  }
}

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

}  // namespace

int fivept_essentials(const Points& p, std::vector<Mat3>* E) {
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
  Eigen::HouseholderQR<Eigen::Matrix<double, 9, 5>> qr(At);
  const auto& QR = qr.matrixQR();
  double dmax = 0.0, dmin = kInf;
  for (int i = 0; i < 5; ++i) {
    dmax = std::max(dmax, std::abs(QR(i, i)));
    dmin = std::min(dmin, std::abs(QR(i, i)));
  }
  if (!(dmin > kRankTol * dmax)) return 0;  // rank-deficient sample (coincident or NaN points)
  const Eigen::Matrix<double, 9, 9> Q = qr.householderQ();
  Mat3 basis[4];
  for (int k = 0; k < 4; ++k) basis[k] = Eigen::Map<const Mat3>(Q.col(5 + k).data());  // column-major E
  // --- template, elimination, action matrix
  Eigen::Matrix<double, 10, 20> A;
  build_template(basis, &A);
  Mat10 A1 = A.leftCols<10>();
  int piv[10];
  if (!lu10(&A1, piv, 0.0)) return 0;
  Mat10 M = Mat10::Zero();
  double col[10];
  for (int c = 0; c < 10; ++c) {
    for (int r = 0; r < 10; ++r) col[r] = A(r, 10 + c);
    lu10_solve(A1, piv, col);
    for (int rr = 0; rr < 6; ++rr) M(rr, c) = -col[kActionRows[rr]];
  }
  for (int rr = 0; rr < 4; ++rr) M(6 + rr, kUnitCols[rr]) = 1.0;
  if (!M.allFinite()) return 0;
  // --- eigenvalues (real Schur form), eigenvectors by inverse iteration
  Eigen::EigenSolver<Mat10> es;
  es.compute(M, false);
  if (es.info() != Eigen::Success) return 0;
  const auto lam = es.eigenvalues();
  const double mnorm = M.cwiseAbs().maxCoeff();
  for (int e = 0; e < 10; ++e) {
    const double lr = lam(e).real(), li = lam(e).imag();
    if (!(std::abs(li) <= kFiveptRealTol * (1.0 + std::abs(lam(e))))) continue;
    Mat10 L = M;
    L.diagonal().array() -= lr;
    lu10(&L, piv, 1e-300 + 1e-15 * mnorm);
    double v[10];
    std::fill(v, v + 10, 1.0);
    bool ok = true;
    for (int it = 0; it < 2 && ok; ++it) {
      lu10_solve(L, piv, v);
      double nv = 0.0;
      for (double x : v) nv += x * x;
      nv = std::sqrt(nv);
      if (!(nv > 0.0 && std::isfinite(nv))) {
        ok = false;
        break;
      }
      for (double& x : v) x /= nv;
    }
    if (!ok) continue;
    Mat3 Ee = v[6] * basis[0] + v[7] * basis[1] + v[8] * basis[2] + v[9] * basis[3];
    const double ne = Ee.norm();
    if (!(ne > 0.0 && std::isfinite(ne))) continue;
    Ee /= ne;
    Eigen::Index ir, ic;
    Ee.cwiseAbs().maxCoeff(&ir, &ic);
    if (Ee(ir, ic) < 0.0) Ee = -Ee;
    E->push_back(Ee);
  }
  return static_cast<int>(E->size());
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
    for (int it = 0; it < 2; ++it) {  // Newton steps of the polar decomposition: R <- (R + R^-T) / 2
      const double d = R.determinant();
      if (!(std::abs(d) > 0.0)) break;
      R = 0.5 * (R + cofactor(R) / d);
    }
    int pos = 0, neg = 0;
    for (int i = 0; i < p.n; ++i) {
      double h, hp;
      depth_numerators(R, t, p.a(i), p.b(i), &h, &hp);
      if (h > 0.0 && hp > 0.0) ++pos;
      else if (h < 0.0 && hp < 0.0) ++neg;
    }
    if (pos == p.n || neg == p.n) {
      pose->R = R;
      pose->t = pos == p.n ? t : Vec3(-t);
      return true;
    }
  }
  return false;
}

void fivept_poses(const Points& p, std::vector<Pose>* out) {
  out->clear();
  std::vector<Mat3> E;
  E.reserve(10);
  fivept_essentials(p, &E);
  for (const Mat3& e : E) {
    Pose pose;
    if (decompose_chiral(e, p, &pose)) out->push_back(pose);
  }
}

}  // namespace poseonly
