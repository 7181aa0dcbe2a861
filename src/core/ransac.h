// The robust loop, generic over an estimator, a support measurer (scorer) and a sampler, in the
// spirit of PoseLib's ransac<> (estimator contract) and COLMAP's LORANSAC<Estimator, SupportMeasurer,
// Sampler>. The same loop runs the default method (5-point hypotheses, LO by weighted LiRP),
// the paper's GNC-RANSAC (Algorithm 3: GNC-IRLS fits of 30-point samples, inlier counting) and a
// 2-D line estimator in the tests.
//
// Estimator contract (Model = the estimator's model type):
//   int sample_size() const;  int num_data() const;
//   void generate(const std::vector<int>& sample, std::vector<Model>* models);   // the solver
//   Terms terms(const Model&) const;  double residual(const Terms&, int i) const; // the residual
//   bool refine(Model* m, const std::vector<int>& inliers);       // local optimisation (LO) step
//   optional: int refine_candidates(const Model&, const std::vector<int>& inliers, Model* out);
//     an LO offering up to Est::kLoCandidates poses (a two-stage LO's stages); the loop scores each
//   double success_probability(double inlier_ratio) const;        // P(a sample is good)
//   double distance(const Model&, const Model&) const;            // how different two models are
// Scorer contract: double cost(const Estimator&, const Model&, double bail) const (lower is better;
// may stop early once the partial cost exceeds `bail`: costs are sums of non-negative terms, so the
// bail-out is exact), bool inlier(double v) const, and double full_cost(int n) const (the cost of a
// model that explains no point: support = full_cost - cost).
#pragma once

#include <cmath>
#include <algorithm>
#include <functional>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace poseonly {

struct RansacOptions {
  int max_iterations = 100000;
  int min_iterations = 0;
  double confidence = 0.999;
  bool adaptive = true;
  int max_lo = 8;  // LO runs at most this often (on each new best model)
  int min_hits = 1;  // adaptive stopping waits for this many good samples at `confidence` (samples_needed)
  // > 0: also keep the best *rival*, the best-scoring model at least this far (estimator.distance)
  // from the returned one; its cost says whether the data single out one model (a uniqueness test)
  double rival_distance = 0.0;
  // > 0: keep this many *challengers*, the best-scoring models of distinct basins (each at least
  // challenger_distance from the best model and from each other, scored up to kRivalCostFactor times
  // the best cost) that never became the best; after the loop each is locally optimised until its
  // cost stops improving and replaces the best if it beats it. A raw minimal model of the right
  // basin often scores worse than a locally optimised model of a wrong one, and LO runs only on new
  // bests, so without them the search can end on the consensus it optimised first. ransac()'s
  // `others` receives the optimised challengers that lost, with their exact costs.
  int challengers = 0;
  double challenger_distance = 1.0;
  // with a progressive (PROSAC) sampler: also stop by PROSAC's rule (progressive_needed), or with
  // progressive_expected by the expected all-inlier draws of the sampler's schedule (expected_needed)
  bool progressive_stop = false;
  bool progressive_expected = false;
  // the progressive rule may end the search only after this many draws (the classical rule is not
  // affected): it trusts the order, and an order that puts one consistent region first can stop the
  // search before the best basin's sample was drawn
  int progressive_min_draws = 0;
  // > 0: the PROSAC sampler's growth schedule is that of this many trials instead of max_iterations
  // (a search split into stages keeps the schedule of the whole)
  int prosac_trials = 0;
  // > 0 (radians), with an estimator that measures parallax (parallax_cos): while the best model's
  // inliers have a median parallax of at least this, the floor is min(min_iterations,
  // min_iterations_parallax) instead of min_iterations. A weakly constrained pose (small parallax, a
  // flat objective) gains from the longer search; a well-constrained one ends where the stopping rule
  // says (docs/history/RESULTS_real_sessions.md, fourteenth session)
  double floor_parallax = 0.0;
  int min_iterations_parallax = 0;
  // > 0: adaptive stopping assumes an inlier ratio of at least this. For a caller that only needs to
  // know whether a model with this much support exists (a decision, not the best estimate), the search
  // ends once such a model would have been drawn with `confidence`, however little the best has
  double min_inlier_ratio = 0.0;
  // if set, called every kInterruptEvery draws: true ends the search as if at its cap (the bindings run
  // Python's signal handlers there, so Ctrl-C and SIGTERM act within milliseconds: a reliability trial
  // waited 8 s to a minute for a search on 30k-200k random matches). Never called otherwise: results
  // do not depend on it
  std::function<bool()> interrupted;
};
constexpr int kInterruptEvery = 64;

