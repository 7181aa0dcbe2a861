// Analysis of a final pose for the status decision (poseonly.analysis): chance inlier counts on
// re-paired matches and the planar homography twin. numpy references: tests/reference/twin.py and
// the formulas in poseonly/analysis.py's docstrings.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common.h"

namespace poseonly {

// Matches of `P` re-paired by `perm` (reps x n indices into view 2) that are Sampson inliers
// (< tau) of the pose (unit t): the numerator of the chance rate.
int64_t chance_count_sampson(const Pose& pose, const Points& P, const int64_t* perm, int reps, double tau);

// Re-paired matches with |R f1 - f2|^2 < chord2 (the rotation-only model's chance count).
int64_t chance_count_rotation(const Mat3& R, const Points& P, const int64_t* perm, int reps, double chord2);

// The four (R, t / d, n) of a calibrated homography H ~ R + t n^T / d (Ma, Soatto, Kosecka, Sastry,
// "An Invitation to 3-D Vision", Sec. 5.3.3; SVD method of Faugeras & Lustman 1988); H is scaled so
// that its middle singular value is 1. Order: (u+, +), (u+, -), (u-, +), (u-, -).
struct HomographyDecomposition {
  std::array<Mat3, 4> R;
  std::array<Vec3, 4> T;  // t / d
  std::array<Vec3, 4> N;  // unit plane normals
};
bool decompose_homography(const Mat3& H, HomographyDecomposition* out);

// The other physically valid decomposition of the homography of the dominant plane through the
// midpoint-triangulated inliers `P` of `pose` (unit t): R_twin, unit t_twin and the planarity
// s3 / s2 of the centred points. False when fewer than 4 points triangulate in front of both
// cameras, the plane or the decomposition is degenerate, or fewer than two decompositions are valid.
bool homography_twin(const Pose& pose, const Points& P, Pose* twin, double* planarity);

// The same from the homography fitted to the matches `P` directly (DLT on the bearings, signed so that H
// f1 points along f2 for most of them), when it carries at least 90 % of them to within max_transfer
// radians (the angle between H f1 and f2; the matches are planar in the images): analyse_twin's fallback
// (at 2 tau) where the triangulated plane's twin fails.
bool homography_twin_dlt(const Pose& pose, const Points& P, double max_transfer, Pose* twin);

// Cheirality-consistent support: matches with sampson_chiral < thr (pose with unit t).
int support_count(const Pose& pose, const Points& P, double thr);

// Two poses' cheirality-consistent supports compared (poseonly.analysis.rival_test and planar_twin):
// the matches with sampson_chiral < thr under a, under b, under a only and under b only (t of either
// pose of any non-zero length: each is normalised).
struct SupportComparison {
  int64_t a = 0, b = 0, only_a = 0, only_b = 0;
};
// far_neutral: a match whose rays R f1 and f2 are parallel to within thr under a pose (|R f1 x f2| < thr,
// the sine of its parallax: consistent with a point at infinity) counts for that pose by its Sampson error
// alone, since the signs of its depths are then the noise's (the rival test; the twin keeps plain cheirality)
SupportComparison compare_support(const Pose& a, const Pose& b, const Points& P, double thr, bool far_neutral = false);

// The status analysis's planar twin (poseonly.analysis.planar_twin documents the decision, made in
// Python from these counts): the homography twin of `pose` from the matches with mask[i] != 0 (its
// inliers; none below 6 of them), screened as select_by_support screens it (support at min(1.5 tau,
// 0.5) at least 30 % of the pose's), polished (polish_candidate) and compared with the pose at
// min(tau, 0.5); where that twin is not found or fails the screen, the twin of the homography fitted to
// those inliers directly (homography_twin_dlt) is screened instead. `found`: the triangulated plane's
// twin decomposition exists (planarity set); `compared`: a twin passed the screen.
struct TwinAnalysis {
  bool found = false;
  bool compared = false;
  double planarity = 0.0;
  Pose twin;
  SupportComparison support;
};
TwinAnalysis analyse_twin(const Pose& pose, const Points& P, const uint8_t* mask, double tau);

// The median angle (radians) between R a_i and b_i over the matches with mask[i] != 0 (the cosine
// clipped to [-1, 1]); NaN when there is none (poseonly.analysis.parallax_deg).
double median_rotation_angle(const Mat3& R, const Points& P, const uint8_t* mask);

// The twin comparison's polish: angular LiGTopt (Cauchy loss at tau, 20 evaluations) on the matches
// with sampson_chiral < 1.5 tau (or, with fewer than 6 of them, Sampson < 1.5 tau); the pose itself
// when it is not a rotation, too few points qualify or the result is not finite.
Pose polish_candidate(const Pose& pose, const Points& P, double tau);

// The default method's pose-only choice (poseonly.robust.default.select_by_support): the RANSAC pose
// re-identified on its Sampson inliers (< tau), the 18 LiRP candidates of those inliers and, when
// plausible, the polished homography twin; among the candidates at least 1 deg (pose_distance_deg) from
// the re-identified pose (other basins: the twin, other cheirality), the one with the most
// cheirality-consistent support at min(tau, 0.5) if it beats the re-identified pose's, else that pose.
// Fewer than 6 inliers: `pose`.
Pose select_by_support(const Pose& pose, const Points& P, double tau);

// log P(Bin(n, p) >= k): log-sum-exp of the terms log C(n, j) + j log p + (n - j) log(1 - p), j = k..n,
// with log j! from one growing table of sequential sums of log i (mutex-guarded; the values do not
// depend on the table's length). 0 for k <= 0 or p >= 1, -inf for k > n or p <= 0. numpy reference:
// tests/reference/nfa.py (poseonly.analysis.log_binom_sf documents the use)
double log_binom_sf(int64_t k, int64_t n, double p);

// numpy's median of the values of *x (reordered): NaN when one is NaN or x is empty; the mean
// (a + b) / 2 of the two middle values for an even count (the same float as numpy.median)
double median_of(std::vector<double>* x);

// The pure-rotation test's precision check (poseonly.analysis.parallax_ratio, which documents the
// method; numpy reference tests/reference/parallax.py). On the matches with v[i] < band * tau and
// |R a_i - b_i|^2 < sel_chord2: e2 = v^2, s2 = median(e2) / chi2_median; when s2 > 0, irls_rounds
// Cauchy-weighted Kabsch refits of R (weights 1 / (1 + |R a - b|^2 / 2 / (cauchy_c^2 s2))); then
// ratio = median(|R a - b|^2 / 2 - e2) / median(e2) (0 where that median parallax is at most
// (min_parallax tau)^2, inf where median(e2) = 0), noise = sqrt(s2) / tau. Fewer than min_matches
// such matches: ratio = noise = NaN and refit = false.
struct ParallaxOptions {
  double band = 3.0;
  double sel_chord2 = 0.0;
  int min_matches = 50;
  int irls_rounds = 5;
  double cauchy_c = 2.385;
  double chi2_median = 0.45493642311957283;
  double min_parallax = 1e-4;
  double noise_floor = 0.0;  // radians: median(e2) >= chi2_median noise_floor^2 (the coordinates' rounding)
};
struct ParallaxResult {
  double ratio = 0.0;
  double noise = 0.0;
  Mat3 R = Mat3::Identity();
  bool refit = false;
};
ParallaxResult parallax_ratio(const Mat3& R, const Points& P, const double* v, double tau, const ParallaxOptions& o);

}  // namespace poseonly
