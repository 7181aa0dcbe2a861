// Levenberg-Marquardt pose refinements (see refine.h for the chart, the losses and the LM rules).
#include "refine.h"

#include <Eigen/LU>

#include "analysis.h"
#include "residuals.h"

#include <algorithm>
#include <optional>
#include <vector>

namespace poseonly {
namespace {

// Signed Sampson residuals (and, with J, their chart Jacobians J[k * kSampsonBlock + i]) of the
// points [i0, i0 + m) at the pose R, t with the chart's Jl, Jt: sampson_point's operations in the
// same order per point (bit-identical), in simple loops over the block that run on SIMD lanes (an
// AVX2 clone chosen at load time; no FMA, so every clone rounds as the scalar code).
constexpr int kSampsonBlock = 32;

POSEONLY_SIMD_CLONES
void sampson_jac_block(const double* Rm, const double* tv, const double* Jlm, const double* Jtm, const SoaPoints& S, int i0, int m,
                       double* r, double* J) {
  double R[9], t[3], L[9], T[6];  // local copies (no aliasing with r, J): row-major R and Jl, t, Jt (3 x 2, row-major)
  for (int k = 0; k < 9; ++k) R[k] = Rm[k], L[k] = Jlm[k];
  for (int k = 0; k < 3; ++k) t[k] = tv[k];
  for (int k = 0; k < 6; ++k) T[k] = Jtm[k];
  const double *x1 = S.x1.data() + i0, *y1 = S.y1.data() + i0, *z1 = S.z1.data() + i0;
  const double *x2 = S.x2.data() + i0, *y2 = S.y2.data() + i0, *z2 = S.z2.data() + i0;
  // pass 1: a = R f1, s = f2 x t, u = t x a and the residual, per point of the block
  double a0[kSampsonBlock], a1[kSampsonBlock], a2[kSampsonBlock], s0[kSampsonBlock], s1[kSampsonBlock], s2[kSampsonBlock];
  double u0[kSampsonBlock], u1[kSampsonBlock], u2[kSampsonBlock], num[kSampsonBlock], q[kSampsonBlock], live[kSampsonBlock];
  for (int i = 0; i < m; ++i) {
    a0[i] = R[0] * x1[i] + R[1] * y1[i] + R[2] * z1[i];
    a1[i] = R[3] * x1[i] + R[4] * y1[i] + R[5] * z1[i];
    a2[i] = R[6] * x1[i] + (R[7] * y1[i] + R[8] * z1[i]);  // Eigen's 3x3 product: rows 0-1 as a packet, row 2 scalar (x0 + (x1 + x2))
    s0[i] = y2[i] * t[2] - z2[i] * t[1], s1[i] = z2[i] * t[0] - x2[i] * t[2], s2[i] = x2[i] * t[1] - y2[i] * t[0];
    u0[i] = t[1] * a2[i] - t[2] * a1[i], u1[i] = t[2] * a0[i] - t[0] * a2[i], u2[i] = t[0] * a1[i] - t[1] * a0[i];
    num[i] = a0[i] * s0[i] + a1[i] * s1[i] + a2[i] * s2[i];
    const double den_raw = (u0[i] * u0[i] + u1[i] * u1[i] + u2[i] * u2[i]) + (s0[i] * s0[i] + s1[i] * s1[i] + s2[i] * s2[i]) - 2.0 * num[i] * num[i];
    const double den = den_raw < kTiny ? kTiny : den_raw;  // std::max(den_raw, kTiny)
    q[i] = 1.0 / std::sqrt(den);
    r[i] = num[i] * q[i];
    live[i] = den_raw > kTiny ? 1.0 : 0.0;  // else no epipolar geometry for this point: flat
  }
  if (!J) return;
  // pass 2: the five chart derivatives, one loop each
  for (int k = 0; k < 3; ++k) {
    const double c0 = L[k], c1 = L[3 + k], c2 = L[6 + k];  // Jl.col(k)
    double* Jk = J + k * kSampsonBlock;
    for (int i = 0; i < m; ++i) {
      const double d0 = c1 * a2[i] - c2 * a1[i], d1 = c2 * a0[i] - c0 * a2[i], d2 = c0 * a1[i] - c1 * a0[i];
      const double dnum = d0 * s0[i] + d1 * s1[i] + d2 * s2[i];
      const double e0 = t[1] * d2 - t[2] * d1, e1 = t[2] * d0 - t[0] * d2, e2 = t[0] * d1 - t[1] * d0;
      const double dden = 2.0 * (u0[i] * e0 + u1[i] * e1 + u2[i] * e2) - 4.0 * num[i] * dnum;
      const double q3 = q[i] * q[i] * q[i];
      Jk[i] = live[i] != 0.0 ? q[i] * dnum - 0.5 * num[i] * q3 * dden : 0.0;
    }
  }
  for (int k = 0; k < 2; ++k) {
    const double c0 = T[k], c1 = T[2 + k], c2 = T[4 + k];  // Jt.col(k)
    double* Jk = J + (3 + k) * kSampsonBlock;
    for (int i = 0; i < m; ++i) {
      const double d0 = y2[i] * c2 - z2[i] * c1, d1 = z2[i] * c0 - x2[i] * c2, d2 = x2[i] * c1 - y2[i] * c0;  // f2 x dt
      const double dnum = a0[i] * d0 + a1[i] * d1 + a2[i] * d2;
      const double e0 = c1 * a2[i] - c2 * a1[i], e1 = c2 * a0[i] - c0 * a2[i], e2 = c0 * a1[i] - c1 * a0[i];  // dt x a
      const double dden = 2.0 * (u0[i] * e0 + u1[i] * e1 + u2[i] * e2) + 2.0 * (s0[i] * d0 + s1[i] * d1 + s2[i] * d2) - 4.0 * num[i] * dnum;
      const double q3 = q[i] * q[i] * q[i];
      Jk[i] = live[i] != 0.0 ? q[i] * dnum - 0.5 * num[i] * q3 * dden : 0.0;
    }
  }
}

// The per-point terms of the IRLS normal equations of a block (Problem::eval's sums, the same
// operations per point): with J scaled by the point's residual weight sw, row a of T holds
// drho (0 + J_a r) (the gradient, a < 5), then drho (0 + J_a J_b) for a <= b (15 rows).
constexpr int kNormalTerms = 20;

POSEONLY_SIMD_CLONES
void sampson_normal_terms(const double* J, const double* sw, const double* rs, const double* dr, int m, double* T) {
  double Js[5][kSampsonBlock];
  for (int a = 0; a < 5; ++a)
    for (int i = 0; i < m; ++i) Js[a][i] = J[a * kSampsonBlock + i] * sw[i];
  for (int a = 0; a < 5; ++a)
    for (int i = 0; i < m; ++i) T[a * kSampsonBlock + i] = dr[i] * (0.0 + Js[a][i] * rs[i]);
  int row = 5;
  for (int a = 0; a < 5; ++a)
    for (int b = a; b < 5; ++b, ++row)
      for (int i = 0; i < m; ++i) T[row * kSampsonBlock + i] = dr[i] * (0.0 + Js[a][i] * Js[b][i]);
}

using Mat32 = Eigen::Matrix<double, 3, 2>;
using Mat5 = Eigen::Matrix<double, 5, 5>;
using Vec5 = Eigen::Matrix<double, 5, 1>;

constexpr double kLambda0 = 1e-3;
constexpr double kLambdaMin = 1e-15;
constexpr double kLambdaMax = 1e16;
constexpr double kLambdaDown = 3.0;
constexpr double kLambdaUp = 10.0;
constexpr double kDiagFloor = 1e-300;
constexpr double kCCFloor = 1e-30;  // theta^4 floor of the normalised LiGT residuals (ligt._CC_FLOOR)

// ---------------------------------------------------------------------------------------------
// the chart of poseonly.refine._manifold.PoseChart (same formulas and series thresholds)

struct Chart {
  Mat3 R0;
  Vec3 t0;
  Mat32 B;
  explicit Chart(const Pose& p) : R0(p.R), t0(p.t.normalized()) {
    Eigen::Index k;
    t0.cwiseAbs().minCoeff(&k);  // the axis least aligned with t0 (first on ties, as np.argmin)
    Vec3 e = Vec3::Zero();
    e(k) = 1.0;
    const Vec3 b1 = t0.cross(e).normalized();
    B.col(0) = b1;
    B.col(1) = t0.cross(b1);
  }
  // R(x), t(x) and (want) J_l(w), Jt = dt/dv.
  void eval(const double* x, bool want, Mat3* R, Vec3* t, Mat3* Jl, Mat32* Jt) const {
    const double th2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    const double th = std::sqrt(th2);
    const Mat3 K = skew(Vec3(x[0], x[1], x[2]));
    const Mat3 K2 = K * K;
    double a, b;
    if (th < 1e-8) {
      a = 1.0 - th2 / 6.0;
      b = 0.5 - th2 / 24.0;
    } else {
      a = std::sin(th) / th;
      b = (1.0 - std::cos(th)) / th2;
    }
    *R = (Mat3::Identity() + a * K + b * K2) * R0;
    const Vec3 u = t0 + B * Eigen::Vector2d(x[3], x[4]);
    const double nu = u.norm();
    *t = u / nu;
    if (!want) return;
    double c, d;
    if (th2 < 1e-12) {
      c = 0.5 - th2 / 24.0;
      d = 1.0 / 6.0 - th2 / 120.0;
    } else {
      c = (1.0 - std::cos(th)) / th2;
      d = (th - std::sin(th)) / (th2 * th);
    }
    *Jl = Mat3::Identity() + c * K + d * K2;
    *Jt = (B - (*t) * ((*t).transpose() * B)) / nu;
  }
};

// rho(s), rho'(s) of the scipy losses
inline void rho_of(RefineLoss loss, double s, double* rho, double* drho) {
  switch (loss) {
    case RefineLoss::Linear: *rho = s; *drho = 1.0; return;
    case RefineLoss::SoftL1: {
      const double r = std::sqrt(1.0 + s);
      *rho = 2.0 * (r - 1.0);
      *drho = 1.0 / r;
      return;
    }
    case RefineLoss::Huber:
      if (s > 1.0) {
        const double r = std::sqrt(s);
        *rho = 2.0 * r - 1.0;
        *drho = 1.0 / r;
      } else {
        *rho = s;
        *drho = 1.0;
      }
      return;
    case RefineLoss::Cauchy: *rho = std::log1p(s); *drho = 1.0 / (1.0 + s); return;
    case RefineLoss::Arctan: *rho = std::atan(s); *drho = 1.0 / (1.0 + s * s); return;
    case RefineLoss::Truncated:
      *rho = std::min(s, 1.0);
      *drho = s < 1.0 ? 1.0 : 0.0;
      return;
    case RefineLoss::TruncatedMulti:
      *rho = std::min(s, 1.0) + 4.0 * std::min(s, 0.25) + 16.0 * std::min(s, 0.0625);
      *drho = (s < 1.0 ? 1.0 : 0.0) + (s < 0.25 ? 4.0 : 0.0) + (s < 0.0625 ? 16.0 : 0.0);
      return;
  }
  *rho = s;
  *drho = 1.0;
}

// ---------------------------------------------------------------------------------------------
// per-point residuals and Jacobians (J[c][k] = d r_c / d x_k); unweighted

struct Frame {  // the pose quantities of one chart point
  Mat3 R, Jl;
  Vec3 t;
  Mat32 Jt;
};

// LiGT (poseonly.refine.ligt._ligt_terms / _kernels_nb.ligt_normal_nb, the same expression order)
inline void ligt_point(const Frame& F, const Vec3& f1, const Vec3& f2, int norm, bool want, double r[3], double J[3][5]) {
  const double y0 = f2(0), y1 = f2(1), y2 = f2(2);
  const Vec3 a = F.R * f1;
  const double a0 = a(0), a1 = a(1), a2 = a(2);
  const double t0 = F.t(0), t1 = F.t(1), t2 = F.t(2);
  const double c0 = y1 * a2 - y2 * a1, c1 = y2 * a0 - y0 * a2, c2 = y0 * a1 - y1 * a0;
  const double s0 = y1 * t2 - y2 * t1, s1 = y2 * t0 - y0 * t2, s2 = y0 * t1 - y1 * t0;
  double cc = c0 * c0 + c1 * c1 + c2 * c2;
  const double cs = c0 * s0 + c1 * s1 + c2 * s2;
  double z = 0.0, q0 = 0.0, q1 = 0.0, q2 = 0.0, P0 = 0.0, P1 = 0.0, P2 = 0.0, nP = 1.0;
  if (norm == 0) {
    r[0] = cc * s0 - c0 * cs;
    r[1] = cc * s1 - c1 * cs;
    r[2] = cc * s2 - c2 * cs;
  } else {
    cc = std::max(cc, kCCFloor);
    z = -cs / cc;
    q0 = s0 + z * c0;
    q1 = s1 + z * c1;
    q2 = s2 + z * c2;
    if (norm == 1) {
      r[0] = q0;
      r[1] = q1;
      r[2] = q2;
    } else {
      P0 = z * a0 + t0;
      P1 = z * a1 + t1;
      P2 = z * a2 + t2;
      nP = std::max(std::sqrt(P0 * P0 + P1 * P1 + P2 * P2), 1e-300);
      r[0] = q0 / nP;
      r[1] = q1 / nP;
      r[2] = q2 / nP;
    }
  }
  if (!want) return;
  for (int k = 0; k < 5; ++k) {
    double dA[3] = {0, 0, 0}, dC[3] = {0, 0, 0}, dS[3] = {0, 0, 0}, dT[3] = {0, 0, 0};
    if (k < 3) {
      const double j0 = F.Jl(0, k), j1 = F.Jl(1, k), j2 = F.Jl(2, k);
      dA[0] = j1 * a2 - j2 * a1;
      dA[1] = j2 * a0 - j0 * a2;
      dA[2] = j0 * a1 - j1 * a0;
      dC[0] = y1 * dA[2] - y2 * dA[1];
      dC[1] = y2 * dA[0] - y0 * dA[2];
      dC[2] = y0 * dA[1] - y1 * dA[0];
    } else {
      dT[0] = F.Jt(0, k - 3);
      dT[1] = F.Jt(1, k - 3);
      dT[2] = F.Jt(2, k - 3);
      dS[0] = y1 * dT[2] - y2 * dT[1];
      dS[1] = y2 * dT[0] - y0 * dT[2];
      dS[2] = y0 * dT[1] - y1 * dT[0];
    }
    const double dcc = 2.0 * (dC[0] * c0 + dC[1] * c1 + dC[2] * c2);
    const double dcs = dC[0] * s0 + dC[1] * s1 + dC[2] * s2 + c0 * dS[0] + c1 * dS[1] + c2 * dS[2];
    if (norm == 0) {
      J[0][k] = s0 * dcc + cc * dS[0] - c0 * dcs - cs * dC[0];
      J[1][k] = s1 * dcc + cc * dS[1] - c1 * dcs - cs * dC[1];
      J[2][k] = s2 * dcc + cc * dS[2] - c2 * dcs - cs * dC[2];
    } else {
      const double dz = -dcs / cc + (cs / (cc * cc)) * dcc;
      const double e0 = dS[0] + c0 * dz + z * dC[0];
      const double e1 = dS[1] + c1 * dz + z * dC[1];
      const double e2 = dS[2] + c2 * dz + z * dC[2];
      if (norm == 1) {
        J[0][k] = e0;
        J[1][k] = e1;
        J[2][k] = e2;
      } else {
        const double dP0 = a0 * dz + z * dA[0] + dT[0];
        const double dP1 = a1 * dz + z * dA[1] + dT[1];
        const double dP2 = a2 * dz + z * dA[2] + dT[2];
        const double f = (P0 * dP0 + P1 * dP1 + P2 * dP2) / (nP * nP * nP);
        J[0][k] = e0 / nP - q0 * f;
        J[1][k] = e1 / nP - q1 * f;
        J[2][k] = e2 / nP - q2 * f;
      }
    }
  }
}

// Sampson distance r = num / sqrt(den), num = f2^T [t]x R f1 = a . s (a = R f1, s = f2 x t),
// den = |t x a|^2 + |s|^2 - 2 num^2 (|E^T f2| = |R^T (f2 x t)| = |s|); floored at kTiny as residuals.h.
inline void sampson_point(const Frame& F, const Vec3& f1, const Vec3& f2, bool want, double r[1], double J[1][5]) {
  const Vec3 a = F.R * f1;
  const Vec3 s = f2.cross(F.t);
  const Vec3 u = F.t.cross(a);
  const double num = a.dot(s);
  const double den_raw = u.squaredNorm() + s.squaredNorm() - 2.0 * num * num;
  const double den = std::max(den_raw, kTiny);
  const double q = 1.0 / std::sqrt(den);
  r[0] = num * q;
  if (!want) return;
  if (!(den_raw > kTiny)) {  // no epipolar geometry for this point (f1 or f2 along t): flat
    for (int k = 0; k < 5; ++k) J[0][k] = 0.0;
    return;
  }
  const double q3 = q * q * q;
  for (int k = 0; k < 5; ++k) {
    double dnum, dden;
    if (k < 3) {
      const Vec3 da = F.Jl.col(k).cross(a);  // d(R f1)/dw_k = -[a]x J_l e_k
      dnum = da.dot(s);
      const Vec3 du = F.t.cross(da);
      dden = 2.0 * u.dot(du) - 4.0 * num * dnum;
    } else {
      const Vec3 dt = F.Jt.col(k - 3);
      const Vec3 ds = f2.cross(dt);
      dnum = a.dot(ds);
      const Vec3 du = dt.cross(a);
      dden = 2.0 * u.dot(du) + 2.0 * s.dot(ds) - 4.0 * num * dnum;
    }
    J[0][k] = q * dnum - 0.5 * num * q3 * dden;
  }
}

// ---------------------------------------------------------------------------------------------
// robust cost and IRLS normal equations over all points

struct Problem {
  const Points& p;
  const double* w;  // weights (not square roots) or nullptr
  int kind;         // 0 Sampson, 1 + normalization LiGT
  RefineLoss loss;
  double scale;
  const Chart& chart;
  bool outer = false;  // w_i multiplies rho instead of scaling r (RefineOptions::weights_outside)
  const double* v = nullptr;  // with outer: residual weights scaling r (RefineOptions::residual_weights)
  const SoaPoints* soa = nullptr;  // Sampson: the points as coordinate arrays (the block path of eval)
  // sqrt of the weight that scales point i's residual
  double inner(int i) const { return outer ? (v ? std::sqrt(v[i]) : 1.0) : (w ? std::sqrt(w[i]) : 1.0); }
  int dim() const { return kind == 0 ? 1 : 3; }