// PROSAC's stopping rule (Chum and Matas, CVPR 2005, Sec. 2.2), with OpenCV USAC's constants: a
// top-n set qualifies when its inlier count I_n is non-random (an incorrect model is supported by a
// random point with probability beta = 0.05; P(Bin(n - m, beta) >= I_n - m) < psi = 0.05, bounded by
// Chernoff's exp(-(n - m) KL), which can only over-state it) and n >= min(N / 2, 100)
constexpr double kProsacBeta = 0.05;
constexpr double kProsacPsi = 0.05;
constexpr int kProsacMinLength = 100;

// LO steps of a challenger at most (each re-selects its inliers), stopping when its cost stops improving
constexpr int kChallengerSteps = 3;

// rivals costing more than this times the best model's are not tracked (RansacOptions::rival_distance)
constexpr double kRivalCostFactor = 1.5;

struct RansacStats {
  int iterations = 0;
  int num_models = 0;
  int num_lo = 0;
  int num_inliers = 0;
  double cost = std::numeric_limits<double>::infinity();
  double rival_cost = std::numeric_limits<double>::infinity();  // inf: no rival tracked or found
  int num_challenger_lo = 0;  // LO steps run on challengers
  int challenger_won = 0;     // 1 when a challenger replaced the search's best model
  // the draws the stopping rule asked for at the end of the loop (inf: no model; above max_iterations:
  // the search stopped at its cap, not converged)
  double needed = std::numeric_limits<double>::infinity();
  // the classical rule's draws alone (the inlier share of all the data) for the best model when it was
  // last updated: a search that ended below it was ended by the progressive rule (or its cap)
  double classical_needed = std::numeric_limits<double>::infinity();
  bool interrupted = false;  // RansacOptions::interrupted ended the search
};

// log P(Bin(k, p) < hits): the chance that k samples, each good with probability p, hold fewer
// than `hits` good ones (0 < p < 1, hits >= 1).
inline double log_fewer_good(double k, double p, int hits) {
  const double lp = std::log(p), lq = std::log1p(-p), lk = std::lgamma(k + 1.0);
  double m = -std::numeric_limits<double>::infinity();
  double terms[64];
  const int h = std::min(hits, 64);
  for (int j = 0; j < h && j <= k; ++j) {
    terms[j] = lk - std::lgamma(j + 1.0) - std::lgamma(k - j + 1.0) + j * lp + (k - j) * lq;
    m = std::max(m, terms[j]);
  }
  double s = 0.0;
  for (int j = 0; j < h && j <= k; ++j) s += std::exp(terms[j] - m);
  return m + std::log(s);
}

// Samples needed so that, with `confidence`, at least `hits` of them are good when one sample is
// good with probability p. hits = 1 is the classical rule log(1 - confidence) / log(1 - p); more hits
// keep the search going until the best consensus has been drawn several times (a single good
// minimal sample's model is noisy and may score below a wrong model's consensus), which costs
// little where good samples are frequent. Exact binomial tail, bisection over integer k.
inline double samples_needed(double p, double confidence, int hits = 1) {
  if (!(p > 0.0)) return std::numeric_limits<double>::infinity();
  if (p >= 1.0) return static_cast<double>(std::max(hits, 1));
  if (hits <= 1) return std::log(1.0 - confidence) / std::log1p(-p);
  const double target = std::log(1.0 - confidence);
  // integers lo < hi with P(lo) > target >= P(hi)
  double lo = hits - 1, hi = std::ceil(std::max(2.0 * hits / p, static_cast<double>(hits)));
  while (log_fewer_good(hi, p, hits) > target) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e15) return std::numeric_limits<double>::infinity();
  }
  while (hi - lo > 1.0) {
    const double mid = std::floor(0.5 * (lo + hi));
    (log_fewer_good(mid, p, hits) > target ? lo : hi) = mid;
  }
  return hi;
}

// Residuals of points [i0, i0 + m) in one call when the estimator has residual_block (a vectorised
// loop), else one by one; the scorers accumulate them in point order either way.
template <class Est, class = void>
struct HasResidualBlock : std::false_type {};
template <class Est>
struct HasResidualBlock<Est, std::void_t<decltype(std::declval<const Est&>().residual_block(
                                 std::declval<const typename Est::Terms&>(), 0, 0, static_cast<double*>(nullptr)))>> : std::true_type {};

constexpr int kScoreBlock = 32;

template <class Est>
inline void residuals_of(const Est& est, const typename Est::Terms& T, int i0, int m, double* out) {
  if constexpr (HasResidualBlock<Est>::value) {
    est.residual_block(T, i0, m, out);
  } else {
    for (int k = 0; k < m; ++k) out[k] = est.residual(T, i0 + k);
  }
}

