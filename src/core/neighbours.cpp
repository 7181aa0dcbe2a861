// k nearest neighbours on a grid, and the neighbour consistency of matches; see neighbours.h.
#include "neighbours.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <vector>

namespace poseonly {

namespace {

constexpr double kPointsPerCell = 2.0;  // grid resolution: about this many bearings per cell of the bounding box
constexpr int kMaxCells = 4096;         // cells per side at most
// the ring bound's slack: a chord at least (r - 1) hc in the plane, less a few ulps of rounding
constexpr double kBoundSlack = 1.0 - 1e-12;

struct Cand {
  double d2;
  int32_t j;
  bool operator<(const Cand& o) const { return d2 < o.d2 || (d2 == o.d2 && j < o.j); }
};

}  // namespace

void nearest_neighbours(const double* f, int n, int k, int32_t* out) {
  // the plane normal to the mean direction (any normal if the bearings cancel out)
  double m[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) m[c] += f[3 * i + c];
  double mn = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
  if (!(mn > 1e-9 * n)) m[0] = 0.0, m[1] = 0.0, m[2] = 1.0, mn = 1.0;
  for (double& v : m) v /= mn;
  // e1 = a unit vector normal to m (from the axis least aligned with it), e2 = m x e1
  const int ax = std::fabs(m[0]) <= std::fabs(m[1]) ? (std::fabs(m[0]) <= std::fabs(m[2]) ? 0 : 2) : (std::fabs(m[1]) <= std::fabs(m[2]) ? 1 : 2);
  double e1[3] = {0.0, 0.0, 0.0};
  e1[ax] = 1.0;
  const double d = e1[0] * m[0] + e1[1] * m[1] + e1[2] * m[2];
  for (int c = 0; c < 3; ++c) e1[c] -= d * m[c];
  const double n1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  for (double& v : e1) v /= n1;
  const double e2[3] = {m[1] * e1[2] - m[2] * e1[1], m[2] * e1[0] - m[0] * e1[2], m[0] * e1[1] - m[1] * e1[0]};
  std::vector<double> px(n), py(n);
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (int i = 0; i < n; ++i) {
    const double* p = f + 3 * i;
    px[i] = p[0] * e1[0] + p[1] * e1[1] + p[2] * e1[2];
    py[i] = p[0] * e2[0] + p[1] * e2[1] + p[2] * e2[2];
    x0 = std::min(x0, px[i]), x1 = std::max(x1, px[i]), y0 = std::min(y0, py[i]), y1 = std::max(y1, py[i]);
  }
  // square cells of side hc: about kPointsPerCell bearings per cell of the bounding box, at most
  // kMaxCells per side (nearly collinear bearings give a thin box; square cells keep the ring bound
  // hc useful there, where the thin side's width would make it vanish)
  const double w = x1 - x0, hgt = y1 - y0;
  const double area = std::max(w, 1e-12) * std::max(hgt, 1e-12);
  const double hc = std::max({std::sqrt(area * kPointsPerCell / n), w / kMaxCells, hgt / kMaxCells, 1e-12});
  const int gx = std::max(1, static_cast<int>(std::min(std::ceil(w / hc), static_cast<double>(kMaxCells))));
  const int gy = std::max(1, static_cast<int>(std::min(std::ceil(hgt / hc), static_cast<double>(kMaxCells))));
  const double hmin = hc;
  auto cell_x = [&](double x) { return std::min(gx - 1, std::max(0, static_cast<int>(std::min((x - x0) / hc, static_cast<double>(gx))))); };
  auto cell_y = [&](double y) { return std::min(gy - 1, std::max(0, static_cast<int>(std::min((y - y0) / hc, static_cast<double>(gy))))); };
  // counting sort of the bearings by cell
  std::vector<int> start(static_cast<size_t>(gx) * gy + 1, 0), cell(n), items(n);
  for (int i = 0; i < n; ++i) ++start[(cell[i] = cell_y(py[i]) * gx + cell_x(px[i])) + 1];
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int i = 0; i < n; ++i) items[fill[cell[i]]++] = i;
  }
  std::vector<Cand> best;  // a max-heap of the k nearest so far (front: the farthest of them)
  best.reserve(k);
  for (int i = 0; i < n; ++i) {
    const double* a = f + 3 * i;
    const int cx = cell_x(px[i]), cy = cell_y(py[i]);
    best.clear();
    auto visit = [&](int x, int y) {
      const int c = y * gx + x;
      for (int s = start[c]; s < start[c + 1]; ++s) {
        const int j = items[s];
        const double* b = f + 3 * j;
        const double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
        const Cand cd{d0 * d0 + d1 * d1 + d2 * d2, j};
        if (j == i) continue;
        if (static_cast<int>(best.size()) < k) {
          best.push_back(cd);
          std::push_heap(best.begin(), best.end());
        } else if (cd < best.front()) {
          std::pop_heap(best.begin(), best.end());
          best.back() = cd;
          std::push_heap(best.begin(), best.end());
        }
      }
    };
    const int rmax = std::max({cx, gx - 1 - cx, cy, gy - 1 - cy});  // the last ring that holds cells
    for (int r = 0; r <= rmax; ++r) {
      // ring r: the cells at Chebyshev distance r from (cx, cy); every bearing in it is at least
      // (r - 1) cells away in the plane, so at least (r - 1) hc in chord distance
      if (r >= 2 && static_cast<int>(best.size()) == k) {
        const double lb = (r - 1) * hmin * kBoundSlack;
        if (best.front().d2 < lb * lb) break;
      }
      const int xa = cx - r, xb = cx + r, ya = cy - r, yb = cy + r;
      const int x_lo = std::max(xa, 0), x_hi = std::min(xb, gx - 1);
      if (ya >= 0)
        for (int x = x_lo; x <= x_hi; ++x) visit(x, ya);
      if (r > 0 && yb < gy)
        for (int x = x_lo; x <= x_hi; ++x) visit(x, yb);
      if (r > 0)
        for (int y = std::max(ya + 1, 0); y <= std::min(yb - 1, gy - 1); ++y) {
          if (xa >= 0) visit(xa, y);
          if (xb < gx) visit(xb, y);
        }
    }
    std::sort_heap(best.begin(), best.end());
    for (int q = 0; q < k; ++q) out[static_cast<size_t>(i) * k + q] = best[q].j;
  }
}