  void point(const Frame& F, int i, bool want, double r[3], double J[3][5]) const {
    if (kind == 0) sampson_point(F, p.a(i), p.b(i), want, r, J);
    else ligt_point(F, p.a(i), p.b(i), kind - 1, want, r, J);
  }

  // Sampson with the points as coordinate arrays: residuals, Jacobians and the normal equations'
  // terms per block of points (sampson_jac_block, sampson_normal_terms: the values of point() and of
  // eval's loop), summed in point order (bit-identical to the loop)
  double eval_blocks(const Frame& F, bool want, Mat5* H, Vec5* g) const {
    const double s2 = scale * scale;
    double Rm[9], Lm[9], Tm[6];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) Rm[3 * a + b] = F.R(a, b), Lm[3 * a + b] = want ? F.Jl(a, b) : 0.0;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 2; ++b) Tm[2 * a + b] = want ? F.Jt(a, b) : 0.0;
    double rb[kSampsonBlock], Jb[5 * kSampsonBlock], swb[kSampsonBlock], rsb[kSampsonBlock], drb[kSampsonBlock];
    double Tb[kNormalTerms * kSampsonBlock];
    bool use[kSampsonBlock];
    double acc[kNormalTerms] = {};
    double cost = 0.0;
    for (int i0 = 0; i0 < p.n; i0 += kSampsonBlock) {
      const int m = std::min(kSampsonBlock, p.n - i0);
      sampson_jac_block(Rm, F.t.data(), Lm, Tm, *soa, i0, m, rb, want ? Jb : nullptr);
      for (int k = 0; k < m; ++k) {
        const int i = i0 + k;
        use[k] = !(outer && w && w[i] == 0.0);
        swb[k] = rsb[k] = drb[k] = 0.0;
        if (!use[k]) continue;
        const double sw = inner(i);
        const double r0 = rb[k] * sw;
        double sq = 0.0;
        sq += r0 * r0;
        double rho, drho;
        rho_of(loss, sq / s2, &rho, &drho);
        if (outer && w) {
          rho *= w[i];
          drho *= w[i];
        }
        cost += s2 * rho;
        swb[k] = sw, rsb[k] = r0, drb[k] = drho;
      }
      if (!want) continue;
      sampson_normal_terms(Jb, swb, rsb, drb, m, Tb);
      for (int k = 0; k < m; ++k) {
        if (!use[k]) continue;
        for (int j = 0; j < kNormalTerms; ++j) acc[j] += Tb[j * kSampsonBlock + k];
      }
    }
    if (want) {
      for (int a = 0; a < 5; ++a) (*g)(a) = acc[a];
      int row = 5;
      for (int a = 0; a < 5; ++a)
        for (int b = a; b < 5; ++b, ++row) (*H)(a, b) = (*H)(b, a) = acc[row];
    }
    return cost;
  }