// The cheirality-aware residuals of [i0, i0 + m) (a point behind either camera scores the largest
// term) when Chiral and the estimator has residual_block_chiral, else residuals_of.
template <class Est, class = void>
struct HasChiralBlock : std::false_type {};
template <class Est>
struct HasChiralBlock<Est, std::void_t<decltype(std::declval<const Est&>().residual_block_chiral(
                               std::declval<const typename Est::Terms&>(), 0, 0, static_cast<double*>(nullptr)))>> : std::true_type {};

template <bool Chiral, class Est>
inline void scored_residuals(const Est& est, const typename Est::Terms& T, int i0, int m, double* out) {
  if constexpr (Chiral && HasChiralBlock<Est>::value) {
    est.residual_block_chiral(T, i0, m, out);
  } else {
    residuals_of(est, T, i0, m, out);
  }
}

// The scorers' pass over the data: residuals in blocks of kScoreBlock, each block mapped to per-point
// costs in place by `point_costs(v, b)` (a branch-free loop, so it runs on SIMD lanes), optionally
// copied to terms, and summed in point order with an exact bail-out once the sum exceeds `bail`.
template <bool Chiral, class Est, class Model, class PointCosts>
inline double block_pass(const Est& est, const Model& m, double bail, double* terms, PointCosts point_costs) {
  const auto T = est.terms(m);
  double c = 0.0;
  const int n = est.num_data();
  double v[kScoreBlock];
  for (int i0 = 0; i0 < n; i0 += kScoreBlock) {
    const int b = std::min(kScoreBlock, n - i0);
    scored_residuals<Chiral>(est, T, i0, b, v);
    point_costs(v, b);
    if (terms) std::copy(v, v + b, terms + i0);
    for (int k = 0; k < b; ++k) {
      c += v[k];
      if (c > bail) return c;
    }
  }
  return c;
}

// Squared-error truncated at thr (MSAC, Torr and Zisserman 2000).
struct MsacScorer {
  double thr;
  bool inlier(double v) const { return v < thr; }
  double full_cost(int n) const { return n * thr * thr; }  // every point an outlier
  double max_point_cost() const { return thr * thr; }
  template <class Est, class Model>
  double cost(const Est& est, const Model& m, double bail) const {
    return pass<false>(est, m, bail);
  }
  template <bool Chiral, class Est, class Model>
  double pass(const Est& est, const Model& m, double bail, double* terms = nullptr) const {
    const double t2 = thr * thr;
    return block_pass<Chiral>(est, m, bail, terms, [t2](double* v, int b) {
      for (int k = 0; k < b; ++k) v[k] = std::isfinite(v[k]) ? std::min(v[k] * v[k], t2) : t2;
    });
  }
};

// MSAC averaged over thr, thr / 2, thr / 4 (normalised by each scale): a coarse marginalisation
// over the noise scale in the spirit of MAGSAC.
struct MultiMsacScorer {
  double thr;
  bool inlier(double v) const { return v < thr; }
  double full_cost(int n) const { return 3.0 * n; }
  double max_point_cost() const { return 3.0; }
  template <class Est, class Model>
  double cost(const Est& est, const Model& m, double bail) const {
    return pass<false>(est, m, bail);
  }
  template <bool Chiral, class Est, class Model>
  double pass(const Est& est, const Model& m, double bail, double* terms = nullptr) const {
    // min(v2, t2 / s) / (t2 / s) = s min(v2, t2 / s) / t2 (s = 1, 4, 16: exact scalings): one
    // multiplication by 1 / t2 per point instead of three divisions
    const double t2 = thr * thr, t2b = 0.25 * t2, t2c = 0.0625 * t2, inv = 1.0 / t2;
    return block_pass<Chiral>(est, m, bail, terms, [=](double* v, int b) {
      for (int k = 0; k < b; ++k) {  // each point's three normalised truncated terms
        const double v2 = std::isfinite(v[k]) ? v[k] * v[k] : std::numeric_limits<double>::infinity();
        v[k] = (std::min(v2, t2) + 4.0 * std::min(v2, t2b) + 16.0 * std::min(v2, t2c)) * inv;
      }
    });
  }
};

// Number of outliers (RANSAC's inlier count, as a cost).
struct CountScorer {
  double thr;
  bool inlier(double v) const { return v < thr; }
  double full_cost(int n) const { return n; }
  double max_point_cost() const { return 1.0; }
  template <class Est, class Model>
  double cost(const Est& est, const Model& m, double bail) const {
    return pass<false>(est, m, bail);
  }
  template <bool Chiral, class Est, class Model>
  double pass(const Est& est, const Model& m, double bail, double* terms = nullptr) const {
    const double t = thr;
    return block_pass<Chiral>(est, m, bail, terms, [t](double* v, int b) {
      for (int k = 0; k < b; ++k) v[k] = v[k] < t ? 0.0 : 1.0;
    });
  }
};

