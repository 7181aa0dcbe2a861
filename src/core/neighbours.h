// k nearest neighbours of unit bearings and the neighbour consistency of matches
// (poseonly.robust.consistency; numpy reference: tests/reference/neighbours.py).
#pragma once

#include <cstdint>
#include <vector>

namespace poseonly {

// For each of the n unit bearings f (n x 3, row-major), the indices of its k nearest other bearings by
// Euclidean (chord) distance, nearest first, ties by the smaller index (a duplicate bearing is a
// neighbour at distance 0). out: n x k. Requires 1 <= k <= n - 1. Exact: a uniform grid over the
// bearings' orthographic projection onto the plane normal to their mean direction (a contraction, so
// a cell ring's planar distance bounds the chord distance of every bearing in it from below) is
// searched ring by ring until no unseen cell can hold a nearer bearing.
void nearest_neighbours(const double* f, int n, int k, int32_t* out);

// For each match i of (f1, f2) (n x 3 each): how many of its k nearest matches in view 1 are among its
// k nearest in view 2. Requires 1 <= k <= n - 1.
void neighbour_consistency(const double* f1, const double* f2, int n, int k, int64_t* out);

// The first match (lowest index) of each group of repeated matches of (f1, f2) (n x 3 each), ascending.
// Two matches repeat each other when their rows are identical (bit for bit, both views) or, with
// tol > 0, both chord distances |f1_i - f1_j| and |f2_i - f2_j| are below tol; the groups are the
// connected components of that relation. Exact: every pair within tol in both views lies within
// sqrt(2) tol in the 6-D space of the two bearings, so a sweep along one fixed direction of that
// space (sorted projections, the bound given a slack of 1e-9 relative and 1e-14 absolute against
// their rounding) meets it; the time is O(n log n) plus the pairs the sweep's slab holds. Finite input.
std::vector<int64_t> distinct_matches(const double* f1, const double* f2, int n, double tol);

// The translation's local support (poseonly.analysis._locally_supported): extra[i] kept where at least
// min(min_count, k) of match i's k = min(k_max, m - 1) nearest matches in view 1 (among the m matches
// in extra | explained; chord distance) are extra too and not the same view-1 bearing as i (a
// keypoint matched again). extra and explained are n-element masks; out gets the result (n).
void locally_supported(const double* f1, int n, const uint8_t* extra, const uint8_t* explained, int k_max, int min_count, uint8_t* out);

}  // namespace poseonly
