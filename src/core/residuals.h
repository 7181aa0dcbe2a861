// Per-correspondence residuals of Section 4 of the paper (and Sampson's), for one pose and one pair
// of unit bearings. Every residual normalises nothing: callers pass unit bearings and a unit t.
// The numpy references live in tests/reference/residuals.py; tests compare to 1e-12.
#pragma once

#include <vector>

#include "common.h"

namespace poseonly {

enum class Residual : int { Sampson = 0, SampsonChiral = 1, LiGT = 2, Coplanar = 3, PPO = 4, BA = 5, OpenGV = 6, OpenGVSymmetric = 7 };
constexpr int kNumResiduals = 8;

// Residual of a point reconstructed behind camera 2 (BA): a gross error.
constexpr double kBehindPenalty = 2.0;
// Rays closer to parallel than this (1 - (R f1 . f2)^2) get zero midpoint depths.
constexpr double kParallelRays = 1e-14;

// Gross error assigned to a point whose pose-only depths are not positive (SampsonChiral).
constexpr double kChiralPenalty = 1.0;

// A pose with the quantities every residual needs, computed once per hypothesis.
struct PoseTerms {
  Mat3 R;
  Vec3 t;
  Mat3 E;
  explicit PoseTerms(const Pose& p) : R(p.R), t(p.t), E(skew(p.t) * p.R) {}
};

// Sampson distance on the unit sphere: |f2^T E f1| / sqrt(|P_f2 E f1|^2 + |P_f1 E^T f2|^2),
// P_f = I - f f^T (tangent projections); radians, the quantity PoseLib and COLMAP threshold.
// Written out in scalars (left to right) so that sampson_block below, the scorers' vectorised loop,
// gives bit-identical values whatever Eigen's expression evaluation chooses.
inline double sampson_terms(const Mat3& E, double x1, double y1, double z1, double x2, double y2, double z2) {
  const double a0 = E(0, 0) * x1 + E(0, 1) * y1 + E(0, 2) * z1;
  const double a1 = E(1, 0) * x1 + E(1, 1) * y1 + E(1, 2) * z1;
  const double a2 = E(2, 0) * x1 + E(2, 1) * y1 + E(2, 2) * z1;
  const double b0 = E(0, 0) * x2 + E(1, 0) * y2 + E(2, 0) * z2;
  const double b1 = E(0, 1) * x2 + E(1, 1) * y2 + E(2, 1) * z2;
  const double b2 = E(0, 2) * x2 + E(1, 2) * y2 + E(2, 2) * z2;
  const double num = x2 * a0 + y2 * a1 + z2 * a2;
  const double den = (a0 * a0 + a1 * a1 + a2 * a2) + (b0 * b0 + b1 * b1 + b2 * b2) - 2.0 * num * num;
  return std::abs(num) / std::sqrt(den < kTiny ? kTiny : den);  // std::max(den, kTiny)
}

inline double sampson(const Mat3& E, const Vec3& f1, const Vec3& f2) {
  return sampson_terms(E, f1(0), f1(1), f1(2), f2(0), f2(1), f2(2));
}

// Bearings as six coordinate arrays (structure of arrays) for loops the compiler vectorises.
struct SoaPoints {
  std::vector<double> x1, y1, z1, x2, y2, z2;
  explicit SoaPoints(const Points& P) : x1(P.n), y1(P.n), z1(P.n), x2(P.n), y2(P.n), z2(P.n) {
    for (int i = 0; i < P.n; ++i) {
      x1[i] = P.f1[3 * i], y1[i] = P.f1[3 * i + 1], z1[i] = P.f1[3 * i + 2];
      x2[i] = P.f2[3 * i], y2[i] = P.f2[3 * i + 1], z2[i] = P.f2[3 * i + 2];
    }
  }
};

// sampson(E, f1_i, f2_i) for i in [i0, i0 + m): the same operations in the same order per point
// (bit-identical results), without a branch, so that the loop runs on SIMD lanes.
// (residuals.cpp: an AVX2 clone is chosen at load time where the CPU has it; no FMA, so every
// clone rounds as the scalar sampson() does)
void sampson_block(const Mat3& E, const SoaPoints& S, int i0, int m, double* out);

// Squared chord |R f1 - f2|^2 of the rotation-only model, in scalars (the block below rounds the same).
inline double chord2_terms(const Mat3& R, double x1, double y1, double z1, double x2, double y2, double z2) {
  const double d0 = R(0, 0) * x1 + R(0, 1) * y1 + R(0, 2) * z1 - x2;
  const double d1 = R(1, 0) * x1 + R(1, 1) * y1 + R(1, 2) * z1 - y2;
  const double d2 = R(2, 0) * x1 + R(2, 1) * y1 + R(2, 2) * z1 - z2;
  return d0 * d0 + d1 * d1 + d2 * d2;
}

void chord2_block(const Mat3& R, const SoaPoints& S, int i0, int m, double* out);

// out[k] = kChiralPenalty for the points of [i0, i0 + m) that (R, t) puts behind either camera (the
// signs of depth_numerators, computed with the same operations), out[k] kept otherwise
void chiral_block(const Mat3& R, const Vec3& t, const SoaPoints& S, int i0, int m, double* out);

// Pose-only depth numerators h^T t = (R f1 x f2).(f2 x t) and h'^T t = (R f1 x f2).(R f1 x t)
// (the equation after Eq. 7): both positive iff the point is in front of both cameras.
inline void depth_numerators(const Mat3& R, const Vec3& t, const Vec3& f1, const Vec3& f2, double* h, double* hp) {
  const Vec3 a = R * f1;
  const Vec3 c = a.cross(f2);
  *h = c.dot(f2.cross(t));
  *hp = c.dot(a.cross(t));
}

inline double sampson_chiral(const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  double h, hp;
  depth_numerators(p.R, p.t, f1, f2, &h, &hp);
  return (h > 0.0 && hp > 0.0) ? sampson(p.E, f1, f2) : kChiralPenalty;
}

// LiGT residual ||L_i t|| (Eq. 8) = |c| |c . t| with c = f2 x R f1 (Lagrange identity).
inline double ligt(const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  const Vec3 c = f2.cross(p.R * f1);
  return c.norm() * std::abs(c.dot(p.t));
}

// Coplanar residual |f2^T [t]x R f1| (Eq. 4).
inline double coplanar(const PoseTerms& p, const Vec3& f1, const Vec3& f2) { return std::abs(f2.dot(p.E * f1)); }

// Pairwise pose-only residual ||normalize(eps) - f2||, eps = |t x f2| R f1 + |f2 x R f1| t (Eq. 7);
// 1 where eps = 0.
inline double ppo(const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  const Vec3 a = p.R * f1;
  const Vec3 eps = p.t.cross(f2).norm() * a + f2.cross(a).norm() * p.t;
  const double ne = eps.norm();
  if (!(ne > 0.0)) return 1.0;
  return (eps / ne - f2).norm();
}

// Midpoint triangulation: depths z1, z2 minimising |z1 R f1 + t - z2 f2| and the midpoint P2 in
// camera 2's frame (geometry.triangulate_midpoint); parallel rays get zero depths.
inline Vec3 midpoint2(const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  const Vec3 a = p.R * f1;
  const double ab = a.dot(f2), at = a.dot(p.t), bt = f2.dot(p.t);
  const double den = 1.0 - ab * ab;
  const bool ok = den > kParallelRays;
  const double z1 = ok ? (ab * bt - at) / den : 0.0;
  const double z2 = ok ? (bt - ab * at) / den : 0.0;
  return 0.5 * (z1 * a + p.t + z2 * f2);
}

// Reprojection residual after midpoint triangulation (v^BA, Section 4), on the tangent plane at f2:
// |eps / (f2 . eps) - f2| with eps = R X1 + t; kBehindPenalty where f2 . eps <= 0.
inline double ba(const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  const Vec3 eps = midpoint2(p, f1, f2);  // R X1 + t with X1 = R^T (P2 - t)
  const double d = eps.dot(f2);
  if (!(d > 1e-12)) return kBehindPenalty;
  return (eps / d - f2).norm();
}

// OpenGV residual 1 - normalize(eps) . f2 with eps = R X1 + t of the midpoint; `symmetric` adds
// view 1's term (OpenGV's SAC score).
inline double opengv(const PoseTerms& p, const Vec3& f1, const Vec3& f2, bool symmetric) {
  const Vec3 P2 = midpoint2(p, f1, f2);
  const double n2 = P2.norm();
  double r = 1.0 - (n2 > 0.0 ? P2.dot(f2) / n2 : 0.0);
  if (symmetric) {
    const Vec3 X1 = p.R.transpose() * (P2 - p.t);
    const double n1 = X1.norm();
    r += 1.0 - (n1 > 0.0 ? X1.dot(f1) / n1 : 0.0);
  }
  return r;
}

inline double residual(Residual kind, const PoseTerms& p, const Vec3& f1, const Vec3& f2) {
  switch (kind) {
    case Residual::Sampson: return sampson(p.E, f1, f2);
    case Residual::SampsonChiral: return sampson_chiral(p, f1, f2);
    case Residual::LiGT: return ligt(p, f1, f2);
    case Residual::Coplanar: return coplanar(p, f1, f2);
    case Residual::PPO: return ppo(p, f1, f2);
    case Residual::BA: return ba(p, f1, f2);
    case Residual::OpenGV: return opengv(p, f1, f2, false);
    case Residual::OpenGVSymmetric: return opengv(p, f1, f2, true);
  }
  return kInf;
}

}  // namespace poseonly