// Base's cost with the cheirality-aware residuals: a match whose point the model puts behind either
// camera is an outlier (the objective of the LO and of select_by_support). Exact and cheap: the plain
// pass runs first with the same bail-out (the chiral cost is never below it), the chiral pass only for
// the models that survive it.
template <class Base>
struct ChiralScorer {
  Base base;
  bool inlier(double v) const { return base.inlier(v); }
  double full_cost(int n) const { return base.full_cost(n); }
  template <class Est, class Model>
  double cost(const Est& est, const Model& m, double bail) const {
    const double c = base.template pass<false>(est, m, bail);
    if (c > bail) return c;
    return base.template pass<true>(est, m, bail);
  }
  // the plain cost alone, a lower bound of the exact one: what ransac() screens every model with
  template <class Est, class Model>
  double plain(const Est& est, const Model& m, double bail) const {
    return base.template pass<false>(est, m, bail);
  }
  // cost(est, m, bail) when plain(est, m, bail) = cp is already known (its pass is not run again)
  template <class Est, class Model>
  double cost_after_plain(const Est& est, const Model& m, double bail, double cp) const {
    if (cp > bail) return cp;
    return base.template pass<true>(est, m, bail);
  }
  // the exact cost with each match's term written to terms[i] (all of them when the cost is <= bail)
  template <class Est, class Model>
  double cost_terms(const Est& est, const Model& m, double bail, double* terms) const {
    const double c = base.template pass<false>(est, m, bail);
    if (c > bail) return c;
    return base.template pass<true>(est, m, bail, terms);
  }
  // the exact pass of cost_terms alone (the plain pass known to be within bail)
  template <class Est, class Model>
  double cost_terms_after_plain(const Est& est, const Model& m, double bail, double* terms) const {
    return base.template pass<true>(est, m, bail, terms);
  }
  // every match's exact term (a full pass without bail-out)
  template <class Est, class Model>
  void exact_terms(const Est& est, const Model& m, double* terms) const {
    base.template pass<true>(est, m, std::numeric_limits<double>::infinity(), terms);
  }
  double max_point_cost() const { return base.max_point_cost(); }
};

template <class Scorer, class = void>
struct HasPlainCost : std::false_type {};
template <class Scorer>
struct HasPlainCost<Scorer, std::void_t<decltype(&Scorer::template plain<int, int>)>> : std::true_type {};

// a scorer that drops some of a model's inliers by a rule over the whole set (KeypointOnceScorer)
template <class Scorer, class = void>
struct HasInlierFilter : std::false_type {};
template <class Scorer>
struct HasInlierFilter<Scorer, std::void_t<decltype(&Scorer::template filter_inliers<int, int>)>> : std::true_type {};

// an estimator whose LO offers several candidates (RelativePoseEstimator's two-stage LOs)
template <class Est, class = void>
struct HasRefineCandidates : std::false_type {};
template <class Est>
struct HasRefineCandidates<Est, std::void_t<decltype(std::declval<Est&>().refine_candidates(std::declval<const typename Est::Model&>(),
                                                                                              std::declval<const std::vector<int>&>(),
                                                                                              std::declval<typename Est::Model*>()))>>
    : std::true_type {};

// The LO of `m` on `inl`, judged by the loop's scorer: the candidate of lowest cost (a later one wins
// ties, i.e. a second stage that scores the same), its cost in *cost (bailing out above `bail`). False
// where the LO failed. An estimator with one LO result (refine) has one candidate.
template <class Est, class Scorer>
bool scored_refine(Est& est, const Scorer& scorer, const typename Est::Model& m, const std::vector<int>& inl, double bail,
                   typename Est::Model* out, double* cost) {
  if constexpr (HasRefineCandidates<Est>::value) {
    typename Est::Model c[Est::kLoCandidates];
    const int k = est.refine_candidates(m, inl, c);
    if (k == 0) return false;
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < k; ++i) {
      const double ci = scorer.cost(est, c[i], std::min(bail, best));
      if (ci <= best) {
        best = ci;
        *out = c[i];
      }
    }
    *cost = best;
    return best < std::numeric_limits<double>::infinity();
  } else {
    *out = m;
    if (!est.refine(out, inl)) return false;
    *cost = scorer.cost(est, *out, bail);
    return true;
  }
}

