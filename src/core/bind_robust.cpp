// Bindings of the robust loops (ransac.h) for the estimators of estimators.h.
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>

#include "arrays.h"
#include "conflicts.h"
#include "estimators.h"
#include "ml_refine.h"
#include "ransac.h"
#include "register.h"
#include "sampling.h"
#include "signals.h"

#include <algorithm>
#include <atomic>
#include <numeric>

namespace poseonly {

GncOptions gnc_options_from(const nb::dict& o);  // bind_lirp.cpp

namespace {

enum class Scoring : int { Msac = 0, MultiMsac = 1, Count = 2 };
static_assert(HasPlainCost<ChiralScorer<MultiMsacScorer>>::value && !HasPlainCost<MultiMsacScorer>::value,
              "ransac() tracks rivals by ChiralScorer's plain cost");

template <class Est, class Sampler, class Model>
RansacStats run_scored(Est& est, Scoring scoring, double thr, Sampler& sampler, const RansacOptions& ro, Model* best, Model* rival,
                       bool chiral = false, const KeypointConflicts* K = nullptr, std::vector<std::pair<Model, double>>* others = nullptr) {
  if (chiral && K && !K->empty()) {
    switch (scoring) {
      case Scoring::Msac: return ransac(est, KeypointOnceScorer<ChiralScorer<MsacScorer>>{{{thr}}, K}, sampler, ro, best, rival, others);
      case Scoring::MultiMsac: return ransac(est, KeypointOnceScorer<ChiralScorer<MultiMsacScorer>>{{{thr}}, K}, sampler, ro, best, rival, others);
      case Scoring::Count: return ransac(est, KeypointOnceScorer<ChiralScorer<CountScorer>>{{{thr}}, K}, sampler, ro, best, rival, others);
    }
  }
  if (chiral) {
    switch (scoring) {
      case Scoring::Msac: return ransac(est, ChiralScorer<MsacScorer>{{thr}}, sampler, ro, best, rival, others);
      case Scoring::MultiMsac: return ransac(est, ChiralScorer<MultiMsacScorer>{{thr}}, sampler, ro, best, rival, others);
      case Scoring::Count: return ransac(est, ChiralScorer<CountScorer>{{thr}}, sampler, ro, best, rival, others);
    }
  }
  switch (scoring) {
    case Scoring::Msac: return ransac(est, MsacScorer{thr}, sampler, ro, best, rival, others);
    case Scoring::MultiMsac: return ransac(est, MultiMsacScorer{thr}, sampler, ro, best, rival, others);
    case Scoring::Count: return ransac(est, CountScorer{thr}, sampler, ro, best, rival, others);
  }
  throw std::invalid_argument("unknown scoring");
}

// Uniform sampling, or PROSAC when an order (best first) is given.
template <class Est, class Model>
RansacStats run_sampled(Est& est, Scoring scoring, double thr, const std::vector<int>& order, uint64_t seed,
                        const RansacOptions& ro, Model* best, Model* rival = nullptr, bool chiral = false,
                        const KeypointConflicts* K = nullptr, std::vector<std::pair<Model, double>>* others = nullptr) {
  if (order.empty()) {
    UniformSampler s(est.num_data(), est.sample_size(), seed);
    return run_scored(est, scoring, thr, s, ro, best, rival, chiral, K, others);
  }
  ProsacSampler s(order, est.sample_size(), ro.prosac_trials > 0 ? ro.prosac_trials : ro.max_iterations, seed);
  return run_scored(est, scoring, thr, s, ro, best, rival, chiral, K, others);
}

std::vector<int> order_of(const std::optional<nb::ndarray<const int64_t, nb::ndim<1>, nb::c_contig>>& order, int n) {
  std::vector<int> out;
  if (!order) return out;
  if (static_cast<int>(order->shape(0)) != n) throw std::invalid_argument("order must be a permutation of range(n)");
  std::vector<uint8_t> seen(n, 0);
  for (int i = 0; i < n; ++i) {
    const int64_t k = order->data()[i];
    if (k < 0 || k >= n || seen[k]) throw std::invalid_argument("order must be a permutation of range(n)");
    seen[k] = 1;
    out.push_back(static_cast<int>(k));
  }
  return out;
}

RansacOptions ransac_options(int max_iterations, int min_iterations, double confidence, bool adaptive, int max_lo) {
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be >= 1");
  if (!(confidence > 0.0 && confidence < 1.0)) throw std::invalid_argument("confidence must be in (0, 1)");
  RansacOptions ro;
  ro.max_iterations = max_iterations;
  ro.min_iterations = std::max(min_iterations, 0);
  ro.confidence = confidence;
  ro.adaptive = adaptive;
  ro.max_lo = std::max(max_lo, 0);
  return ro;
}

// the LO's code, checked (it was cast to the enum unchecked)
LocalOpt local_opt_of(int lo) {
  if (lo < 0 || lo > static_cast<int>(LocalOpt::SampsonCauchyAuto))
    throw std::invalid_argument(
        "lo must be 0 (lirp), 1 (sampson), 2 (sampson-truncated), 3 (sampson-multi), 4 (sampson-cauchy-multi), 5 (sampson-cauchy-truncated) or 6 "
        "(sampson-cauchy-auto)");
  return static_cast<LocalOpt>(lo);
}

// the LO's residual code, checked
Residual lo_residual_of(int code) {
  if (code < 0 || code >= kNumResiduals) throw std::invalid_argument("lo_residual must be a residual code in [0, " + std::to_string(kNumResiduals) + ")");
  return static_cast<Residual>(code);
}

// RansacOptions::min_inlier_ratio, checked
double checked_min_inlier_ratio(double r) {
  if (!(r >= 0.0 && r <= 1.0)) throw std::invalid_argument("min_inlier_ratio must be in [0, 1]");
  return r;
}

nb::dict stats_dict(const RansacStats& st) {
  nb::dict d;
  d["iterations"] = st.iterations;
  d["num_models"] = st.num_models;
  d["num_lo"] = st.num_lo;
  d["num_inliers"] = st.num_inliers;
  d["cost"] = st.cost;
  d["rival_cost"] = st.rival_cost;
  d["num_challenger_lo"] = st.num_challenger_lo;
  d["challenger_won"] = st.challenger_won;
  d["needed"] = st.needed;
  d["classical_needed"] = st.classical_needed;
  return d;
}

// A cancellation flag that a search in any thread reads every kInterruptEvery draws without the GIL (a
// batch on threads sets it when Ctrl-C comes or its caller stops iterating: the searches running then
// waited to their end, 7.7 s in a review's run, since only the main thread runs Python's signal handlers)
struct CancelFlag {
  std::atomic<bool> value{false};
};
// raised (as poseonly._core.SearchCancelled) by a search that a CancelFlag ended
struct SearchCancelled : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A loop's interrupt hook (RansacOptions::interrupted): `cancel` read in any thread, Python's signal
// handlers run only with check_signals, in Python's main thread, where they run: elsewhere taking the GIL
// every 64 draws slowed a search beside busy Python 10x and aborted the process at interpreter exit (a
// review). Neither set: no hook, and no result depends on it.
void watch_interrupts(RansacOptions* ro, PythonSignals* signals, bool check_signals, const CancelFlag* cancel) {
  if (check_signals || cancel) {
    ro->interrupted = [signals, check_signals, cancel]() {
      return (cancel && cancel->value.load(std::memory_order_relaxed)) || (check_signals && (*signals)());
    };
  }
}

// With the GIL held, after an interruptible loop: a signal handler's exception (Ctrl-C, SIGTERM) raised,
// else SearchCancelled if the flag ended the loop.
void end_if_interrupted(PythonSignals* signals, const RansacStats& st, const CancelFlag* cancel) {
  signals->rethrow();
  if (st.interrupted && cancel) throw SearchCancelled("the search was cancelled (its CancelFlag was set)");
}

nb::tuple ransac_relpose(const BearingsIn& f1, const BearingsIn& f2, double threshold, uint64_t seed, int solver, int scoring,
                         int max_iterations, int min_iterations, double confidence, int max_lo, double lo_mu0, int lo_iterations,
                         int lo_residual, const std::optional<nb::ndarray<const int64_t, nb::ndim<1>, nb::c_contig>>& order,
                         int lo, double rival_distance, bool chiral, int min_hits, int challengers, double challenger_distance,
                         int lo_max_points, bool keypoint_once, bool progressive_stop, double floor_parallax,
                         int min_iterations_parallax, bool progressive_expected, int progressive_min_draws, int prosac_trials,
                         double min_inlier_ratio, bool check_signals, const CancelFlag* cancel) {
  const Points P = points_of(f1, f2);
  if (!(threshold > 0.0 && std::isfinite(threshold))) throw std::invalid_argument("threshold must be finite and > 0");
  if (min_hits < 1 || min_hits > 64) throw std::invalid_argument("min_hits must be in [1, 64]");
  if (challengers < 0 || challengers > 64) throw std::invalid_argument("challengers must be in [0, 64]");
  if (!(challenger_distance > 0.0 && std::isfinite(challenger_distance))) throw std::invalid_argument("challenger_distance must be finite and > 0");
  if (lo_max_points < 0) throw std::invalid_argument("lo_max_points must be >= 0");
  RansacOptions ro = ransac_options(max_iterations, min_iterations, confidence, true, max_lo);
  ro.rival_distance = rival_distance;
  ro.min_hits = min_hits;
  ro.challengers = challengers;
  ro.challenger_distance = challenger_distance;
  ro.progressive_stop = progressive_stop;
  ro.progressive_expected = progressive_expected;
  if (progressive_min_draws < 0) throw std::invalid_argument("progressive_min_draws must be >= 0");
  ro.progressive_min_draws = progressive_min_draws;
  if (prosac_trials < 0) throw std::invalid_argument("prosac_trials must be >= 0");
  ro.prosac_trials = prosac_trials;
  ro.min_inlier_ratio = checked_min_inlier_ratio(min_inlier_ratio);
  if (!(floor_parallax >= 0.0 && floor_parallax <= 3.141592653589793)) throw std::invalid_argument("floor_parallax must be in [0, pi] radians");
  if (min_iterations_parallax < 0) throw std::invalid_argument("min_iterations_parallax must be >= 0");
  ro.floor_parallax = floor_parallax;
  ro.min_iterations_parallax = min_iterations_parallax;
  RelativePoseEstimator::Options eo;
  eo.solver = static_cast<MinimalSolver>(solver);
  eo.lo_threshold = threshold;
  eo.lo_mu0 = lo_mu0;
  eo.lo_iterations = lo_iterations;
  eo.lo_residual = lo_residual_of(lo_residual);
  eo.lo = local_opt_of(lo);
  eo.lo_max_points = lo_max_points;
  const std::vector<int> ord = order_of(order, P.n);
  Pose best, rival;
  std::vector<std::pair<Pose, double>> others;
  RansacStats st;
  int d_groups = 0;
  PythonSignals signals;
  watch_interrupts(&ro, &signals, check_signals, cancel);
  {
    nb::gil_scoped_release release;
    RelativePoseEstimator est(P, eo);
    // matches sharing a keypoint count once (conflicts.h); with the cheirality-aware scorers only
    const KeypointConflicts K = keypoint_once && chiral ? keypoint_conflicts(P) : KeypointConflicts{};
    st = run_sampled(est, static_cast<Scoring>(scoring), threshold, ord, seed, ro, &best, &rival, chiral, &K, &others);
    d_groups = K.num_groups();
  }
  end_if_interrupted(&signals, st, cancel);
  std::vector<double> R(9), t(3), Rr(9), tr(3);
  put_pose(best, R.data(), t.data());
  put_pose(rival, Rr.data(), tr.data());
  nb::dict d = stats_dict(st);
  d["rival_R"] = to_numpy(std::move(Rr), {3, 3});
  d["rival_t"] = to_numpy(std::move(tr), {3});
  d["keypoint_groups"] = d_groups;
  // the optimised challengers that lost (ransac(): `others`), with their exact costs
  const size_t k = others.size();
  std::vector<double> oR(9 * k), ot(3 * k), oc(k);
  for (size_t i = 0; i < k; ++i) {
    put_pose(others[i].first, oR.data() + 9 * i, ot.data() + 3 * i);
    oc[i] = others[i].second;
  }
  d["others_R"] = to_numpy(std::move(oR), {k, 3, 3});
  d["others_t"] = to_numpy(std::move(ot), {k, 3});
  d["others_cost"] = to_numpy(std::move(oc), {k});
  return nb::make_tuple(to_numpy(std::move(R), {3, 3}), to_numpy(std::move(t), {3}), d);
}

// The default search's objective at one pose: its exact cost (cheirality-aware, the matches of a shared
// keypoint scored once when keypoint_once) and its inliers, as the loop measures them.
nb::tuple search_cost(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double threshold, int scoring,
                      bool keypoint_once) {
  const Points P = points_of(f1, f2);
  if (!(threshold > 0.0 && std::isfinite(threshold))) throw std::invalid_argument("threshold must be finite and > 0");
  const Pose pose = pose_of(R, t);
  RelativePoseEstimator::Options eo;
  eo.lo_threshold = threshold;
  double c = 0.0;
  std::vector<int> inl;
  {
    nb::gil_scoped_release release;
    RelativePoseEstimator est(P, eo);
    const KeypointConflicts K = keypoint_once ? keypoint_conflicts(P) : KeypointConflicts{};
    auto run = [&](const auto& sc) {
      c = sc.cost(est, pose, std::numeric_limits<double>::infinity());
      inliers_of(est, pose, sc, &inl);
    };
    switch (static_cast<Scoring>(scoring)) {
      case Scoring::Msac: run(KeypointOnceScorer<ChiralScorer<MsacScorer>>{{{threshold}}, &K}); break;
      case Scoring::MultiMsac: run(KeypointOnceScorer<ChiralScorer<MultiMsacScorer>>{{{threshold}}, &K}); break;
      case Scoring::Count: run(KeypointOnceScorer<ChiralScorer<CountScorer>>{{{threshold}}, &K}); break;
      default: throw std::invalid_argument("unknown scoring");
    }
  }
  std::vector<int64_t> o(inl.begin(), inl.end());
  const size_t m = o.size();
  return nb::make_tuple(c, to_numpy_t<int64_t>(std::move(o), {m}));
}

nb::tuple keypoint_groups_py(const BearingsIn& f1, const BearingsIn& f2) {
  const Points P = points_of(f1, f2);
  KeypointConflicts K;
  {
    nb::gil_scoped_release release;
    K = keypoint_conflicts(P);
  }
  auto ints = [](const std::vector<int>& v) {
    std::vector<int64_t> o(v.begin(), v.end());
    const size_t m = o.size();
    return to_numpy_t<int64_t>(std::move(o), {m});
  };
  return nb::make_tuple(ints(K.start), ints(K.members), ints(K.corr));
}

nb::tuple relpose_lo(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double threshold,
                     double lo_mu0, int lo_iterations, int lo_residual, int lo, int lo_max_points) {
  if (lo_max_points < 0) throw std::invalid_argument("lo_max_points must be >= 0");
  if (!(threshold > 0.0 && std::isfinite(threshold))) throw std::invalid_argument("threshold must be finite and > 0");
  const Points P = points_of(f1, f2);
  const Pose p = pose_of(R, t);
  RelativePoseEstimator::Options eo;
  eo.solver = MinimalSolver::LiRP6;
  eo.lo_threshold = threshold;
  eo.lo_mu0 = lo_mu0;
  eo.lo_iterations = lo_iterations;
  eo.lo_residual = lo_residual_of(lo_residual);
  eo.lo = local_opt_of(lo);
  eo.lo_max_points = lo_max_points;
  Pose c[RelativePoseEstimator::kLoCandidates];
  int k;
  {
    GilRelease release(10.0 * P.n);  // ~0.35 ms at n = 1000: about ten passes
    RelativePoseEstimator est(P, eo);
    std::vector<int> inl;
    const PoseTerms T(p);
    for (int i = 0; i < P.n; ++i)
      if (sampson_chiral(T, P.a(i), P.b(i)) < std::min(threshold, 0.5)) inl.push_back(i);
    k = est.local_candidates(p, inl, threshold, c);
  }
  std::vector<double> Rs(9 * k), ts(3 * k);
  for (int i = 0; i < k; ++i) put_pose(c[i], Rs.data() + 9 * i, ts.data() + 3 * i);
  const size_t n = static_cast<size_t>(k);
  return nb::make_tuple(to_numpy(std::move(Rs), {n, 3, 3}), to_numpy(std::move(ts), {n, 3}));
}

// The ML stage's options from the binding's arguments, checked (ml_refine and ml_cross_fit).
MlOptions ml_options(double range, int rounds, int lm_iterations, double pose_tol, bool student, bool band_start, std::optional<double> nu,
                     std::optional<double> alpha, bool pose_only, std::optional<double> sigma_init, std::optional<double> g_init,
                     double noise_floor) {
  if (!(range > 0.0 && std::isfinite(range))) throw std::invalid_argument("range must be finite and > 0");
  if (!(noise_floor >= 0.0) || !std::isfinite(noise_floor)) throw std::invalid_argument("noise_floor must be finite and >= 0");
  MlOptions mo;
  mo.sigma_floor = std::max(mo.sigma_floor, noise_floor);  // the coordinates' rounding: EM's scale not below it
  mo.range = range;
  mo.rounds = rounds;
  mo.lm_iterations = lm_iterations;
  mo.pose_tol = pose_tol;
  mo.student = student;
  mo.band_start = band_start;
  mo.pose_only = pose_only;
  if (sigma_init.has_value() != g_init.has_value()) throw std::invalid_argument("sigma_init and g_init are given together or not at all");
  if (sigma_init) {
    if (!(*sigma_init > 0.0 && std::isfinite(*sigma_init))) throw std::invalid_argument("sigma_init must be finite and > 0");
    if (!(*g_init > 0.0 && *g_init < 1.0)) throw std::invalid_argument("g_init must be in (0, 1)");
    mo.sigma_init = *sigma_init, mo.g_init = *g_init;
  }
  if (nu.has_value() != alpha.has_value()) throw std::invalid_argument("nu and alpha are given together or not at all");
  if (nu) {
    if (!(*nu >= 1.0)) throw std::invalid_argument("nu must be >= 1 (inf: Gaussian)");
    if (!(*alpha == 0.0 || *alpha == 0.5 || *alpha == 1.0)) throw std::invalid_argument("alpha must be 0, 0.5 or 1");
    if (std::isfinite(*nu) && !student) throw std::invalid_argument("a finite nu needs student=True");
    mo.fixed_tails = true, mo.nu = *nu, mo.alpha = *alpha;
  }
  return mo;
}

const double* ml_scales(const std::optional<VectorIn>& scales, int n) {
  const double* sc = weights_of(scales, n);
  if (sc)
    for (int i = 0; i < n; ++i)
      if (!(std::isfinite(sc[i]) && sc[i] > 0.0)) throw std::invalid_argument("scales must be finite and > 0");
  return sc;
}

nb::dict ml_refine_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double range, int rounds,
                      int lm_iterations, double pose_tol, bool student, const std::optional<VectorIn>& scales, bool band_start,
                      std::optional<double> nu, std::optional<double> alpha, bool pose_only,
                      std::optional<double> sigma_init, std::optional<double> g_init, double noise_floor) {
  const Points P = points_of(f1, f2);
  if (!(range > 0.0 && std::isfinite(range))) throw std::invalid_argument("range must be finite and > 0");
  const double* sc = ml_scales(scales, P.n);
  const MlOptions mo = ml_options(range, rounds, lm_iterations, pose_tol, student, band_start, nu, alpha, pose_only, sigma_init, g_init, noise_floor);
  MlResult r;
  {
    nb::gil_scoped_release release;
    ml_refine(P, pose_of(R, t), mo, &r, sc);
  }
  auto [Ro, to] = pose_arrays(r.pose);
  nb::dict d;
  d["R"] = Ro;
  d["t"] = to;
  d["sigma"] = r.sigma;
  d["nu"] = r.nu;
  d["alpha"] = r.alpha;
  d["sigma_gauss"] = r.sigma_gauss;
  d["sigma_start"] = r.sigma_start;
  d["inlier_fraction"] = r.inlier_fraction;
  d["decision"] = r.decision;
  d["decision_gauss"] = r.decision_gauss;
  d["rounds"] = r.rounds;
  d["log_likelihood"] = r.log_likelihood;
  d["posterior"] = to_numpy(std::move(r.posterior), {static_cast<size_t>(P.n)});
  return d;
}

// (R, t, vetoed, ok, veto (n,) uint8): the cross-fit (ml_refine.h ml_cross_fit); R, t are the input pose when nothing is vetoed
nb::tuple ml_cross_fit_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double range, double decision,
                          int folds, int min_agree, bool student, const std::optional<VectorIn>& scales, std::optional<double> nu,
                          std::optional<double> alpha, std::optional<double> sigma_init, std::optional<double> g_init, int fold_rounds,
                          int fold_lm_iterations, double fold_pose_tol, int final_rounds, int final_lm_iterations, double final_pose_tol,
                          double noise_floor) {
  const Points P = points_of(f1, f2);
  if (folds < 2) throw std::invalid_argument("folds must be >= 2");
  if (!(decision >= 0.0)) throw std::invalid_argument("decision must be >= 0");
  const double* sc = ml_scales(scales, P.n);
  CrossFitOptions co;
  co.folds = folds;
  co.decision = decision;
  co.min_agree = min_agree;
  co.fold = ml_options(range, fold_rounds, fold_lm_iterations, fold_pose_tol, student, false, nu, alpha, true, sigma_init, g_init, noise_floor);
  co.final = ml_options(range, final_rounds, final_lm_iterations, final_pose_tol, student, false, nu, alpha, true, sigma_init, g_init, noise_floor);
  Pose out;
  int vetoed = 0;
  bool ok;
  std::vector<uint8_t> veto;
  {
    nb::gil_scoped_release release;
    ok = ml_cross_fit(P, pose_of(R, t), co, sc, &out, &vetoed, &veto);
  }
  const size_t n = static_cast<size_t>(P.n);
  if (veto.size() != n) veto.assign(n, 0);
  auto [Ro, to] = pose_arrays(out);
  return nb::make_tuple(Ro, to, vetoed, ok, to_numpy_t<uint8_t>(std::move(veto), {n}));
}