  // cost s^2 sum rho(|r_i|^2 / s^2); with want also H and g
  double eval(const double* x, bool want, Mat5* H, Vec5* g) const {
    Frame F;
    chart.eval(x, want, &F.R, &F.t, &F.Jl, &F.Jt);
    if (kind == 0 && soa) return eval_blocks(F, want, H, g);
    const int m = dim();
    const double s2 = scale * scale;
    double Hs[5][5] = {}, gs[5] = {};
    double cost = 0.0;
    double r[3], J[3][5];
    for (int i = 0; i < p.n; ++i) {
      if (outer && w && w[i] == 0.0) continue;
      point(F, i, want, r, J);
      const double sw = inner(i);
      double sq = 0.0;
      for (int c = 0; c < m; ++c) {
        r[c] *= sw;
        sq += r[c] * r[c];
      }
      double rho, drho;
      rho_of(loss, sq / s2, &rho, &drho);
      if (outer && w) {
        rho *= w[i];
        drho *= w[i];
      }
      cost += s2 * rho;
      if (!want) continue;
      for (int c = 0; c < m; ++c)
        for (int k = 0; k < 5; ++k) J[c][k] *= sw;
      for (int a = 0; a < 5; ++a) {
        double ga = 0.0;
        for (int c = 0; c < m; ++c) ga += J[c][a] * r[c];
        gs[a] += drho * ga;
        for (int b = a; b < 5; ++b) {
          double h = 0.0;
          for (int c = 0; c < m; ++c) h += J[c][a] * J[c][b];
          Hs[a][b] += drho * h;
        }
      }
    }
    if (want) {
      for (int a = 0; a < 5; ++a) {
        (*g)(a) = gs[a];
        for (int b = a; b < 5; ++b) (*H)(a, b) = (*H)(b, a) = Hs[a][b];
      }
    }
    return cost;
  }
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + h, v.end());
  const double hi = v[h];
  if (v.size() % 2) return hi;
  const double lo = *std::max_element(v.begin(), v.begin() + h);
  return 0.5 * (lo + hi);
}

