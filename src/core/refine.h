// Levenberg-Marquardt refinements of a relative pose on SO(3) x S^2 (5 parameters), the compact LM of
// poseonly.refine.ligt._lm (solver="lm"), in the same chart and with the same rules:
//   chart   R(x) = exp([w]x) R0, t(x) = normalize(t0 + B v), x = (w, v), B an orthonormal basis of
//           the tangent plane at t0 (poseonly.refine._manifold.PoseChart; exact Jacobians at any x:
//           d(R p)/dw = -[R p]x J_l(w), dt/dv = (I - t t^T) B / |t0 + B v|);
//   robust  cost s^2 sum_i rho(|r_i|^2 / s^2) (scipy's loss semantics applied to each point's squared
//           residual norm), normal equations in IRLS form H = sum rho'_i J_i^T J_i, g = sum rho'_i J_i^T r_i
//           (no rho'' term);
//   LM      (H + lam diag(d)) dx = -g, d the largest diagonal of H seen (Marquardt / MINPACK scaling),
//           lam0 = 1e-3, a step is taken only if the cost decreases (lam / 3, floor 1e-15), else lam * 10;
//   stops   (status codes of scipy.optimize.least_squares) 1 gtol: max|g| <= tol F (or g not finite)
//           or an exact start (zero cost); 2 ftol: accepted dF <= tol F; 3 xtol: |dx| <= tol (tol + |x|);
//           0: max_iterations cost evaluations; -1: lam > 1e16 without a decreasing step.
// After the optimisation the sign of t is fixed by the weighted majority of positive pose-only depths
// h_i^T t (poseonly.refine._common.fix_translation_sign); the objective is invariant to t -> -t.
#pragma once

#include "common.h"

#include <cstdint>
#include <vector>

