// k nearest neighbours on a grid, and the neighbour consistency of matches; see neighbours.h.
#include "neighbours.h"

#include <algorithm>
#include <cmath>
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

}  // namespace poseonly