// default scale: 1.4826 median over the points with positive weight (all if none) of |sqrt(w_i) r_i|
// (of |sqrt(v_i) r_i| with outer weights w and residual weights v)
double default_scale(const Points& p, const double* w, int kind, const Chart& chart, bool outer, const double* v) {
  Frame F;
  const double x0[5] = {0, 0, 0, 0, 0};
  chart.eval(x0, false, &F.R, &F.t, &F.Jl, &F.Jt);
  const Problem pr{p, w, kind, RefineLoss::Linear, 1.0, chart, outer, v};
  std::vector<double> all, pos;
  all.reserve(p.n);
  pos.reserve(p.n);
  double r[3], J[3][5];
  for (int i = 0; i < p.n; ++i) {
    pr.point(F, i, false, r, J);
    const double sw = w ? std::sqrt(w[i]) : 1.0;
    const double rs = pr.inner(i);  // outer weights do not scale the residuals
    double sq = 0.0;
    for (int c = 0; c < pr.dim(); ++c) sq += (rs * r[c]) * (rs * r[c]);
    all.push_back(std::sqrt(sq));
    if (sw > 0.0) pos.push_back(all.back());
  }
  return std::max(kMadFactor * median(pos.empty() ? all : pos), kMinLossScale);
}

// the LM loop of poseonly.refine.ligt._lm
// From x = 0 with its cost F0, normal matrix H and gradient g (one evaluation, counted); returns the
// cost at the returned x (the last accepted evaluation's)
double levenberg_marquardt(const Problem& pr, int max_iter, double tol, double F0, Mat5 H, Vec5 g, double x[5], RefineStats* st) {
  Mat5 Hn;
  Vec5 gn;
  Vec5 xv = Vec5::Zero();
  double F = F0;
  int nfev = 1, njev = 1;
  Vec5 d = H.diagonal().cwiseMax(kDiagFloor);
  double lam = kLambda0;
  int status = 0;
  while (nfev < max_iter) {
    if (!g.allFinite() || g.cwiseAbs().maxCoeff() <= tol * std::max(F, 1e-300)) {
      status = 1;
      break;
    }
    Mat5 A = H;
    A.diagonal() += lam * d;
    const Eigen::PartialPivLU<Mat5> lu(A);
    const Vec5 dx = lu.solve(-g);
    if (!dx.allFinite()) {  // (numerically) singular system: numpy's LinAlgError branch
      lam *= kLambdaUp;
      if (lam > kLambdaMax) {
        status = -1;
        break;
      }
      continue;
    }
    const Vec5 xn = xv + dx;
    const double Fn = pr.eval(xn.data(), true, &Hn, &gn);
    ++nfev;
    if (std::isfinite(Fn) && Fn < F) {
      const double dF = F - Fn;
      xv = xn;
      F = Fn;
      H = Hn;
      g = gn;
      ++njev;
      d = d.cwiseMax(H.diagonal());
      lam = std::max(lam / kLambdaDown, kLambdaMin);
      if (dF <= tol * F) {
        status = 2;
        break;
      }
      if (dx.norm() <= tol * (tol + xv.norm())) {
        status = 3;
        break;
      }
    } else {
      lam *= kLambdaUp;
      if (lam > kLambdaMax) {
        status = -1;
        break;
      }
    }
  }
  for (int k = 0; k < 5; ++k) x[k] = xv(k);
  st->iterations = njev;
  st->evaluations = nfev;
  st->status = status;
  return F;
}

