// Samplers of the robust loops: uniform and progressive (PROSAC). Deterministic for a seed on
// every platform: std::mt19937_64 is fully specified, and indices are drawn by Lemire's
// multiply-shift instead of the implementation-defined std::uniform_int_distribution.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace poseonly {

class Rng {
 public:
  explicit Rng(uint64_t seed) : gen_(seed) {}
  // uniform integer in [0, n)
  int below(int n) { return static_cast<int>((static_cast<unsigned __int128>(gen_()) * static_cast<uint64_t>(n)) >> 64); }
  double uniform() { return static_cast<double>(gen_() >> 11) * 0x1.0p-53; }

 private:
  std::mt19937_64 gen_;
};

// m distinct indices drawn uniformly from [0, n) (rejection; m is small against n).
inline void draw_distinct(Rng& rng, int n, int m, int* out) {
  for (int j = 0; j < m; ++j) {
    int x;
    do {
      x = rng.below(n);
    } while (std::find(out, out + j, x) != out + j);
    out[j] = x;
  }
}

class UniformSampler {
 public:
  UniformSampler(int n, int m, uint64_t seed) : n_(n), m_(m), rng_(seed) {}
  void sample(std::vector<int>* s) {
    s->resize(m_);
    if (m_ >= n_) {
      for (int j = 0; j < m_; ++j) (*s)[j] = j;
      return;
    }
    draw_distinct(rng_, n_, m_, s->data());
  }

 private:
  int n_, m_;
  Rng rng_;
};

// PROSAC (Chum and Matas 2005), as COLMAP's ProgressiveSampler: samples are drawn from the
// top-ranked points first, the pool growing with the growth function T_n; after `max_trials`
// draws it has become uniform over all points. `order` lists the points best first.
class ProsacSampler {
 public:
  ProsacSampler(std::vector<int> order, int m, int max_trials, uint64_t seed)
      : order_(std::move(order)), N_(static_cast<int>(order_.size())), m_(m), rng_(seed) {
    n_ = std::min(m_, N_);
    T_n_ = static_cast<double>(max_trials);
    for (int i = 0; i < m_; ++i) T_n_ *= static_cast<double>(n_ - i) / static_cast<double>(N_ - i);
    T_n_p_ = 1.0;
    // the growth schedule, replayed without the generator: grown_at_[k] is the draw at which the
    // pool first holds k points (the draws before it all lie in the top k - 1)
    grown_at_.assign(N_ + 2, std::numeric_limits<double>::infinity());
    double Tn = T_n_, Tp = 1.0, t = 0.0;
    int n = n_;
    for (int k = 0; k <= n; ++k) grown_at_[k] = 0.0;
    while (n < N_) {
      t = std::max(t + 1.0, std::ceil(Tp));
      const double T1 = Tn * (n + 1.0) / (n + 1.0 - m_);
      Tp += std::ceil(T1 - Tn);
      Tn = T1;
      grown_at_[++n] = t;
    }
    last_full_ = Tp;
  }
  // the points, best first
  const std::vector<int>& order() const { return order_; }
  // the number of draws, among the first `draws`, whose points all lie in the top n (n <= N)
  double draws_within(int n, double draws) const { return n >= N_ ? draws : std::max(0.0, std::min(draws, grown_at_[n + 1] - 1.0)); }
  // the last draw that still holds the N-th point (with m - 1 of the top N - 1); later draws are m of
  // all N (uniform sampling)
  double last_with_newest() const { return last_full_; }
  void sample(std::vector<int>* s) {
    s->resize(m_);
    if (m_ >= N_) {
      for (int j = 0; j < m_; ++j) (*s)[j] = order_[j];
      return;
    }
    t_ += 1;
    if (t_ >= T_n_p_ && n_ < N_) {
      const double T_n1 = T_n_ * (n_ + 1.0) / (n_ + 1.0 - m_);
      T_n_p_ += std::ceil(T_n1 - T_n_);
      T_n_ = T_n1;
      n_ += 1;
    }
    int k = m_, top = n_;
    const bool take_last = T_n_p_ >= t_;
    if (take_last) {  // the n-th point plus m - 1 from the n - 1 before it
      k -= 1;
      top -= 1;
    }
    std::vector<int>& v = *s;
    draw_distinct(rng_, top, k, v.data());
    if (take_last) v[k] = n_ - 1;
    for (int j = 0; j < m_; ++j) v[j] = order_[v[j]];
  }

 private:
  std::vector<int> order_;
  int N_, m_;
  Rng rng_;
  int n_ = 0;
  double t_ = 0.0, T_n_ = 0.0, T_n_p_ = 1.0;
  std::vector<double> grown_at_;
  double last_full_ = 0.0;
};

}  // namespace poseonly
