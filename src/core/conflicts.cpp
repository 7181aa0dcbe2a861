// Groups of matches that share a keypoint; see conflicts.h.
#include "conflicts.h"

#include <cmath>
#include <cstddef>

namespace poseonly {
namespace {

// indices of the finite matches sorted by the d doubles at key(i) (lexicographic), ties by index;
// a match with a non-finite bearing is no keypoint and joins no group (and NaN would break the order)
template <class Key>
std::vector<int> sorted_by(const std::vector<char>& finite, int d, Key key) {
  std::vector<int> idx;
  idx.reserve(finite.size());
  for (int i = 0; i < static_cast<int>(finite.size()); ++i)
    if (finite[i]) idx.push_back(i);
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
  const size_t N = static_cast<size_t>(n);
  K.corr.assign(N, 0);
  std::vector<char> finite(N, 1);
  for (size_t i = 0; i < N; ++i)
    for (size_t k = 0; k < 3; ++k) finite[i] = finite[i] && std::isfinite(P.f1[3 * i + k]) && std::isfinite(P.f2[3 * i + k]);
  // distinct correspondences: both bearings identical (a non-finite match is a correspondence of its own)
  std::vector<double> both(6 * N);
  for (size_t i = 0; i < N; ++i)
    for (size_t k = 0; k < 3; ++k) both[6 * i + k] = P.f1[3 * i + k], both[6 * i + 3 + k] = P.f2[3 * i + k];
  auto kb = [&](int i) { return both.data() + 6 * static_cast<size_t>(i); };
  const std::vector<int> ob = sorted_by(finite, 6, kb);
  int id = -1;
  for (size_t r = 0; r < ob.size(); ++r) {
    if (r == 0 || !same(kb, 6, ob[r - 1], ob[r])) ++id;
    K.corr[ob[r]] = id;
  }
  for (size_t i = 0; i < N; ++i)
    if (!finite[i]) K.corr[i] = ++id;
  for (int view = 0; view < 2; ++view) {
    const double* f = view == 0 ? P.f1 : P.f2;
    auto kv = [&](int i) { return f + 3 * static_cast<size_t>(i); };
    const std::vector<int> ov = sorted_by(finite, 3, kv);
    const int m = static_cast<int>(ov.size());
    for (int r0 = 0; r0 < m;) {
      int r1 = r0 + 1;
      bool distinct = false;
      while (r1 < m && same(kv, 3, ov[r0], ov[r1])) distinct |= K.corr[ov[r1]] != K.corr[ov[r0]], ++r1;
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
