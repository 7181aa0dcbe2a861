// Maximum-likelihood refinement of a relative pose under a Gaussian-uniform mixture of Sampson
// errors (MLESAC's model, Torr and Zisserman 2000), by EM: inliers have half-normal Sampson errors
// of scale sigma, outliers are uniform on [0, T); points beyond T are outliers. Each round
//   E: posterior p_i = g N+(r_i; sigma) / (g N+(r_i; sigma) + (1 - g) / T)   (r_i < T, else 0),
//   M: sigma^2 = sum p r^2 / sum p,  g = sum p / #(r < T),  the pose by weighted Sampson LM (weights p).
// With every match an inlier this is least squares on the Sampson error (the ML pose to first order);
// sigma is estimated, not set, so a threshold cannot be inflated by structured outliers beyond T and
// the inlier decision p_i >= 1/2 follows the measured noise.
#pragma once

#include "common.h"

namespace poseonly {

struct MlOptions {
  double range = 3e-3;       // T (radians): the outlier range; the caller's maximal threshold
  int rounds = 6;            // EM rounds at most
  int lm_iterations = 10;    // LM cost evaluations per round
  double pose_tol = 0.0;     // stop when a round moves R (angle) and t by at most this (0: all rounds)
  double sigma_floor = 1e-7; // radians (~1e-4 px at f = 1000)
};

struct MlResult {
  Pose pose;
  double sigma = 0.0;           // inlier noise scale (radians)
  double sigma_start = 0.0;     // EM's start: 1.4826 median of the errors below T / 2 at the start pose
  double inlier_fraction = 0.0; // g
  double decision = 0.0;        // residual where p = 1/2 (radians)
  double log_likelihood = 0.0;  // of all matches under the fitted mixture (errors clamped at T)
  std::vector<double> posterior;
  int rounds = 0;
};

void ml_refine(const Points& P, const Pose& start, const MlOptions& opt, MlResult* out);

}  // namespace poseonly
