// Five-point solver on unit bearings: Nister's polynomial with a Stewenius fallback (Stewenius,
// Engels, Nister, ISPRS J. 2006; the reference poseonly.solvers.fivept is OpenGV's fivept_stewenius):
//   1. null space X, Y, Z, W of the 5 x 9 epipolar rows kron(f1_i, f2_i) (Householder QR of A^T);
//   2. E = x X + y Y + z Z + W; the nine Demazure cubics 2 E E^T E - tr(E E^T) E = 0 and det E = 0
//      as a 10 x 20 template over the cubic monomials (order of poseonly.solvers.fivept.MONOMIALS),
//      built by polynomial arithmetic;
//   3. (Nister, PAMI 2004) Gauss-Jordan elimination of the template in Nister's column order; the
//      rows of x^2 z, x^2, y^2 z, y^2, x y z, x y give B(z) (x, y, 1)^T = 0 with B cubic / quartic in
//      z; the real roots of the degree-10 det B(z) by a Sturm sequence (sturm.h), (x, y) from B(z)'s
//      null vector. PoseLib's construction; ~1.6x faster per sample than step 4 (measured on a
//      C++ driver: 6.7 against 10.7 us for fivept_poses on noisy samples);
//   4. where step 3 is unreliable (a Gauss-Jordan pivot below 1e-2 of the largest: low parallax,
//      ~6 % of ordinary samples, 13 % of random samples of real pairs, benchmarks/fivept_paths.py;
//      or a near-multiple root in the Sturm chain) the Stewenius path:
//      G = A1^{-1} A2, the 10 x 10 action matrix of multiplication by x; its eigenvalues by
//      Parlett-Reinsch balancing, Hessenberg form and Francis double-shift QR (EISPACK hqr; Eigen's
//      EigenSolver on the fixed 10 x 10 cost ~5x more); each real eigenvalue's eigenvector by two
//      steps of inverse iteration on the 6 x 6 system left by the four unit rows of the action matrix;
//   5. (fivept_essentials) (x, y, z) = v[6:9] / v9 polished by two Gauss-Newton steps on the ten template equations
//      (kept only if they lower the residual); E = x X + y Y + z Z + W (v6 X + v7 Y + v8 Z + v9 W when
//      v9 ~ 0), unit Frobenius norm, largest entry positive.
// Only the real solutions are returned (|Im lambda| <= kFiveptRealTol (1 + |lambda|), as numpy's
// is_real).
#pragma once

#include <vector>

#include "common.h"

namespace poseonly {

constexpr double kFiveptRealTol = 1e-8;

// The constructions of the solver (fivept_essentials_path: tests and benchmarks/fivept_paths.py): kAuto
// is fivept_essentials' choice (Nister's elimination, else the action matrix); kNister and kAction take
// one construction only. It returns the construction that produced E: kNone where the sample is
// rank-deficient or the construction asked for fails its test (E then empty).
enum class FiveptPath { kNone = -2, kAuto = -1, kNister = 0, kAction = 1 };

// The real essential matrices of a minimal sample (p.n must be 5; returns 0 otherwise or when a step
// breaks down, e.g. coincident points). E is cleared first; returns E->size() (<= 10).
int fivept_essentials(const Points& p, std::vector<Mat3>* E);
FiveptPath fivept_essentials_path(const Points& p, FiveptPath path, std::vector<Mat3>* E);

// Every real solution decomposed into the pose (unit t) under which all five points have positive
// pose-only depths h^T t > 0 and h'^T t > 0 (depth_numerators); solutions without such a
// decomposition are dropped; each pose is then polished by (at most four) Newton steps on the five epipolar
// equations f2_i^T [t]x R f1_i = 0 (kept only if they lower the largest residual and keep the
// chirality; this removes the null space's error amplification at small parallax). out is cleared first.
void fivept_poses(const Points& p, std::vector<Pose>* out);

// The chiral decomposition of one essential matrix (any scale) on the points p (any n >= 1):
// false when none of the four (R, t) puts every point in front of both cameras.
bool decompose_chiral(const Mat3& E, const Points& p, Pose* pose);

}  // namespace poseonly
