// Maximum-likelihood refinement of a relative pose under a mixture of inlier and outlier Sampson
// errors (MLESAC's model, Torr and Zisserman 2000), by EM. Outliers are uniform on [0, T); points
// beyond T are outliers. Inliers have Sampson errors |r| of a Student-t of scale s and nu degrees of
// freedom (Lange, Little and Taylor 1989), nu chosen by the profile likelihood on a grid that
// includes nu = inf, the half-normal of MLESAC (`student = false`: the half-normal only).
// Known noise scales (`scales`): a match's inlier density is that of q_i r_i, q_i = c_i^-alpha for
// its relative noise scale c_i, alpha chosen with nu by the profile likelihood on {0, 1/2, 1} (0: the
// scales explain nothing and the stage is the one without them).
// Why the t: real match errors are heavy-tailed (a keypoint's localisation error depends on its
// scale, so the inliers are a scale mixture of Gaussians): on the SIFT matches of the five real
// datasets the chosen nu is 1.5-3, and on Gaussian errors it is inf, where the stage is MLESAC's.
// Each round
//   E: s and g to convergence at fixed nu (EM on the current errors), then the posteriors
//      p_i = g f(r_i) / (g f(r_i) + (1 - g) / T) (r_i < T, else 0);
//   M: the pose maximising sum_i p_i log f(r_i): weighted Sampson least squares (Gaussian) or the
//      Cauchy loss of scale sqrt(nu) s with weights p_i (the t's log-density is that loss).
// With every match an inlier and Gaussian errors this is least squares on the Sampson error (the ML
// pose to first order); the scale is estimated, not set, so a threshold cannot be inflated by
// structured outliers beyond T, and the inlier decision p_i >= 1/2 follows the measured noise.
#pragma once

#include <cstdint>
#include <vector>

#include <cmath>

#include "common.h"

namespace poseonly {

struct MlOptions {
  double range = 3e-3;       // T (radians): the outlier range; the caller's maximal threshold
  int rounds = 6;            // EM rounds at most
  int lm_iterations = 10;    // LM cost evaluations per round
  double pose_tol = 0.0;     // stop when a round moves R (angle) and t by at most this (0: all rounds)
  double sigma_floor = 1e-7; // radians (~1e-4 px at f = 1000)
  bool student = true;       // Student-t inliers, nu chosen by the data (inf included); false: Gaussian (MLESAC)
  // EM starts from the least-squares Sampson refit of the matches within min(T, 3 s0) of the given
  // pose, s0 = 1.4826 median of its errors below T / 2 (a wide uniform kernel first, as deterministic
  // annealing starts EM; ml_refine.cpp, kBand*); unchanged start with fewer than 6 such matches
  bool band_start = false;
  // the inlier model given instead of chosen (no profile-likelihood search): nu (inf: Gaussian) and
  // alpha (0 without scales), e.g. those the stage chose on all matches, for EM on a subset of them
  // (the cross-fit's folds: the tails are the pair's noise, not a fold's; and the search is most of
  // the stage's cost)
  bool fixed_tails = false;
  double nu = INFINITY;
  double alpha = 0.0;
  // only the pose (and rounds) are wanted: the statistics at the returned pose (the final E-step,
  // log-likelihood, decision residuals, the Gaussian refit) are not computed (NaN in the result);
  // sigma, nu, alpha, inlier_fraction and the posteriors are the last E-step's (the cross-fit's
  // folds); the pose is the same
  bool pose_only = false;
  // EM's first E-step starts from this scale and inlier share (both > 0, g_init < 1; else from the
  // MAD start below): on the tested scenes the same fixed point to ~1e-8, reached in fewer steps from
  // a nearby start (the cross-fit's folds start from the ML stage's fit on all matches). Used with
  // fixed_tails: a tails choice (student or scales without fixed tails) restarts EM from the MAD start
  double sigma_init = 0.0;
  double g_init = 0.0;
};

struct MlResult {
  Pose pose;
  double sigma = 0.0;           // inlier noise scale s (radians): the t's scale, or the Gaussian's sigma
  double nu = NAN;              // the t's degrees of freedom (inf: Gaussian; NaN: EM did not run)
  double alpha = 0.0;           // the noise scales' exponent: a match's inlier scale is sigma c_i^alpha
  double sigma_gauss = 0.0;     // the Gaussian mixture's sigma at the returned pose (= sigma for the Gaussian)
  double sigma_start = 0.0;     // EM's start: 1.4826 median of the errors below T / 2 at the start pose
  double inlier_fraction = 0.0; // g
  double decision = 0.0;        // residual where p = 1/2 (radians; for a match of the median scale)
  double decision_gauss = 0.0;  // the same for the Gaussian mixture fitted at the returned pose (the
                                // t's decision itself lies far out in its heavy tail)
  double log_likelihood = 0.0;  // of all matches under the fitted mixture (errors clamped at T)
  std::vector<double> posterior;
  int rounds = 0;
};

// scales (optional, (n,)): each match's relative noise scale (e.g. sqrt(size1 size2) of its SIFT
// keypoints; only ratios matter, c_i = scale_i / median of the finite positive ones; other entries
// count as the median, ratios are clamped to [1/32, 32]). Open: as for the t, the inlier density is
// not renormalised on [0, T), which biases the choice towards alpha = 0 when a large-scale match's
// inlier scale is a sizeable part of T.
void ml_refine(const Points& P, const Pose& start, const MlOptions& opt, MlResult* out, const double* scales = nullptr);

// The default's cross-fitted inliers (poseonly.robust.default._cross_fit; the numpy-era reference is
// tests/reference/cross_fit.py). Match i belongs to fold i % folds. Each fold's matches are classified
// by the ML pose of the other folds (`fold` options, EM from `pose`): an inlier where its Sampson error
// is below `decision`; the pose's own inliers the other folds reject are vetoed, and the result is EM
// from `pose` on every other match (`final` options). False (no result) when a fold's EM fails or fewer
// than `min_agree` matches are inliers of both; no veto: *out = pose, *vetoed = 0.
struct CrossFitOptions {
  int folds = 5;
  double decision = 0.0;  // radians
  int min_agree = 15;
  MlOptions fold;
  MlOptions final;
};

// veto (optional): the vetoed matches, (n,) 0 / 1.
bool ml_cross_fit(const Points& P, const Pose& pose, const CrossFitOptions& opt, const double* scales, Pose* out, int* vetoed,
                  std::vector<uint8_t>* veto_out = nullptr);

}  // namespace poseonly