nb::tuple gnc_ransac(const BearingsIn& f1, const BearingsIn& f2, double theta, uint64_t seed, int sample_size,
                     int max_iterations, bool adaptive, double confidence, const nb::dict& gnc, bool check_signals,
                     const CancelFlag* cancel) {
  const Points P = points_of(f1, f2);
  if (!(theta > 0.0 && std::isfinite(theta))) throw std::invalid_argument("theta must be finite and > 0");
  if (sample_size < kLirpMinPoints || sample_size > P.n) throw std::invalid_argument("sample_size must be in [6, n]");
  const GncOptions g = gnc_options_from(gnc);
  RansacOptions ro = ransac_options(max_iterations, adaptive ? 0 : max_iterations, confidence, adaptive, 0);
  Pose best;
  RansacStats st;
  std::vector<double> weights(P.n, 0.0);
  PythonSignals signals;
  watch_interrupts(&ro, &signals, check_signals, cancel);
  {
    nb::gil_scoped_release release;
    GncRansacEstimator est(P, sample_size, g);
    UniformSampler s(P.n, sample_size, seed);
    const CountScorer sc{theta};
    st = ransac(est, sc, s, ro, &best);
    // Algorithm 3, last step: the best model's inlier set refit by GNC-IRLS (not after an interruption,
    // whose result the caller never sees)
    std::vector<int> inl;
    if (!st.interrupted) inliers_of(est, best, sc, &inl);
    if (static_cast<int>(inl.size()) >= kLirpMinPoints && est.refine(&best, inl))
      for (size_t j = 0; j < inl.size(); ++j) weights[inl[j]] = est.last().weights[j];
  }
  end_if_interrupted(&signals, st, cancel);
  std::vector<double> R(9), t(3);
  put_pose(best, R.data(), t.data());
  return nb::make_tuple(to_numpy(std::move(R), {3, 3}), to_numpy(std::move(t), {3}), to_numpy(std::move(weights), {static_cast<size_t>(P.n)}),
                        stats_dict(st));
}