// flip t so that the weighted majority of h_i^T t is positive; the weighted positive fraction after
double fix_translation_sign(const Points& p, const double* w, const Mat3& R, Vec3* t) {
  double m2 = 0.0, sw = 0.0, pos = 0.0;
  std::vector<double> h(p.n);
  for (int i = 0; i < p.n; ++i) {
    const Vec3 c = (R * p.a(i)).cross(p.b(i));
    h[i] = c.dot(p.b(i).cross(*t));
    const double wi = w ? w[i] : 1.0;
    m2 += wi * (h[i] > 0.0 ? 1.0 : (h[i] < 0.0 ? -1.0 : 0.0));
  }
  const double sgn = m2 < 0.0 ? -1.0 : 1.0;
  if (m2 < 0.0) *t = -*t;
  for (int i = 0; i < p.n; ++i) {
    const double wi = w ? w[i] : 1.0;
    sw += wi;
    if (sgn * h[i] > 0.0) pos += wi;
  }
  *t = t->normalized();
  return pos / std::max(sw, 1e-300);
}

RefineStats refine(const Points& p, const double* w, const RefineOptions& opt, int kind, Pose* pose) {
  RefineStats st;
  Pose start = *pose;
  start.t = start.t.normalized();
  const Chart chart(start);
  double scale = 1.0;
  if (opt.loss != RefineLoss::Linear) scale = opt.loss_scale > 0.0 ? opt.loss_scale : default_scale(p, w, kind, chart, opt.weights_outside, opt.residual_weights);
  st.loss_scale = scale;
  std::optional<SoaPoints> soa;
  if (kind == 0) soa.emplace(p);
  const Problem pr{p, w, kind, opt.loss, scale, chart, opt.weights_outside, opt.weights_outside ? opt.residual_weights : nullptr, soa ? &*soa : nullptr};
  const double x0[5] = {0, 0, 0, 0, 0};
  // the start's cost with its normal equations, LM's first evaluation; the cost at the returned x
  // is LM's last accepted one (the same computation: no evaluation repeated)
  Mat5 H0;
  Vec5 g0;
  const double cost0 = pr.eval(x0, true, &H0, &g0);
  st.initial_cost = cost0;
  const double tol = std::max(opt.tol, kRefineMinTol);
  double x[5] = {0, 0, 0, 0, 0};
  double cost1 = cost0;
  if (cost0 == 0.0) {  // an exact start (its normal equations were computed for nothing: rare)
    st.iterations = 0;
    st.evaluations = 1;
    st.status = 1;
  } else {
    cost1 = levenberg_marquardt(pr, std::max(opt.max_iterations, 1), tol, cost0, H0, g0, x, &st);
  }
  Frame F;
  chart.eval(x, false, &F.R, &F.t, &F.Jl, &F.Jt);
  Pose out{F.R, F.t};
  if (!(cost1 <= cost0)) {  // never return a worse pose (guard; LM only accepts decreasing steps)
    out = start;
    cost1 = cost0;
    st.status = -2;
  }
  st.final_cost = cost1;
  st.positive_depth_fraction = fix_translation_sign(p, w, out.R, &out.t);
  *pose = out;
  return st;
}

}  // namespace

