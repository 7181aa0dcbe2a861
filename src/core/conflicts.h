// Matches that share a keypoint: at most one of them can be right, so a model's support counts,
// for each keypoint, only its best match.
//
// Ratio-test matching without a mutual check pairs one keypoint with several (SIFT also detects a
// corner once per dominant orientation, at the same position). On the shared Strecha and realpairs
// sets 12-35 % of the distinct correspondences share a keypoint with another one. A model whose
// epipole sits on a keypoint that many keypoints of the other image were matched to gives all those
// matches a zero epipolar error (every epipolar line passes through the epipole): on Herz-Jesus-P8
// views 0 and 6 seven matches into one point made such a model, 80 deg off, outscore the true one
// on every seed (docs/history/RESULTS_real_sessions.md, ninth session).
//
// Keypoints are identified by identical bearings (the same pixel through the same calibration).
// Exact copies of a correspondence (the same keypoint pair, e.g. two orientations on both sides)
// are one correspondence here: they count with it, as before. A *group* holds the matches of one
// keypoint (in either image) that belong to two or more distinct correspondences; in a group only
// the matches of the correspondence with the lowest cost keep their cost, every other member scores
// as an outlier. A match in two groups is demoted at most once. numpy reference:
// tests/reference/conflicts.py.
#pragma once

#include <algorithm>
#include <cassert>
#include <iterator>
#include <limits>
#include <vector>

#include "common.h"

namespace poseonly {

struct KeypointConflicts {
  std::vector<int> start{0};  // group g holds members[start[g] .. start[g + 1])
  std::vector<int> members;
  std::vector<int> corr;      // per match: the id of its distinct correspondence
  int num_groups() const { return static_cast<int>(start.size()) - 1; }
  bool empty() const { return num_groups() == 0; }
};

// The groups of the matches P: view 1's groups first, each view's in the lexicographic order of its
// keypoints, members in increasing index order; correspondence ids are equal exactly for identical
// correspondences (numbered in the order of the sorted pairs). Matches with a non-finite bearing
// join no group. Deterministic.
KeypointConflicts keypoint_conflicts(const Points& P);

// The members of K's groups that a model with per-match costs `cost_of(i)` demotes (sorted, unique).
template <class CostOf>
void demoted_members(const KeypointConflicts& K, CostOf cost_of, std::vector<char>* mark, std::vector<int>* out) {
  out->clear();
  for (int g = 0; g < K.num_groups(); ++g) {
    int best = -1;
    double bc = std::numeric_limits<double>::infinity();
    for (int k = K.start[g]; k < K.start[g + 1]; ++k) {
      const int i = K.members[k];
      const double c = cost_of(i);
      if (best < 0 || c < bc) best = i, bc = c;  // ties: the lowest index (members are sorted)
    }
    for (int k = K.start[g]; k < K.start[g + 1]; ++k) {
      const int i = K.members[k];
      if (K.corr[i] != K.corr[best] && !(*mark)[i]) {
        (*mark)[i] = 1;
        out->push_back(i);
      }
    }
  }
  for (int i : *out) (*mark)[i] = 0;
  std::sort(out->begin(), out->end());
}

// Base's cost (a ChiralScorer: its plain pass is the loop's lower bound, left as it is, since
// demoting only raises a cost) with the demoted members scored as outliers. Base provides
// cost_terms(est, model, bail, terms) (the exact cost, each match's term written out when the cost
// is within bail), exact_terms(est, model, terms) and max_point_cost().
template <class Base>
struct KeypointOnceScorer {
  Base base;
  const KeypointConflicts* K = nullptr;
  // scratch of one search (the scorer is never shared between threads: each search builds its own)
  mutable std::vector<char> mark;
  mutable std::vector<int> dem;
  mutable std::vector<double> pc;
  mutable std::vector<int> keep;

  bool inlier(double v) const { return base.inlier(v); }
  double full_cost(int n) const { return base.full_cost(n); }
  template <class Est, class Model>
  double plain(const Est& est, const Model& m, double bail) const {
    return base.plain(est, m, bail);
  }
  template <class Est, class Model>
  double cost(const Est& est, const Model& m, double bail) const {
    if (!K || K->empty()) return base.cost(est, m, bail);
    size_to(est.num_data());
    const double c = base.cost_terms(est, m, bail, pc.data());
    if (c > bail) return c;
    return c + demote();
  }
  template <class Est, class Model>
  double cost_after_plain(const Est& est, const Model& m, double bail, double cp) const {
    if (!K || K->empty()) return base.cost_after_plain(est, m, bail, cp);
    if (cp > bail) return cp;
    size_to(est.num_data());
    const double c = base.cost_terms_after_plain(est, m, bail, pc.data());
    if (c > bail) return c;
    return c + demote();
  }
  // the model's demoted members removed from its inliers (`inl` sorted, as inliers_of makes it)
  template <class Est, class Model>
  void filter_inliers(const Est& est, const Model& m, std::vector<int>* inl) const {
    if (!K || K->empty() || inl->empty()) return;
    size_to(est.num_data());
    base.exact_terms(est, m, pc.data());
    demote();
    if (dem.empty()) return;
    keep.clear();
    std::set_difference(inl->begin(), inl->end(), dem.begin(), dem.end(), std::back_inserter(keep));
    inl->swap(keep);
  }

 private:
  // K was built from the estimator's own points (keypoint_conflicts(P) of the same P)
  void size_to(int n) const {
    assert(static_cast<int>(K->corr.size()) == n);
    if (static_cast<int>(mark.size()) != n) mark.assign(n, 0), pc.assign(n, 0.0);
  }
  // from the terms in pc: fills dem, returns the cost the demotions add
  double demote() const {
    demoted_members(*K, [&](int i) { return pc[i]; }, &mark, &dem);
    const double top = base.max_point_cost();
    double add = 0.0;
    for (int i : dem) add += top - pc[i];
    return add;
  }
};

}  // namespace poseonly