nb::tuple robust_rotation(const BearingsIn& f1, const BearingsIn& f2, double chord, uint64_t seed, int max_iterations, double confidence,
                          int max_score_points, double min_inlier_ratio) {
  const Points P = points_of(f1, f2);
  if (!(chord > 0.0 && std::isfinite(chord))) throw std::invalid_argument("chord threshold must be finite and > 0");
  if (P.n < 2) throw std::invalid_argument("at least 2 points are needed");
  if (max_score_points < 0) throw std::invalid_argument("max_score_points must be >= 0 (0: all)");
  RansacOptions ro = ransac_options(max_iterations, 0, confidence, true, 1);
  ro.min_inlier_ratio = checked_min_inlier_ratio(min_inlier_ratio);
  Mat3 best = Mat3::Identity();
  RansacStats st;
  std::vector<uint8_t> mask(P.n, 0);
  {
    GilRelease release(3.0 * P.n);  // ~0.1 ms at n = 1000
    const CountScorer sc{chord * chord};  // the estimator's residual is the squared chord
    // hypotheses are sampled and scored on a seeded random subset of at most max_score_points
    // matches (the inlier ratio, hence the samples needed, is that of all matches); the Kabsch
    // refinement below uses every match
    PointBuffer sub;
    Points Ps = P;
    if (max_score_points > 0 && P.n > std::max(max_score_points, 2)) {
      std::vector<int> idx(P.n);
      std::iota(idx.begin(), idx.end(), 0);
      Rng rng(seed ^ 0x9e3779b97f4a7c15ULL);
      for (int i = 0; i < max_score_points; ++i) std::swap(idx[i], idx[i + rng.below(P.n - i)]);  // partial Fisher-Yates
      std::sort(idx.begin(), idx.begin() + max_score_points);
      for (int i = 0; i < max_score_points; ++i) sub.push(P.f1 + 3 * idx[i], P.f2 + 3 * idx[i]);
      Ps = sub.view();
    }
    {
      RotationEstimator es(Ps);
      UniformSampler s(Ps.n, 2, seed);
      st = ransac(es, sc, s, ro, &best);
    }
    // Kabsch on the inliers among all matches, twice, each kept only if the inliers do not drop
    RotationEstimator est(P);
    std::vector<int> inl, inl2;
    inliers_of(est, best, sc, &inl);
    for (int k = 0; k < 2 && inl.size() >= 3; ++k) {
      Mat3 R = best;
      if (!est.refine(&R, inl)) break;
      inliers_of(est, R, sc, &inl2);
      if (inl2.size() < inl.size()) break;
      best = R;
      inl.swap(inl2);
    }
    for (int i : inl) mask[i] = 1;
  }
  std::vector<double> R(9);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R[3 * i + j] = best(i, j);
  return nb::make_tuple(to_numpy(std::move(R), {3, 3}), to_numpy_t<uint8_t>(std::move(mask), {static_cast<size_t>(P.n)}),
                        st.iterations + 2);
}