// The model's inliers under the scorer's residuals (cheirality-aware for a ChiralScorer, so that the
// LO starts from and the adaptive stop counts the matches the score counts).
template <class Est, class Model, class Scorer>
void inliers_of(const Est& est, const Model& m, const Scorer& sc, std::vector<int>* inl) {
  inl->clear();
  const auto T = est.terms(m);
  if constexpr (HasPlainCost<Scorer>::value && HasChiralBlock<Est>::value) {
    double v[kScoreBlock];
    for (int i0 = 0; i0 < est.num_data(); i0 += kScoreBlock) {
      const int b = std::min(kScoreBlock, est.num_data() - i0);
      est.residual_block_chiral(T, i0, b, v);
      for (int k = 0; k < b; ++k)
        if (sc.inlier(v[k])) inl->push_back(i0 + k);
    }
  } else {
    for (int i = 0; i < est.num_data(); ++i)
      if (sc.inlier(est.residual(T, i))) inl->push_back(i);
  }
  if constexpr (HasInlierFilter<Scorer>::value) sc.filter_inliers(est, m, inl);
}

template <class Est, class = void>
struct HasParallax : std::false_type {};
template <class Est>
struct HasParallax<Est, std::void_t<decltype(std::declval<const Est&>().parallax_cos(std::declval<const typename Est::Model&>(),
                                                                                   std::declval<const std::vector<int>&>()))>> : std::true_type {};

template <class Sampler, class = void>
struct HasProgressiveOrder : std::false_type {};
template <class Sampler>
struct HasProgressiveOrder<Sampler, std::void_t<decltype(std::declval<const Sampler&>().draws_within(0, 0.0))>> : std::true_type {};

// the non-randomness test of PROSAC's rule: i of n points support a model fitted to m of them
inline bool non_random(int i, int n, int m) {
  const double k = i - m, d = n - m;
  if (!(d > 0.0) || !(k > kProsacBeta * d)) return false;
  const double q = k / d;
  const double kl = q * std::log(q / kProsacBeta) + (q < 1.0 ? (1.0 - q) * std::log((1.0 - q) / (1.0 - kProsacBeta)) : 0.0);
  return -d * kl < std::log(kProsacPsi);
}

// The draws after which a model supported by at least min_inlier_ratio of the n points would, at
// `confidence`, have been drawn (min_hits times) had one existed (infinite when the option is off or
// no such sample exists). A sample of m distinct points drawn uniformly is all inliers of a model with
// I = ceil(ratio n) inliers with probability prod_j (I - j) / (n - j), which r^m with
// r = (I - m + 1) / (n - m + 1) bounds from below (as in progressive_needed): using I / n, the
// with-replacement ratio, under-counted the draws on small sets (n = 50, I = 15: 0.0024 against the
// true 0.0014). A progressive sampler draws from a growing top of its order, where a model whose
// inliers rank low is not drawn at all, so only its uniform draws count: those after
// last_with_newest().
template <class Est, class Sampler>
double min_support_needed(const Est& est, const Sampler& sampler, int n, const RansacOptions& opt) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (!(opt.min_inlier_ratio > 0.0)) return inf;
  const int m = est.sample_size();
  const double I = std::ceil(std::min(opt.min_inlier_ratio, 1.0) * n - 1e-9);
  if (I < m || n <= m) return inf;
  const double r = (I - m + 1.0) / (n - m + 1.0);
  double k = samples_needed(est.success_probability(r), opt.confidence, opt.min_hits);
  if constexpr (HasProgressiveOrder<Sampler>::value) k += sampler.last_with_newest();
  return k;
}

// The draws after which PROSAC's rule stops for a best model with inliers `inl` (infinite when no top-n
// set qualifies): the least k_n = samples_needed(success(r_n)) over the non-random top-n sets for
// which k_n draws all within the top n happen (the sampler's pool passes n only after grown_at(n + 1);
// the draws are the ones the loop makes anyway, so the rule only ends it earlier: the probability that
// a model with more inliers among the top n exists and none of its samples was drawn is below
// 1 - confidence). r_n = (I_n - m + 1) / (n - m + 1): a sample of m distinct points of the top n is all
// inliers with probability prod_j (I_n - j) / (n - j) (the paper's k_n), which r_n^m bounds from below,
// so the count is conservative for every estimator's success(r). The standard rule is the n = N case.
template <class Est, class Sampler>
double progressive_needed(const Est& est, const Sampler& sampler, const std::vector<int>& inl, const RansacOptions& opt) {
  const std::vector<int>& order = sampler.order();
  const int N = static_cast<int>(order.size()), m = est.sample_size();
  std::vector<char> in(N, 0);  // by point
  for (int i : inl) in[i] = 1;
  const int first = std::max(m + 1, std::min(N / 2, kProsacMinLength));
  double best = std::numeric_limits<double>::infinity();
  int I = 0;
  for (int n = 1; n <= N; ++n) {
    I += in[order[n - 1]];
    if (n < first || !non_random(I, n, m)) continue;
    const double k = samples_needed(est.success_probability(static_cast<double>(I - m + 1) / (n - m + 1)), opt.confidence, opt.min_hits);
    if (k < best && sampler.draws_within(n, k) >= k) best = k;
  }
  return best;
}