void neighbour_consistency(const double* f1, const double* f2, int n, int k, int64_t* out) {
  std::vector<int32_t> a(static_cast<size_t>(n) * k), b(static_cast<size_t>(n) * k);
  nearest_neighbours(f1, n, k, a.data());
  nearest_neighbours(f2, n, k, b.data());
  for (int i = 0; i < n; ++i) {
    int32_t* ai = a.data() + static_cast<size_t>(i) * k;
    int32_t* bi = b.data() + static_cast<size_t>(i) * k;
    std::sort(ai, ai + k);
    std::sort(bi, bi + k);
    int64_t c = 0;
    for (int p = 0, q = 0; p < k && q < k;) {
      if (ai[p] == bi[q]) ++c, ++p, ++q;
      else if (ai[p] < bi[q]) ++p;
      else ++q;
    }
    out[i] = c;
  }
}

namespace {

// a fixed generic unit direction in the 6-D space of a match's two bearings (unnormalised here)
constexpr double kSweep[6] = {0.41, -0.27, 0.53, 0.37, 0.45, -0.38};

int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

std::vector<int64_t> distinct_matches(const double* f1, const double* f2, int n, double tol) {
  // exact repeats: the rows sorted by their 48 bytes (ties by index), the first of each run kept
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  auto row_cmp = [&](int a, int b) {
    const int c1 = std::memcmp(f1 + 3 * static_cast<size_t>(a), f1 + 3 * static_cast<size_t>(b), 3 * sizeof(double));
    if (c1 != 0) return c1;
    return std::memcmp(f2 + 3 * static_cast<size_t>(a), f2 + 3 * static_cast<size_t>(b), 3 * sizeof(double));
  };
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const int c = row_cmp(a, b);
    return c < 0 || (c == 0 && a < b);
  });
  std::vector<int> first;
  first.reserve(n);
  for (int s = 0; s < n; ++s)
    if (s == 0 || row_cmp(order[s - 1], order[s]) != 0) first.push_back(order[s]);
  std::sort(first.begin(), first.end());
  const int m = static_cast<int>(first.size());
  if (tol > 0.0 && m > 1) {
    double norm = 0.0;
    for (double c : kSweep) norm += c * c;
    norm = std::sqrt(norm);
    std::vector<double> proj(m);
    for (int a = 0; a < m; ++a) {
      const double* p = f1 + 3 * static_cast<size_t>(first[a]);
      const double* q = f2 + 3 * static_cast<size_t>(first[a]);
      proj[a] = (kSweep[0] * p[0] + kSweep[1] * p[1] + kSweep[2] * p[2] + kSweep[3] * q[0] + kSweep[4] * q[1] + kSweep[5] * q[2]) / norm;
    }
    std::vector<int> by(m);
    std::iota(by.begin(), by.end(), 0);
    std::stable_sort(by.begin(), by.end(), [&](int a, int b) { return proj[a] < proj[b]; });
    // the projections' rounding (a few ulps of values ~1) must not cut a pair off where tol is tiny: a
    // slack on the pre-filter only (each candidate's distances are checked exactly)
    const double bound = std::sqrt(2.0) * tol * (1.0 + 1e-9) + 1e-14;
    std::vector<int> parent(m);
    std::iota(parent.begin(), parent.end(), 0);
    auto dist = [](const double* x, const double* y) {
      const double d0 = x[0] - y[0], d1 = x[1] - y[1], d2 = x[2] - y[2];
      return std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    };
    for (int s = 0; s < m; ++s) {
      const int a = by[s];
      const size_t ia = static_cast<size_t>(first[a]);
      for (int u = s + 1; u < m && proj[by[u]] - proj[a] < bound; ++u) {
        const int b = by[u];
        const size_t ib = static_cast<size_t>(first[b]);
        if (dist(f1 + 3 * ia, f1 + 3 * ib) < tol && dist(f2 + 3 * ia, f2 + 3 * ib) < tol) {
          // union, the lower position the root: a group is represented by its lowest index
          const int ra = find_root(parent, a), rb = find_root(parent, b);
          if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
        }
      }
    }
    std::vector<int> kept;
    kept.reserve(m);
    for (int a = 0; a < m; ++a)
      if (find_root(parent, a) == a) kept.push_back(first[a]);
    first.swap(kept);
  }
  return std::vector<int64_t>(first.begin(), first.end());
}