nb::tuple ransac_line(const nb::ndarray<const double, nb::ndim<2>, nb::c_contig>& xy, double threshold, uint64_t seed,
                      int max_iterations, double confidence, int max_lo, int scoring, int challengers, double challenger_distance,
                      double min_inlier_ratio) {
  if (xy.shape(1) != 2) throw std::invalid_argument("points must have shape (n, 2)");
  const int n = static_cast<int>(xy.shape(0));
  if (n < 2) throw std::invalid_argument("at least 2 points are needed");
  if (challengers < 0 || challengers > 64) throw std::invalid_argument("challengers must be in [0, 64]");
  if (!(challenger_distance > 0.0 && std::isfinite(challenger_distance))) throw std::invalid_argument("challenger_distance must be finite and > 0");
  RansacOptions ro = ransac_options(max_iterations, 0, confidence, true, max_lo);
  ro.challengers = challengers;
  ro.challenger_distance = challenger_distance;
  ro.min_inlier_ratio = checked_min_inlier_ratio(min_inlier_ratio);
  Line best;
  RansacStats st;
  {
    nb::gil_scoped_release release;
    LineEstimator est(xy.data(), n);
    st = run_sampled(est, static_cast<Scoring>(scoring), threshold, {}, seed, ro, &best);
  }
  return nb::make_tuple(nb::make_tuple(best.a, best.b, best.c), stats_dict(st));
}