RefineStats refine_sampson(const Points& p, const double* w, const RefineOptions& opt, Pose* pose) {
  return refine(p, w, opt, 0, pose);
}

RefineStats refine_ligt(const Points& p, const double* w, const RefineOptions& opt, int normalization, Pose* pose) {
  if (normalization < 0 || normalization > 2) normalization = 0;
  return refine(p, w, opt, 1 + normalization, pose);
}

double refine_normal_equations(const Points& p, const double* w, const Pose& start, const double x[5], bool blocks, double* H, double* g,
                               RefineLoss loss, double loss_scale, bool weights_outside, const double* residual_weights) {
  Pose unit = start;
  unit.t.normalize();
  const Chart chart(unit);
  std::optional<SoaPoints> soa;
  if (blocks) soa.emplace(p);
  const Problem pr{p, w, 0, loss, loss_scale, chart, weights_outside, weights_outside ? residual_weights : nullptr, soa ? &*soa : nullptr};
  Mat5 Hm;
  Vec5 gv;
  const double cost = pr.eval(x, true, &Hm, &gv);
  for (int a = 0; a < 5; ++a) {
    g[a] = gv(a);
    for (int b = 0; b < 5; ++b) H[5 * a + b] = Hm(a, b);
  }
  return cost;
}

void refine_residuals(const Points& p, const double* w, const Pose& start, const double x[5], int kind,
                      std::vector<double>* r, std::vector<double>* J) {
  const Chart chart(start);
  Frame F;
  chart.eval(x, true, &F.R, &F.t, &F.Jl, &F.Jt);
  const Problem pr{p, w, kind, RefineLoss::Linear, 1.0, chart};
  const int m = pr.dim();
  r->assign(static_cast<size_t>(p.n) * m, 0.0);
  J->assign(static_cast<size_t>(p.n) * m * 5, 0.0);
  double ri[3], Ji[3][5];
  for (int i = 0; i < p.n; ++i) {
    pr.point(F, i, true, ri, Ji);
    const double sw = w ? std::sqrt(w[i]) : 1.0;
    for (int c = 0; c < m; ++c) {
      (*r)[static_cast<size_t>(i) * m + c] = sw * ri[c];
      for (int k = 0; k < 5; ++k) (*J)[(static_cast<size_t>(i) * m + c) * 5 + k] = sw * Ji[c][k];
    }
  }
}

