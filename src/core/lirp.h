// LiRP, the linear six-point relative pose solver (Section 5, Algorithm 1), and the pose-only
// identification of its candidates. numpy reference: tests/reference/lirp.py (tests compare to 1e-9).
#pragma once

#include "common.h"

namespace poseonly {

constexpr int kLirpCandidates = 18;  // 12 action-matrix + 3 det-cubic + q1, q2, q3
constexpr int kLirpMinPoints = 6;

// Steps 1-5 of Algorithm 1: the 18 unit-Frobenius candidate essential matrices.
struct LirpCandidates {
  std::array<Mat3, kLirpCandidates> E;
  Vec9 singular_values = Vec9::Zero();  // of the weighted epipolar matrix A, descending
  double d_min = kInf;                  // Table 2 indicator: min |lambda_i - lambda_j| of C1
  double d_min_C2 = kInf;               // the same for C2
  // |A vec(E_k)|^2 of each candidate (the weighted algebraic epipolar error, from its coordinates in
  // the basis q1, q2, q3 and their singular values): the order in which lirp() scores them
  std::array<double, kLirpCandidates> algebraic{};
};

// One candidate reduced to one pose by the pose-only depth conditions.
struct Identified {
  Pose pose;
  bool valid = false;  // M1 > 0 and M2 != 0 after the flip
  double M1 = 0.0;     // weighted mean sign of (h^T t)(h'^T t), in [-1, 1]
  double cost = kInf;  // weighted mean v_PPO (inf where not computed or not finite)
};

struct LirpResult {
  LirpCandidates cand;
  std::array<Identified, kLirpCandidates> id;
  int best = kLirpCandidates - 1;
};

// Candidates of the weighted problem (w == nullptr: all ones). Weights are rescaled by their
// maximum first (the null space is invariant to a global scale), so 1e150 or mixed 1e150 / 1e-150
// weights neither overflow nor underflow the factorisation.
void lirp_candidates(const Points& P, const double* w, LirpCandidates* out);

// Singular values (descending) of the unweighted n x 9 epipolar matrix (rows kron(f1_i, f2_i)): the
// rank test of the public API (Householder QR + one-sided Jacobi SVD, as LiRP's null space).
Vec9 epipolar_singular_values(const Points& P);

enum class CostMode : int { Never = 0, IfValid = 1, Always = 2 };

// Decompose E into its two rotations, keep the one with the larger M1, flip t when M2 < 0
// (the rules of the pose-only depth conditions, M1 and M2 as weighted sign counts); `mode` says when
// to add the weighted mean PPO residual.
void identify(const Mat3& E, const Points& P, const double* w, CostMode mode, Identified* out);

// Weighted mean PPO residual of a pose (the ranking objective).
double ppo_cost(const Pose& pose, const Points& P, const double* w);

// Index of the best candidate: the valid one with the least cost, invalid ones ranked after
// every valid one (cost + 10; PPO <= 2).
int rank_best(const std::array<Identified, kLirpCandidates>& id);

// Algorithm 1 in full. `all_costs`: PPO cost of every candidate (the public solver); otherwise
// invalid candidates are only scored when no valid one has a finite cost (same best).
void lirp(const Points& P, const double* w, bool all_costs, LirpResult* out);

}  // namespace poseonly