// A Python estimator (poseonly.robust.generic: generate / residuals / refine / distance) under the
// same ransac<> as the core's estimators: models are Python objects, so the loop holds the GIL.
class PyEstimator {
 public:
  using Model = nb::object;
  using Terms = std::vector<double>;
  PyEstimator(nb::object est, int sample_size, int n, bool has_refine, bool has_distance)
      : est_(std::move(est)), s_(sample_size), n_(n), refine_(has_refine), distance_(has_distance) {}
  int sample_size() const { return s_; }
  int num_data() const { return n_; }
  Terms terms(const Model& m) const {
    const auto r = nb::cast<VectorIn>(est_.attr("residuals")(m));  // the adapter's checked float64 (n,)
    if (static_cast<int>(r.shape(0)) != n_) throw std::invalid_argument("residuals must have shape (num_data,)");
    return Terms(r.data(), r.data() + n_);
  }
  double residual(const Terms& t, int i) const { return t[i]; }
  double success_probability(double r) const { return std::pow(r, s_); }
  double distance(const Model& p, const Model& q) const { return distance_ ? nb::cast<double>(est_.attr("distance")(p, q)) : 0.0; }
  void generate(const std::vector<int>& s, std::vector<Model>* models) {
    std::vector<int64_t> idx(s.begin(), s.end());
    const nb::object out = est_.attr("generate")(to_numpy_t<int64_t>(std::move(idx), {s.size()}));
    for (nb::handle m : out) models->push_back(nb::borrow(m));
  }
  bool refine(Model* m, const std::vector<int>& inl) {
    if (!refine_) return false;
    std::vector<int64_t> idx(inl.begin(), inl.end());
    nb::object r = est_.attr("refine")(*m, to_numpy_t<int64_t>(std::move(idx), {inl.size()}));
    if (r.is_none()) return false;
    *m = std::move(r);
    return true;
  }