// P(all k points drawn without replacement from n, of which I are inliers, are inliers)
inline double all_inlier_probability(int I, int n, int k) {
  if (I < k || n < k) return 0.0;
  double q = 1.0;
  for (int j = 0; j < k; ++j) q *= static_cast<double>(I - j) / static_cast<double>(n - j);
  return q;
}

// The expected number of hits at which P(fewer than `hits` hits) <= 1 - confidence, the hits a sum of
// independent rare Bernoulli draws (Poisson): -ln(1 - confidence) for one hit, by bisection otherwise.
inline double poisson_hits_needed(double confidence, int hits) {
  const double target = 1.0 - confidence;
  auto fewer = [hits](double lam) {  // P(Poisson(lam) < hits)
    double term = std::exp(-lam), sum = term;
    for (int k = 1; k < hits; ++k) sum += (term *= lam / k);
    return sum;
  };
  if (hits <= 1) return -std::log(target);
  double lo = 0.0, hi = 1.0;
  while (fewer(hi) > target) hi *= 2.0;
  for (int it = 0; it < 100 && hi - lo > 1e-9 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (fewer(mid) > target ? lo : hi) = mid;
  }
  return hi;
}

// The draws after which the search may stop for a best model with inliers `inl`, counted on the draws
// the progressive sampler actually makes: the classical rule asks for confidence that an all-inlier
// sample of a model as good as the best was drawn, assuming that model's inliers are spread like the
// best's; under uniform sampling that is k = ln(1 - c) / ln(1 - r^m). PROSAC's draws are not uniform: a
// draw while the pool holds the top n is the n-th point with m - 1 of the top n - 1, all-inlier with
// probability [point n inlier] * P(m - 1 of the top n - 1 are inliers); after the last growth step is
// used up (last_with_newest), m of all N. The expected number of all-inlier draws is summed over the sampler's schedule
// (draws_within) and the loop may stop where it reaches poisson_hits_needed(confidence, min_hits): the
// same criterion as the classical rule, for the draws made (with a uniform order it is the classical
// count; where the best model's inliers come first in the score order, far fewer draws). PROSAC's own
// rule (progressive_needed) counts only the draws that fall within one top-n set, which the growth
// schedule keeps few: on entry-P10's pairs with 16.5-18 % inliers it may stop after 23-68k draws
// (classical 48-75k), this sum after 1.8-43k (benchmarks/prosac_stop_bound.py). For estimators whose success is an all-inlier minimal sample.
// Opt-in (progressive_expected): the shorter searches see fewer rival models, and on the real pairs the
// uniqueness test then let two wrong poses through (docs/history/RESULTS_real_sessions.md, fifteenth session).
template <class Est, class Sampler>
double expected_needed(const Est& est, const Sampler& sampler, const std::vector<int>& inl, const RansacOptions& opt) {
  const std::vector<int>& order = sampler.order();
  const int N = static_cast<int>(order.size()), m = est.sample_size();
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (N <= m) return inf;
  std::vector<char> in(N, 0);
  for (int i : inl) in[i] = 1;
  const double need = poisson_hits_needed(opt.confidence, opt.min_hits);
  int I = 0;  // inliers among the top n - 1 (then the top n)
  for (int k = 0; k < m; ++k) I += in[order[k]];
  double acc = 0.0, start = 0.0;
  // pool m: the top m exactly
  double end = sampler.draws_within(m, inf);
  double p = I == m ? 1.0 : 0.0;
  for (int n = m + 1;; ++n) {
    if (p > 0.0 && acc + (end - start) * p >= need) return start + (need - acc) / p;
    acc += (end - start) * p;
    start = end;
    if (n > N - 1) break;
    // pool n: point n (index n - 1) with m - 1 of the top n - 1
    p = in[order[n - 1]] ? all_inlier_probability(I, n - 1, m - 1) : 0.0;
    I += in[order[n - 1]];
    end = sampler.draws_within(n, inf);
  }
  // pool N: until the sampler's last growth step is used up, the N-th point with m - 1 of the top N - 1
  end = std::max(start, sampler.last_with_newest());
  p = in[order[N - 1]] ? all_inlier_probability(I, N - 1, m - 1) : 0.0;
  if (p > 0.0 && acc + (end - start) * p >= need) return start + (need - acc) / p;
  acc += (end - start) * p;
  start = end;
  // then m of all N
  I += in[order[N - 1]];
  p = all_inlier_probability(I, N, m);
  return p > 0.0 ? start + (need - acc) / p : inf;
}