namespace {

// the smallest eigenvalue of an information, relative to its largest, that still counts as constrained
constexpr double kCovarianceMinEigenRatio = 1e-12;
constexpr double kRayleighMedian = 1.1774100225154747;  // sqrt(2 ln 2)
constexpr int kScaleBisections = 200;

// Sigma = s2 H^-1 for a symmetric information H (false when it is not positive definite)
template <int D>
bool invert_information(const Eigen::Matrix<double, D, D>& H, double s2, Eigen::Matrix<double, D, D>* C) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, D, D>> es(0.5 * (H + H.transpose()));
  if (es.info() != Eigen::Success) return false;
  const auto& ev = es.eigenvalues();
  if (!(ev(D - 1) > 0.0) || !std::isfinite(ev(D - 1)) || !(ev(0) > kCovarianceMinEigenRatio * ev(D - 1))) return false;
  *C = s2 * es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  return true;
}

// The fraction of |e| below x * sigma: half-normal (chords = false: 2 Phi(x) - 1) or Rayleigh (chords =
// true, the norm of a 2-D Gaussian: 1 - exp(-x^2 / 2)).
double below(double x, bool chords) { return chords ? -std::expm1(-0.5 * x * x) : std::erf(x / std::sqrt(2.0)); }

// The noise scale sigma of errors |e| known only below `threshold` (the matches were selected by it) whose
// median is `med`: the root in a = threshold / sigma of F(q a) = F(a) / 2, q = med / threshold (F: below()).
// q -> 0 is the untruncated estimate; as q approaches the median of a uniform truncation (1/2, or 1/sqrt(2)
// for chords) sigma grows without bound: inf where q reaches it (the threshold does not resolve the noise).
double truncated_scale(double med, double threshold, bool chords) {
  const double q = med / threshold;
  auto g = [&](double a) { return below(q * a, chords) - 0.5 * below(a, chords); };
  double lo = 1e-3, hi = 1e3;  // a = threshold / sigma; g(lo) < 0 < g(hi) when the noise is resolved
  if (!(g(lo) < 0.0)) return std::numeric_limits<double>::infinity();
  if (!(g(hi) > 0.0)) return med / (chords ? kRayleighMedian : 1.0 / kMadFactor);  // no truncation to speak of
  for (int k = 0; k < kScaleBisections && hi - lo > 1e-12 * hi; ++k) {
    const double mid = std::sqrt(lo * hi);
    (g(mid) < 0.0 ? lo : hi) = mid;
  }
  return threshold / (0.5 * (lo + hi));
}

}  // namespace

PoseCovariance pose_covariance(const Points& p, const double* w, const Pose& pose, bool translation, double threshold, double noise_floor) {
  PoseCovariance out;
  const double inf = std::numeric_limits<double>::infinity();
  out.rotation = Mat3::Constant(inf);
  out.translation = translation ? Mat3::Constant(inf) : Mat3::Zero();
  // the weights' scale cancels (H and sigma^2 both scale with it): divided by their largest against underflow
  double wmax = 0.0;
  for (int i = 0; i < p.n; ++i) wmax = std::max(wmax, w ? w[i] : 1.0);
  if (!(wmax > 0.0) || !std::isfinite(wmax)) return out;
  std::vector<double> absr;
  Pose unit = pose;
  if (translation) {
    unit.t /= unit.t.cwiseAbs().maxCoeff();  // (no overflow in the norm)
    unit.t.normalize();
    if (!unit.t.allFinite()) return out;
  } else {
    unit.t = Vec3::UnitZ();  // (the chart needs a direction; only R is used)
  }
  const Chart chart(unit);
  const double x0[5] = {0, 0, 0, 0, 0};
  Frame F;
  chart.eval(x0, true, &F.R, &F.t, &F.Jl, &F.Jt);
  const int params = translation ? 5 : 3;
  Mat5 H5 = Mat5::Zero();
  Mat3 H3 = Mat3::Zero();
  for (int i = 0; i < p.n; ++i) {
    const double wi = (w ? w[i] : 1.0) / wmax;
    if (!(wi > 0.0)) continue;
    if (translation) {
      double r[1], J[1][5];
      sampson_point(F, p.a(i), p.b(i), true, r, J);
      const Eigen::Map<const Vec5> Ji(J[0]);
      H5.noalias() += wi * Ji * Ji.transpose();
      absr.push_back(std::sqrt(wi) * std::abs(r[0]));
    } else {
      // chord residuals u_k^T (R f1 - f2), u_k spanning the tangent plane of f2: sum_k u_k u_k^T = I - f2 f2^T;
      // d(exp([w]x) R f1)/dw = -[R f1]x (left perturbation)
      const Vec3 b = p.b(i).normalized();
      const Vec3 a = unit.R * p.a(i).normalized();
      const Mat3 P = Mat3::Identity() - b * b.transpose();
      const Mat3 A = skew(a);
      H3.noalias() += wi * (A.transpose() * P * A);
      absr.push_back(std::sqrt(wi) * (P * (a - b)).norm());  // a match's two components: Rayleigh
    }
  }
  out.matches = static_cast<int>(absr.size());
  // residual degrees of freedom: one Sampson error per match and 5 parameters, or two chord components and 3
  const int dof = translation ? out.matches - params : 2 * out.matches - params;
  if (out.matches < (translation ? kRefineMinPoints : 3) || dof <= 0) return out;
  const double med = median_of(&absr);
  // the scale of the residuals weighted by w / wmax (the threshold too: sqrt(w_i) |r_i| < threshold)
  double sn = threshold > 0.0 ? truncated_scale(med, threshold / std::sqrt(wmax), !translation)
                               : (translation ? kMadFactor * med : med / kRayleighMedian);
  // the coordinates' own rounding: no match's errors are below it. sn is the scale of the highest-weight
  // match's raw errors (the weights are inverse variances up to a constant), so the floor applies to it as is
  if (noise_floor > 0.0 && std::isfinite(sn)) sn = std::max(sn, translation ? noise_floor : std::sqrt(2.0) * noise_floor);
  out.sigma = sn * std::sqrt(wmax);  // the scale of a unit-weight residual
  if (!std::isfinite(sn)) return out;  // the threshold does not resolve the noise (sigma inf)
  // small-sample correction of the scale (the residuals are those of a fit of `params` parameters)
  const double s2 = sn * sn * (translation ? out.matches : 2.0 * out.matches) / dof;
  if (translation) {
    Mat5 C;
    if (!H5.allFinite() || !invert_information<5>(H5, 1.0, &C)) return out;
    C *= s2;  // (s2 = 0: exact residuals, a zero covariance)
    out.rotation = C.topLeftCorner<3, 3>();
    out.translation = F.Jt * C.bottomRightCorner<2, 2>() * F.Jt.transpose();
  } else {
    Mat3 C;
    if (!H3.allFinite() || !invert_information<3>(H3, 1.0, &C)) return out;
    out.rotation = s2 * C;
  }
  out.ok = true;
  return out;
}