 private:
  nb::object est_;
  int s_, n_;
  bool refine_, distance_;
};

nb::tuple ransac_python(nb::object est, int sample_size, int n, bool has_refine, bool has_distance, double threshold, uint64_t seed,
                        int max_iterations, int min_iterations, double confidence, int max_lo, int scoring, int challengers,
                        double challenger_distance, const std::optional<nb::ndarray<const int64_t, nb::ndim<1>, nb::c_contig>>& order) {
  if (sample_size < 1 || n < sample_size) throw std::invalid_argument("need 1 <= sample_size <= num_data");
  if (challengers < 0 || challengers > 64) throw std::invalid_argument("challengers must be in [0, 64]");
  if (challengers > 0 && !has_distance) throw std::invalid_argument("challengers need the estimator's distance()");
  RansacOptions ro = ransac_options(max_iterations, min_iterations, confidence, true, max_lo);
  ro.challengers = challengers;
  ro.challenger_distance = challenger_distance;
  PyEstimator pe(std::move(est), sample_size, n, has_refine, has_distance);
  nb::object best;
  const RansacStats st = run_sampled(pe, static_cast<Scoring>(scoring), threshold, order_of(order, n), seed, ro, &best);
  return nb::make_tuple(best.is_valid() ? best : nb::none(), stats_dict(st));
}

}  // namespace
}  // namespace poseonly

