// k nearest neighbours of unit bearings and the neighbour consistency of matches
// (poseonly.robust.consistency; numpy reference: tests/reference/neighbours.py).
#pragma once

#include <cstdint>

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

}  // namespace poseonly