template <class Est, class Scorer, class Sampler, class Model>
RansacStats ransac(Est& est, const Scorer& scorer, Sampler& sampler, const RansacOptions& opt, Model* best, Model* rival = nullptr,
                   std::vector<std::pair<Model, double>>* others = nullptr) {
  RansacStats st;
  const int n = est.num_data();
  const bool track = opt.rival_distance > 0.0 && rival != nullptr;
  const int K = std::max(opt.challengers, 0);
  const double dch = opt.challenger_distance;
  std::vector<int> sample, inl;
  std::vector<Model> models;
  // challengers and their costs: the plain cost, or for a model that passed the plain test the exact
  // cheirality-aware one (a ChiralScorer's), so the ranking is approximate; the end phase rescores
  std::vector<std::pair<Model, double>> ch;
  double needed = opt.max_iterations;
  const double support_needed = opt.adaptive ? min_support_needed(est, sampler, n, opt) : std::numeric_limits<double>::infinity();
  needed = std::min(needed, support_needed);
  bool have = false;
  // support = full cost - cost; gain = the largest support ratio an LO step achieved so far. A
  // challenger is kept only if that gain would lift its support above the best's (before any LO:
  // never), so models that no LO seen could make the best are neither kept nor scored in full.
  const double full = scorer.full_cost(n);
  double gain = 1.0;
  auto reachable = [&]() { return full - (full - st.cost) / gain; };
  // the cost up to which a challenger's cost must be exact
  auto challenger_bound = [&]() {
    if (!K) return 0.0;
    double b = std::min(kRivalCostFactor * st.cost, reachable());
    if (static_cast<int>(ch.size()) == K) {
      double worst = 0.0;
      for (const auto& c : ch) worst = std::max(worst, c.second);
      b = std::min(b, worst);
    }
    return b;
  };
  // a model that is not the best: a challenger if it is far from the best and better than the list's
  // worst or than the members of its own basin (which it then replaces: the members stay apart)
  auto consider = [&](const Model& m, double c) {
    if (!K || !have || !(c <= kRivalCostFactor * st.cost) || !(c < reachable()) || !(est.distance(*best, m) > dch)) return;
    bool near = false, better = true;
    for (const auto& e : ch)
      if (!(est.distance(e.first, m) > dch)) near = true, better = better && c < e.second;
    if (near) {
      if (!better) return;
      ch.erase(std::remove_if(ch.begin(), ch.end(), [&](const auto& e) { return !(est.distance(e.first, m) > dch); }), ch.end());
      ch.emplace_back(m, c);
      return;
    }
    if (static_cast<int>(ch.size()) < K) {
      ch.emplace_back(m, c);
      return;
    }
    auto worst = std::max_element(ch.begin(), ch.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
    if (c < worst->second) *worst = {m, c};
  };
  // a model replacing `best`: the old best becomes the rival if it is far enough from the new one
  auto promote = [&](const Model& m, double c) {
    const Model old = *best;
    const double oc = st.cost;
    const bool had = have;
    if (track && have && est.distance(*best, m) > opt.rival_distance) {
      *rival = *best;
      st.rival_cost = st.cost;
    } else if (track && st.rival_cost < std::numeric_limits<double>::infinity() && !(est.distance(*rival, m) > opt.rival_distance)) {
      st.rival_cost = std::numeric_limits<double>::infinity();  // the rival was this model's basin
    }
    *best = m;
    st.cost = c;
    have = true;
    if (K && had) {  // the challengers of the new best's basin go; the old best may become one
      ch.erase(std::remove_if(ch.begin(), ch.end(), [&](const auto& e) { return !(est.distance(e.first, m) > dch); }), ch.end());
      consider(old, oc);
    }
  };
  // the sample floor (RansacOptions::floor_parallax): min_iterations until a best model with enough parallax
  int floor = opt.min_iterations;
  const double floor_cos = std::cos(opt.floor_parallax);
  while (st.iterations < opt.max_iterations && (st.iterations < needed || st.iterations < floor)) {
    if (opt.interrupted && st.iterations % kInterruptEvery == 0 && st.iterations > 0 && opt.interrupted()) {
      st.interrupted = true;
      break;
    }
    ++st.iterations;
    sampler.sample(&sample);
    models.clear();
    est.generate(sample, &models);
    for (const Model& m : models) {
      ++st.num_models;
      // a rival is scored up to kRivalCostFactor times the best cost at most (a model that far behind
      // cannot rival the result; without the cap every model is scored in full until a rival exists)
      const double bound = track ? std::min(st.rival_cost, kRivalCostFactor * st.cost) : st.cost;
      // the cost is needed exactly up to the largest bound at which the loop could keep the model: the
      // best's cost, and for a model far enough from the best to be a rival or a challenger their
      // bounds (a model of the best's basin can only replace the best: scored to its cost, it bails
      // out earlier and skips the exact pass of a scorer that has one, with the same results)
      const double dist = have && (track || K) ? est.distance(*best, m) : std::numeric_limits<double>::infinity();
      double exact_to = st.cost;
      if (track && dist > opt.rival_distance) exact_to = std::max(exact_to, bound);
      if (K && dist > dch) exact_to = std::max(exact_to, challenger_bound());
      double c;
      if constexpr (HasPlainCost<Scorer>::value) {
        // a scorer with a costlier exact pass (ChiralScorer): the plain cost, a lower bound, first;
        // the exact one for a candidate best, rival or challenger, up to their largest bound, so that
        // every model the loop keeps is ranked by its exact cost, not by the plain bound or a partial sum
        const double cp = scorer.plain(est, m, exact_to);
        c = cp <= exact_to ? scorer.cost_after_plain(est, m, exact_to, cp) : cp;
      } else {
        c = scorer.cost(est, m, exact_to);
      }
      if (!(c < st.cost)) {
        if (track && c <= bound && c < st.rival_cost && est.distance(*best, m) > opt.rival_distance) {
          *rival = m;
          st.rival_cost = c;
        }
        consider(m, c);
        continue;
      }
      promote(m, c);
      if (st.num_lo < opt.max_lo) {
        inliers_of(est, *best, scorer, &inl);
        Model lo;
        double c2;
        ++st.num_lo;
        if (scored_refine(est, scorer, *best, inl, st.cost, &lo, &c2)) {
          const double c0 = st.cost;
          if (c2 <= st.cost) {
            if (full - c0 > 0.0) gain = std::max(gain, (full - c2) / (full - c0));
            promote(lo, c2);
          }
        }
      }
      inliers_of(est, *best, scorer, &inl);
      st.num_inliers = static_cast<int>(inl.size());
      if (opt.adaptive) {
        needed = std::min(samples_needed(est.success_probability(static_cast<double>(inl.size()) / n), opt.confidence, opt.min_hits), support_needed);
        st.classical_needed = needed;
      }
      if constexpr (HasProgressiveOrder<Sampler>::value) {
        if (opt.adaptive && opt.progressive_stop)
          needed = std::min(needed, std::max(static_cast<double>(opt.progressive_min_draws),
                                             opt.progressive_expected ? expected_needed(est, sampler, inl, opt) : progressive_needed(est, sampler, inl, opt)));
      }
      if constexpr (HasParallax<Est>::value) {
        if (opt.floor_parallax > 0.0)
          floor = est.parallax_cos(*best, inl) <= floor_cos ? std::min(opt.min_iterations, opt.min_iterations_parallax) : opt.min_iterations;
      }
    }
  }
  st.needed = have ? needed : std::numeric_limits<double>::infinity();
  // the challengers, best first: each locally optimised until its exact cost stops improving or it
  // falls into the best model's basin; one that beats the best replaces it
  // (the search's stopping rule was met for the best model before this phase, not for a winner)
  std::vector<std::pair<Model, double>> final_ch = ch;  // promote() edits ch
  if (st.interrupted) final_ch.clear();  // the caller discards an interrupted search's result
  std::stable_sort(final_ch.begin(), final_ch.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  std::vector<std::pair<Model, double>> optimised;  // the challengers that lost, with exact costs
  for (const auto& e : final_ch) {
    if (!(est.distance(*best, e.first) > dch) || !(e.second < reachable()) || !(e.second <= kRivalCostFactor * st.cost)) continue;
    Model m = e.first;
    double c = scorer.cost(est, m, std::numeric_limits<double>::infinity());
    for (int k = 0; k < kChallengerSteps; ++k) {
      inliers_of(est, m, scorer, &inl);
      Model lo;
      double c2;
      ++st.num_challenger_lo;
      if (!scored_refine(est, scorer, m, inl, c, &lo, &c2)) break;
      if (!(c2 < c)) break;
      m = lo;
      c = c2;
      if (!(est.distance(*best, m) > dch)) break;  // it fell into the best model's basin
    }
    if (c < st.cost) {
      promote(m, c);
      st.challenger_won = 1;
      inliers_of(est, *best, scorer, &inl);
      st.num_inliers = static_cast<int>(inl.size());
    } else {
      optimised.emplace_back(m, c);
    }
  }
  // a winner may have taken the rival's basin; no later sample can refill the rival slot, so the
  // optimised challengers that lost are offered to it (exact costs, as the loop's rivals)
  if (track)
    for (const auto& e : optimised)
      if (e.second <= kRivalCostFactor * st.cost && e.second < st.rival_cost && est.distance(*best, e.first) > opt.rival_distance) {
        *rival = e.first;
        st.rival_cost = e.second;
      }
  if (others) *others = have ? std::move(optimised) : std::vector<std::pair<Model, double>>{};
  if (!have) st.num_inliers = 0;
  return st;
}

}  // namespace poseonly