POSEONLY_BIND(robust) {
  using namespace poseonly;
  using Order = std::optional<nb::ndarray<const int64_t, nb::ndim<1>, nb::c_contig>>;
  nb::class_<CancelFlag>(m, "CancelFlag", "a flag that ends the searches given it (ransac_relpose's `cancel`) within 64 draws of set()")
      .def(nb::init<>())
      .def("set", [](CancelFlag& f) { f.value.store(true, std::memory_order_relaxed); })
      .def("is_set", [](const CancelFlag& f) { return f.value.load(std::memory_order_relaxed); });
  nb::exception<SearchCancelled>(m, "SearchCancelled");
  m.def("ransac_relpose", &ransac_relpose, nb::arg("f1"), nb::arg("f2"), nb::arg("threshold"), nb::arg("seed"), nb::arg("solver") = 0,
        nb::arg("scoring") = 1, nb::arg("max_iterations") = 100000, nb::arg("min_iterations") = 50, nb::arg("confidence") = 0.999,
        nb::arg("max_lo") = 8, nb::arg("lo_mu0") = 1e3, nb::arg("lo_iterations") = 10, nb::arg("lo_residual") = 1,
        nb::arg("order") = Order(), nb::arg("lo") = 0, nb::arg("rival_distance") = 0.0, nb::arg("chiral") = false, nb::arg("min_hits") = 1,
        nb::arg("challengers") = 0, nb::arg("challenger_distance") = 1.0, nb::arg("lo_max_points") = 0, nb::arg("keypoint_once") = false,
        nb::arg("progressive_stop") = false, nb::arg("floor_parallax") = 0.0, nb::arg("min_iterations_parallax") = 0,
        nb::arg("progressive_expected") = false, nb::arg("progressive_min_draws") = 0, nb::arg("prosac_trials") = 0,
        nb::arg("min_inlier_ratio") = 0.0, nb::arg("check_signals") = false, nb::arg("cancel").none() = nb::none(),
        "LO-RANSAC of minimal hypotheses (check_signals: run Python's signal handlers every 64 draws and raise their "
        "exception, for a call from the main thread; cancel: a CancelFlag read every 64 draws, in any thread, whose set() "
        "ends the search with SearchCancelled) (solver 0: 5-point, 1: LiRP on 6 points) on bearings (n, 3) with the "
        "Sampson error against `threshold` (radians); scoring 0 msac, 1 multi-scale msac, 2 count; `order` "
        "(a permutation, best match first) switches to PROSAC; lo 0: LiRP GNC-IRLS, 1: Sampson LM; chiral: a match "
        "whose point is behind either camera scores as an outlier; rival_distance > 0 (degrees) also returns the best model that far "
        "from the result (rival_R, rival_t, rival_cost in stats); min_hits: adaptive stopping waits for that many all-inlier samples at `confidence`; challengers in [0, 64]: the best "
        "models of that many other basins (challenger_distance degrees apart) are locally optimised after the loop and replace the result "
        "if they beat it (num_challenger_lo, challenger_won in stats; those that lost: others_R (k, 3, 3), others_t (k, 3), others_cost (k,)); lo_max_points > 0: each LO runs on an evenly strided subset of at most that many of its window's points; keypoint_once (with chiral): "
        "of the matches that share a keypoint (identical bearings) only the best correspondence scores and is an inlier (conflicts.h; "
        "keypoint_groups in stats); progressive_stop (with order): also stop by PROSAC's rule (ransac.h progressive_needed; not before progressive_min_draws draws), or with progressive_expected where the "
        "expected all-inlier draws of the sampler's schedule reach the confidence (ransac.h expected_needed); floor_parallax > 0 (radians): while the best model's "
        "inliers have a median parallax of at least that, the sample floor is min(min_iterations, min_iterations_parallax); min_inlier_ratio > 0: "
        "adaptive stopping assumes at least that inlier share (the search ends once a model with that much support would have been drawn). Returns (R, t, stats).");
  m.def("search_cost", &search_cost, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("threshold"), nb::arg("scoring") = 1,
        nb::arg("keypoint_once") = true,
        "The cheirality-aware search objective at one pose (scoring 0 msac, 1 multi-scale msac, 2 count; keypoint_once: "
        "the matches of a shared keypoint scored once): (exact cost, inlier indices).");
  m.def("keypoint_groups", &keypoint_groups_py, nb::arg("f1"), nb::arg("f2"),
        "The groups of matches sharing a keypoint (identical bearings in one view) among two or more distinct correspondences "
        "(conflicts.h): (start, members, corr); group g = members[start[g]:start[g + 1]], corr[i] = match i's correspondence id.");
  m.def("relpose_lo", &relpose_lo, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("threshold"),
        nb::arg("lo_mu0") = 1e3, nb::arg("lo_iterations") = 10, nb::arg("lo_residual") = 1, nb::arg("lo") = 0, nb::arg("lo_max_points") = 0,
        "The default method's LO step at `threshold` from the pose's cheirality-consistent inliers: its candidate poses "
        "(R (k, 3, 3), t (k, 3)); k = 0 where it failed, 2 for a two-stage LO whose second stage ran and gave a finite pose (first stage first).");
  m.def("ml_refine", &ml_refine_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("range"),
        nb::arg("rounds") = 6, nb::arg("lm_iterations") = 10, nb::arg("pose_tol") = 0.0, nb::arg("student") = true,
        nb::arg("scales") = nb::none(), nb::arg("band_start") = false, nb::arg("nu") = nb::none(), nb::arg("alpha") = nb::none(),
        nb::arg("pose_only") = false, nb::arg("sigma_init") = nb::none(), nb::arg("g_init") = nb::none(), nb::arg("noise_floor") = 0.0,
        "ML pose under a mixture of Student-t inlier (`student`: nu chosen by the data, inf included; else Gaussian) and uniform outlier Sampson errors "
        "(EM + weighted Sampson LM; outlier range `range`, radians; at most `rounds` rounds, ending early when a round moves the pose "
        "by at most `pose_tol`; `scales` (n,) > 0: relative noise scales, a match's inlier scale sigma (scale_i / median)^alpha, "
        "alpha in {0, 1/2, 1} chosen with nu; `nu`, `alpha` given together: that inlier model, not chosen): dict R, t, sigma, nu, alpha, sigma_gauss, sigma_start, inlier_fraction, decision, decision_gauss (the Gaussian mixture's at the pose), rounds, log_likelihood, posterior (n,). band_start: EM starts from the least-squares Sampson refit of the matches within min(range, 3 s0) of (R, t), s0 = 1.4826 median of the errors below range / 2. pose_only: R, t and rounds only are computed, the pose the same (sigma, nu, alpha, inlier_fraction, posterior: the last E-step's, before the last pose step; sigma_gauss, decision, decision_gauss, log_likelihood: NaN). sigma_init, g_init (together): EM's first E-step starts from this scale and inlier share instead of the start's (with fixed tails; a tails choice restarts EM from the start's). noise_floor (radians): EM's scale not below it (the coordinates' rounding).");
  m.def("ml_cross_fit", &ml_cross_fit_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("range"), nb::arg("decision"),
        nb::arg("folds") = 5, nb::arg("min_agree") = 15, nb::arg("student") = true, nb::arg("scales") = nb::none(), nb::arg("nu") = nb::none(),
        nb::arg("alpha") = nb::none(), nb::arg("sigma_init") = nb::none(), nb::arg("g_init") = nb::none(), nb::arg("fold_rounds"),
        nb::arg("fold_lm_iterations"), nb::arg("fold_pose_tol"), nb::arg("final_rounds"), nb::arg("final_lm_iterations"), nb::arg("final_pose_tol"),
        nb::arg("noise_floor") = 0.0,
        "The default's cross-fitted inliers: match i in fold i % folds is classified by the ML pose (ml_refine, pose_only, EM from (R, t)) of "
        "the other folds (an inlier where its Sampson error is below `decision`); the pose's own inliers the other folds reject are vetoed "
        "and EM from (R, t) runs on every other match. (R, t, vetoed, ok, veto (n,) uint8 the vetoed matches): ok False when a fold's EM failed or fewer than min_agree matches are "
        "inliers of both; with no veto the input pose.");
  m.def("gnc_ransac", &gnc_ransac, nb::arg("f1"), nb::arg("f2"), nb::arg("theta"), nb::arg("seed"), nb::arg("sample_size") = 30,
        nb::arg("max_iterations") = 50, nb::arg("adaptive") = false, nb::arg("confidence") = 0.99, nb::arg("gnc") = nb::dict(),
        nb::arg("check_signals") = false, nb::arg("cancel").none() = nb::none(),
        "The paper's GNC-RANSAC (Alg. 3): (R, t, weights (n,), stats); check_signals and cancel as ransac_relpose's (every 64 samples).");
  m.def("robust_rotation", &robust_rotation, nb::arg("f1"), nb::arg("f2"), nb::arg("chord"), nb::arg("seed"),
        nb::arg("max_iterations") = 10000, nb::arg("confidence") = 0.999, nb::arg("max_score_points") = 0,
        nb::arg("min_inlier_ratio") = 0.0,
        "Rotation-only model by 2-point RANSAC (inliers |R f1 - f2| < chord; hypotheses scored on a seeded subset of "
        "max_score_points matches, 0: all; the stopping rule assumes an inlier ratio of at least min_inlier_ratio) "
        "and Kabsch on the inliers among all matches: (R, inlier mask (n,), hypotheses tested).");
  m.def("ransac_line", &ransac_line, nb::arg("xy"), nb::arg("threshold"), nb::arg("seed"), nb::arg("max_iterations") = 1000,
        nb::arg("confidence") = 0.999, nb::arg("max_lo") = 8, nb::arg("scoring") = 0, nb::arg("challengers") = 0,
        nb::arg("challenger_distance") = 1.0, nb::arg("min_inlier_ratio") = 0.0,
        "The generic loop on a 2-D line estimator (tests): ((a, b, c), stats).");
  m.def("ransac_python", &ransac_python, nb::arg("estimator"), nb::arg("sample_size"), nb::arg("num_data"), nb::arg("has_refine"),
        nb::arg("has_distance"), nb::arg("threshold"), nb::arg("seed"), nb::arg("max_iterations"), nb::arg("min_iterations"),
        nb::arg("confidence"), nb::arg("max_lo"), nb::arg("scoring"), nb::arg("challengers"), nb::arg("challenger_distance"),
        nb::arg("order").none(),
        "The generic loop on a Python estimator (poseonly.robust.generic.ransac's adapter; the GIL is held): (best model or None, stats).");
}