void locally_supported(const double* f1, int n, const uint8_t* extra, const uint8_t* explained, int k_max, int min_count, uint8_t* out) {
  std::vector<int> idx;
  idx.reserve(n);
  for (int i = 0; i < n; ++i) {
    out[i] = extra[i];
    if (extra[i] || explained[i]) idx.push_back(i);
  }
  const int m = static_cast<int>(idx.size());
  const int k = std::min(k_max, m - 1);
  if (k < 1) return;
  std::vector<double> g(3 * static_cast<size_t>(m));
  for (int a = 0; a < m; ++a)
    for (int c = 0; c < 3; ++c) g[3 * static_cast<size_t>(a) + c] = f1[3 * static_cast<size_t>(idx[a]) + c];
  std::vector<int32_t> nb(static_cast<size_t>(m) * k);
  nearest_neighbours(g.data(), m, k, nb.data());
  const int need = std::min(min_count, k);
  for (int a = 0; a < m; ++a) {
    const int i = idx[a];
    if (!extra[i]) continue;
    const double* ga = g.data() + 3 * static_cast<size_t>(a);
    int c = 0;
    for (int q = 0; q < k; ++q) {
      const int b = nb[static_cast<size_t>(a) * k + q];
      const double* gb = g.data() + 3 * static_cast<size_t>(b);
      const bool other = ga[0] != gb[0] || ga[1] != gb[1] || ga[2] != gb[2];
      c += extra[idx[b]] && other;
    }
    out[i] = c >= need;
  }
}

}  // namespace poseonly