namespace poseonly {

// scipy.optimize.least_squares losses rho(s) (poseonly.refine._common.LOSSES), codes 0-4 as
// poseonly.refine.ligt._LOSS_CODE (5 and 6 have no scipy twin). A separate enum from common.h's Loss (PoseLib's family: truncated
// losses, no soft_l1/arctan). Two truncated quadratics for the search's LO, which minimise its scores
// (ransac.h): Truncated rho(s) = min(s, 1) (MSAC at the scale, PoseLib's LO loss) and TruncatedMulti
// rho(s) = min(s, 1) + 4 min(s, 1/4) + 16 min(s, 1/16) (MultiMsacScorer's sum at s, s/2, s/4); their
// rho' is a step function (0 beyond the scale: the LM's normal equations are IRLS over the points
// within it) and the LM takes a step only where the cost decreases.
enum class RefineLoss : int { Linear = 0, SoftL1 = 1, Huber = 2, Cauchy = 3, Arctan = 4, Truncated = 5, TruncatedMulti = 6 };

constexpr int kRefineMinPoints = 6;          // ligt_refine's minimum (5 parameters + 1)
constexpr double kRefineMinTol = 2.3e-16;    // tol floor (as ligt_refine)
constexpr double kMadFactor = 1.4826;        // default scale: 1.4826 median_i |sqrt(w_i) r_i|
constexpr double kMinLossScale = 1e-12;

struct RefineOptions {
  int max_iterations = 50;           // cap on cost evaluations (scipy max_nfev)
  RefineLoss loss = RefineLoss::Linear;
  double loss_scale = 0.0;           // s; <= 0: the default 1.4826 median_{w_i > 0} |sqrt(w_i) r_i| at the start (>= 1e-12)
  double tol = 1e-12;                // ftol = xtol = gtol
  bool weights_outside = false;      // cost s^2 sum_i w_i rho(r_i^2 / s^2) (w_i a point's probability
                                     // of being an inlier) instead of scaling the residuals by sqrt(w_i)
  const double* residual_weights = nullptr;  // with weights_outside: (n,) v_i > 0 scaling the residuals
                                     // by sqrt(v_i) inside the loss, s^2 sum_i w_i rho(v_i r_i^2 / s^2)
                                     // (v_i the inverse variance of a match of known noise scale)
};

struct RefineStats {
  int iterations = 0;                // Jacobian evaluations = accepted steps + 1 (0 for an exact start)
  int evaluations = 0;               // cost evaluations
  int status = 0;                    // see the header comment; -2: final cost above the start, start returned
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double loss_scale = 1.0;           // the scale used (1 for the linear loss)
  double positive_depth_fraction = 0.0;  // weighted fraction of h_i^T t > 0 at the returned pose
};

// Sampson refinement: r_i = sqrt(w_i) (f2^T E f1) / sqrt(|P_f2 E f1|^2 + |P_f1 E^T f2|^2) (residuals.h
// sampson, radians), minimising s^2 sum_i rho(r_i^2 / s^2). pose: start in, result out (unit t).
RefineStats refine_sampson(const Points& p, const double* w, const RefineOptions& opt, Pose* pose);

// LiGTopt (poseonly.refine.ligt): r_i = sqrt(w_i) L~_i t / N_i with normalization 0 "none" (N = 1),
// 1 "theta2" (N = theta_i^2, floored at 1e-30), 2 "angular" (N = theta_i^2 |z_i R f1_i + t|).
RefineStats refine_ligt(const Points& p, const double* w, const RefineOptions& opt, int normalization, Pose* pose);

// The Sampson LM's cost s^2 sum rho and IRLS normal equations at chart point x around `start` (the
// loss of scale s, the weights as RefineOptions: scaling the residuals by sqrt(w_i), or outside the
// loss with the residual weights inside): H (25, row-major), g (5), in point order; `blocks` through
// the SIMD blocks over coordinate arrays (the LM's path) or point by point. Exposed for tests (the two
// paths are bit-identical).
double refine_normal_equations(const Points& p, const double* w, const Pose& start, const double x[5], bool blocks, double* H, double* g,
                               RefineLoss loss = RefineLoss::Linear, double loss_scale = 1.0, bool weights_outside = false,
                               const double* residual_weights = nullptr);

// Residual (1 for Sampson, 3 for LiGT) and its Jacobian w.r.t. the chart at x, exposed for tests:
// r (n * dim), J (n * dim * 5, row-major per residual component). kind 0 Sampson, 1 + norm LiGT.
void refine_residuals(const Points& p, const double* w, const Pose& start, const double x[5], int kind,
                      std::vector<double>* r, std::vector<double>* J);

// First-order covariance of a relative pose fitted by least squares on the Sampson errors (Hartley and
// Zisserman, section 5.2.3: Sigma = sigma^2 (J^T J)^-1, J the errors' Jacobian in the pose's five
// parameters) of the matches with w_i > 0, each scaled by sqrt(w_i) (w_i an inverse variance up to a
// constant, or a 0 / 1 inlier mask). Parameters: the chart of refine_sampson at the pose, so the rotation
// block is in the left perturbation R = exp([w]x) R0 (radians^2) and the translation block is mapped to
// R^3 through the tangent basis B (t = t0 + B v: a rank-2 3x3, tangent to unit t). Rotation-only
// (translation = false; a pose without translation, X2 ~ R X1): the chord R f1 - f2 in the tangent plane
// of f2 (two residuals per match), the covariance of w only (translation left zero).
// sigma: from the median m of |sqrt(w_i) r_i| (robust to the few wrong matches an inlier set keeps):
// 1.4826 m (chords: m / sqrt(2 ln 2), a Rayleigh's median); with threshold > 0 the matches were selected
// by sqrt(w_i) |r_i| < threshold (chords: |R f1 - f2|; w a 0 / 1 mask: |r_i| < threshold), so their
// errors are a truncated sample and
// sigma solves the truncated distribution's median (inf where m / threshold reaches the median of a
// uniform truncation: the threshold does not resolve the noise); then scaled by sqrt(k / (k - p)), k
// the residuals and p the parameters (a least-squares fit's residuals are smaller than its noise).
// ok = false (covariances inf) with fewer than 6 weighted matches (3 without translation), an unresolved
// or non-finite scale or a singular information (a parameter the matches do not constrain); a zero scale
// (exact residuals) gives a zero covariance.
struct PoseCovariance {
  Mat3 rotation = Mat3::Zero();
  Mat3 translation = Mat3::Zero();
  double sigma = 0.0;
  int matches = 0;
  bool ok = false;
};
// noise_floor: the least noise scale of one view's bearings (radians; e.g. the rounding of integer pixel
// coordinates): the highest-weight match's error scale (sigma / sqrt(max w)) >= noise_floor for the
// Sampson errors, sqrt(2) noise_floor for the chords (two views)
PoseCovariance pose_covariance(const Points& p, const double* w, const Pose& pose, bool translation = true, double threshold = 0.0,
                               double noise_floor = 0.0);

// The inliers a pose cannot vouch for (poseonly.robust.default, the leverage test). The leverage of
// inlier i (inl[i] != 0) in the least-squares Sampson fit of the inliers at `pose` is h_i = J_i H^-1
// J_i^T (H = sum J_j^T J_j over the inliers, J the errors' Jacobian in the five pose parameters): the
// share of its own residual the fit absorbs. Where h_i > max_leverage, the match's residual says little
// about whether it belongs (two wrong matches far off the others' parallax can hold a weakly constrained
// translation direction and fit it exactly: a SLAM user's trial, 5 deg off with leverages 0.96 and 0.98).
// Those matches (the group) leave the fit: the least-squares fit of the other inliers (refine_sampson,
// linear loss, from `pose`) is made again, and a match whose leverage in it exceeds max_leverage joins
// the group (at most 5 rounds: two matches of leverage ~1 can mask a third that holds the same wrong
// direction once they are gone). The group is then tested against the last fit of the others, as a
// prediction: vetoed where |r_i| > decision * sqrt(1 + J_i
// H_B^-1 J_i^T) at that fit (H_B its information; the Gaussian prediction interval of a match the fit did
// not see, at the level `decision` sets for the fitted matches). tested = false where the group is empty,
// the other inliers are fewer than kRefineMinPoints or an information is singular (nothing vetoed).
struct LeverageVeto {
  std::vector<double> leverage;  // (n,), 0 for a non-inlier
  std::vector<uint8_t> veto;     // (n,)
  std::vector<uint8_t> group;    // (n,): the inliers peeled off (leverage above max_leverage in a fit); may be
                                 // non-empty where tested is false (the peeling stopped early): then unused
  bool tested = false;
  Pose others;                   // the last least-squares fit of the other inliers (where tested)
};
LeverageVeto leverage_veto(const Points& p, const uint8_t* inl, const Pose& pose, double decision, double max_leverage);

}  // namespace poseonly
