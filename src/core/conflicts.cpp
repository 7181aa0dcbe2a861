// Groups of matches that share a keypoint; see conflicts.h.
#include "conflicts.h"

#include <numeric>

namespace poseonly {
namespace {

// indices 0..n-1 sorted by the d doubles at key(i) (lexicographic), ties by index
template <class Key>
std::vector<int> sorted_by(int n, int d, Key key) {
  std::vector<int> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(), [&](int a, int b) {
    const double *x = key(a), *y = key(b);
    for (int k = 0; k < d; ++k)
      if (x[k] != y[k]) return x[k] < y[k];
    return false;
  });
  return idx;
}

template <class Key>
bool same(Key key, int d, int a, int b) {
  const double *x = key(a), *y = key(b);
  for (int k = 0; k < d; ++k)
    if (x[k] != y[k]) return false;
  return true;
}

}  // namespace

KeypointConflicts keypoint_conflicts(const Points& P) {
  KeypointConflicts K;
  const int n = P.n;
  K.corr.assign(n, 0);
  // distinct correspondences: both bearings identical
  std::vector<double> both(6 * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) both[6 * i + k] = P.f1[3 * i + k], both[6 * i + 3 + k] = P.f2[3 * i + k];
  auto kb = [&](int i) { return both.data() + 6 * i; };
  const std::vector<int> ob = sorted_by(n, 6, kb);
  for (int r = 0, id = -1; r < n; ++r) {
    if (r == 0 || !same(kb, 6, ob[r - 1], ob[r])) ++id;
    K.corr[ob[r]] = id;
  }
  for (int view = 0; view < 2; ++view) {
    const double* f = view == 0 ? P.f1 : P.f2;
    auto kv = [&](int i) { return f + 3 * i; };
    const std::vector<int> ov = sorted_by(n, 3, kv);
    for (int r0 = 0; r0 < n;) {
      int r1 = r0 + 1;
      bool distinct = false;
      while (r1 < n && same(kv, 3, ov[r0], ov[r1])) distinct |= K.corr[ov[r1]] != K.corr[ov[r0]], ++r1;
      if (distinct) {
        std::vector<int> g(ov.begin() + r0, ov.begin() + r1);
        std::sort(g.begin(), g.end());
        K.members.insert(K.members.end(), g.begin(), g.end());
        K.start.push_back(static_cast<int>(K.members.size()));
      }
      r0 = r1;
    }
  }
  return K;
}

}  // namespace poseonly