namespace {

// The inliers' Sampson errors and Jacobians at `pose` (the chart of refine_sampson at x = 0).
void sampson_rows(const Points& p, const uint8_t* sel, const Pose& pose, std::vector<int>* idx, std::vector<double>* r, std::vector<Vec5>* J) {
  Pose unit = pose;
  unit.t /= unit.t.cwiseAbs().maxCoeff();
  unit.t.normalize();
  const Chart chart(unit);
  const double x0[5] = {0, 0, 0, 0, 0};
  Frame F;
  chart.eval(x0, true, &F.R, &F.t, &F.Jl, &F.Jt);
  idx->clear();
  r->clear();
  J->clear();
  for (int i = 0; i < p.n; ++i) {
    if (!sel[i]) continue;
    double ri[1], Ji[1][5];
    sampson_point(F, p.a(i), p.b(i), true, ri, Ji);
    idx->push_back(i);
    r->push_back(ri[0]);
    J->push_back(Eigen::Map<const Vec5>(Ji[0]));
  }
}

constexpr int kLeveragePeelRounds = 5;  // leverage_veto's rounds of peeling

// H^-1 of the information of the rows J (false where it is not positive definite)
bool inverse_information(const std::vector<Vec5>& J, Mat5* Hi) {
  Mat5 H = Mat5::Zero();
  for (const Vec5& j : J) H.noalias() += j * j.transpose();
  return H.allFinite() && invert_information<5>(H, 1.0, Hi);
}

}  // namespace

LeverageVeto leverage_veto(const Points& p, const uint8_t* inl, const Pose& pose, double decision, double max_leverage) {
  LeverageVeto out;
  out.leverage.assign(p.n, 0.0);
  out.veto.assign(p.n, 0);
  if (!pose.R.allFinite() || !pose.t.allFinite() || !(pose.t.cwiseAbs().maxCoeff() > 0.0)) return out;
  std::vector<int> idx;
  std::vector<double> r;
  std::vector<Vec5> J;
  std::vector<uint8_t>& group = out.group;
  group.assign(p.n, 0);
  std::vector<uint8_t> bulk(inl, inl + p.n);
  int peeled = 0;
  Pose fit = pose;
  Mat5 Hi;
  // peel: the matches of high leverage leave the fit, the others' fit is made again, and a match that
  // now dominates it joins them (two wrong matches of leverage ~1 can mask a third of 0.07 that holds
  // the same wrong direction once they are gone)
  for (int round = 0; round < kLeveragePeelRounds; ++round) {
    sampson_rows(p, bulk.data(), fit, &idx, &r, &J);
    if (static_cast<int>(idx.size()) <= kRefineMinPoints || !inverse_information(J, &Hi)) return out;
    int added = 0;
    for (size_t k = 0; k < idx.size(); ++k) {
      const double h = J[k].dot(Hi * J[k]);
      if (round == 0) out.leverage[idx[k]] = h;
      if (h > max_leverage) {
        group[idx[k]] = 1;
        bulk[idx[k]] = 0;
        ++added;
      }
    }
    peeled += added;
    if (added == 0) break;
    PointBuffer rest;
    for (int i = 0; i < p.n; ++i)
      if (bulk[i]) rest.push(p.f1 + 3 * i, p.f2 + 3 * i);
    if (rest.view().n < kRefineMinPoints) return out;
    fit = pose;
    RefineOptions ro;
    ro.max_iterations = 50;
    refine_sampson(rest.view(), nullptr, ro, &fit);
    if (!fit.R.allFinite() || !fit.t.allFinite()) return out;
  }
  if (peeled == 0) return out;
  sampson_rows(p, bulk.data(), fit, &idx, &r, &J);
  if (static_cast<int>(idx.size()) < kRefineMinPoints || !inverse_information(J, &Hi)) return out;
  sampson_rows(p, group.data(), fit, &idx, &r, &J);
  out.tested = true;
  out.others = fit;
  for (size_t k = 0; k < idx.size(); ++k) out.veto[idx[k]] = std::abs(r[k]) > decision * std::sqrt(1.0 + J[k].dot(Hi * J[k]));
  return out;
}

}  // namespace poseonly
