// Bindings of LiRP (Algorithm 1) and GNC-IRLS (Algorithm 2): single problems and stacked batches,
// the GIL released around the numeric work.
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>

#include "arrays.h"
#include "bearings.h"
#include "gnc.h"
#include "lirp.h"
#include "register.h"
#include "signals.h"

namespace poseonly {
namespace {

// (h, n, 3) stacked problems -> the i-th problem's points
struct Stack {
  const double* f1;
  const double* f2;
  const double* w;
  size_t h, n;
  Points at(size_t i) const { return Points{f1 + 3 * n * i, f2 + 3 * n * i, static_cast<int>(n)}; }
  const double* w_at(size_t i) const { return w ? w + n * i : nullptr; }
};

Stack stack_of(const ArrayIn& f1, const ArrayIn& f2, const std::optional<ArrayIn>& w) {
  if (f1.ndim() != 3 || f2.ndim() != 3 || f1.shape(2) != 3 || f2.shape(2) != 3)
    throw std::invalid_argument("stacked bearings must have shape (h, n, 3)");
  if (f1.shape(0) != f2.shape(0) || f1.shape(1) != f2.shape(1)) throw std::invalid_argument("f1 and f2 must have the same shape");
  if (w && (w->ndim() != 2 || w->shape(0) != f1.shape(0) || w->shape(1) != f1.shape(1)))
    throw std::invalid_argument("stacked weights must have shape (h, n)");
  return Stack{f1.data(), f2.data(), w ? w->data() : nullptr, f1.shape(0), f1.shape(1)};
}

nb::dict lirp_batch(const ArrayIn& f1, const ArrayIn& f2, const std::optional<ArrayIn>& w, bool all_costs) {
  const Stack S = stack_of(f1, f2, w);
  const size_t h = S.h, K = kLirpCandidates;
  std::vector<double> E(h * K * 9), R(h * K * 9), t(h * K * 3), M1(h * K), cost(h * K), sv(h * 9), dm(h), dm2(h), Rb(h * 9), tb(h * 3), Eb(h * 9);
  std::vector<uint8_t> valid(h * K);
  std::vector<int64_t> best(h);
  {
    nb::gil_scoped_release release;
    LirpResult r;
    for (size_t i = 0; i < h; ++i) {
      lirp(S.at(i), S.w_at(i), all_costs, &r);
      for (size_t k = 0; k < K; ++k) {
        const size_t o = i * K + k;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) E[9 * o + 3 * a + b] = r.cand.E[k](a, b);
        put_pose(r.id[k].pose, &R[9 * o], &t[3 * o]);
        valid[o] = r.id[k].valid;
        M1[o] = r.id[k].M1;
        cost[o] = r.id[k].cost;
      }
      for (int a = 0; a < 9; ++a) sv[9 * i + a] = r.cand.singular_values(a);
      dm[i] = r.cand.d_min;
      dm2[i] = r.cand.d_min_C2;
      best[i] = r.best;
      put_pose(r.id[r.best].pose, &Rb[9 * i], &tb[3 * i]);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Eb[9 * i + 3 * a + b] = r.cand.E[r.best](a, b);
    }
  }
  nb::dict d;
  d["cand_E"] = to_numpy(std::move(E), {h, K, 3, 3});
  d["cand_R"] = to_numpy(std::move(R), {h, K, 3, 3});
  d["cand_t"] = to_numpy(std::move(t), {h, K, 3});
  d["cand_valid"] = to_numpy_t<uint8_t>(std::move(valid), {h, K});
  d["cand_M1"] = to_numpy(std::move(M1), {h, K});
  d["cand_cost"] = to_numpy(std::move(cost), {h, K});
  d["singular_values"] = to_numpy(std::move(sv), {h, 9});
  d["d_min"] = to_numpy(std::move(dm), {h});
  d["d_min_C2"] = to_numpy(std::move(dm2), {h});
  d["best"] = to_numpy_t<int64_t>(std::move(best), {h});
  d["R"] = to_numpy(std::move(Rb), {h, 3, 3});
  d["t"] = to_numpy(std::move(tb), {h, 3});
  d["E"] = to_numpy(std::move(Eb), {h, 3, 3});
  return d;
}

// One problem for the public solver: (cand_E (18, 3, 3), cand_R (18, 3, 3), cand_t (18, 3), cand_valid
// (18,) bool, cand_cost (18,), singular_values (9,), best, d_min, d_min_C2, rank, R (3, 3), t (3,),
// E (3, 3)), R, t the best candidate's pose and E = [t]x R. The float arrays are views of one buffer
// with one owner (a call allocates once), the rank counts singular values above rank_tol *
// max(sigma_1, 1e-300) as poseonly.solvers.lirp documents.
nb::tuple lirp_tuple(const Points& P, const double* wp, bool all_costs, double rank_tol) {
  constexpr size_t K = kLirpCandidates, oE = 0, oR = 9 * K, oT = 18 * K, oC = 21 * K, oS = 22 * K, oBR = 22 * K + 9, oBT = oBR + 9,
                   oBE = oBT + 3, total = oBE + 9;
  auto* buf = new std::vector<double>(total);
  nb::capsule owner(buf, [](void* p) noexcept { delete static_cast<std::vector<double>*>(p); });
  auto* vb = new std::vector<uint8_t>(K);
  nb::capsule vowner(vb, [](void* p) noexcept { delete static_cast<std::vector<uint8_t>*>(p); });
  LirpResult r;
  int rank = 0;
  {
    nb::gil_scoped_release release;
    lirp(P, wp, all_costs, &r);
    double* d = buf->data();
    for (size_t k = 0; k < K; ++k) {
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) d[oE + 9 * k + 3 * a + b] = r.cand.E[k](a, b);
      put_pose(r.id[k].pose, d + oR + 9 * k, d + oT + 3 * k);
      d[oC + k] = r.id[k].cost;
      (*vb)[k] = r.id[k].valid;
    }
    const Vec9& s = r.cand.singular_values;
    const double cut = rank_tol * std::max(s(0), 1e-300);
    for (int a = 0; a < 9; ++a) {
      d[oS + a] = s(a);
      rank += s(a) > cut;
    }
    const Pose& best = r.id[r.best].pose;
    put_pose(best, d + oBR, d + oBT);
    const Mat3 E = essential(best);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) d[oBE + 3 * a + b] = E(a, b);
  }
  double* d = buf->data();
  const size_t sh_m[3] = {K, 3, 3}, sh_t[2] = {K, 3}, sh_k[1] = {K}, sh_s[1] = {9}, sh_3x3[2] = {3, 3}, sh_3[1] = {3};
  return nb::make_tuple(NpArray(d + oE, 3, sh_m, owner), NpArray(d + oR, 3, sh_m, owner), NpArray(d + oT, 2, sh_t, owner),
                        NpBool(reinterpret_cast<bool*>(vb->data()), 1, sh_k, vowner), NpArray(d + oC, 1, sh_k, owner),
                        NpArray(d + oS, 1, sh_s, owner), r.best, r.cand.d_min, r.cand.d_min_C2, rank,
                        NpArray(d + oBR, 2, sh_3x3, owner), NpArray(d + oBT, 1, sh_3, owner), NpArray(d + oBE, 2, sh_3x3, owner));
}

nb::tuple lirp_one(const BearingsIn& f1, const BearingsIn& f2, const std::optional<VectorIn>& w, bool all_costs, double rank_tol) {
  const Points P = points_of(f1, f2);
  return lirp_tuple(P, weights_of(w, P.n), all_costs, rank_tol);
}

// The public poseonly.lirp in one call, for the common input: f1, f2 (n, 3) rows of any finite length
// (scaled to unit bearings by unit_rows_into, as poseonly.geometry._unit_rows), w (n,) or None, every
// candidate's cost. Returns None wherever the checked Python path has something to say, so that its
// messages stay the only ones: a NaN / inf or zero row, rows that all end in exactly 1 (the
// homogeneous-pixel check), a negative or non-finite weight, fewer than min_points rows. Weights are
// divided by their largest as poseonly.solvers.lirp.lirp_checked does. Else lirp_one's tuple.
nb::object lirp_bearings(const BearingsIn& f1, const BearingsIn& f2, const std::optional<VectorIn>& w, double rank_tol, double zero,
                         int min_points) {
  if (f1.shape(1) != 3 || f2.shape(1) != 3 || f1.shape(0) != f2.shape(0)) return nb::none();
  const size_t n = f1.shape(0);
  if (n < static_cast<size_t>(std::max(min_points, 1))) return nb::none();
  if (w && w->shape(0) != n) return nb::none();
  std::vector<double> b(6 * n), wn;
  bool ok = true;
  {
    nb::gil_scoped_release release;
    int64_t zeros1 = 0, bad1 = 0, zeros2 = 0, bad2 = 0;
    unit_rows_into(f1.data(), n, zero, b.data(), &zeros1, &bad1);
    unit_rows_into(f2.data(), n, zero, b.data() + 3 * n, &zeros2, &bad2);
    ok = !(zeros1 || bad1 || zeros2 || bad2);
    bool hom1 = true, hom2 = true;
    for (size_t i = 0; i < n; ++i) {
      hom1 = hom1 && f1.data()[3 * i + 2] == 1.0;
      hom2 = hom2 && f2.data()[3 * i + 2] == 1.0;
    }
    ok = ok && !hom1 && !hom2;
    if (ok && w) {
      const double* wd = w->data();
      double wmax = 0.0;
      for (size_t i = 0; i < n && ok; ++i) {
        ok = std::isfinite(wd[i]) && wd[i] >= 0.0;
        wmax = std::max(wmax, wd[i]);
      }
      if (ok) {
        wn.assign(wd, wd + n);
        if (wmax > 0.0 && wmax != 1.0)
          for (double& x : wn) x = x / wmax;
      }
    }
  }
  if (!ok) return nb::none();
  const Points P{b.data(), b.data() + 3 * n, static_cast<int>(n)};
  return lirp_tuple(P, w ? wn.data() : nullptr, true, rank_tol);
}

nb::dict identify_batch(const ArrayIn& E, const BearingsIn& f1, const BearingsIn& f2, const std::optional<VectorIn>& w, bool with_cost) {
  const Points P = points_of(f1, f2);
  const double* wp = weights_of(w, P.n);
  if (E.size() % 9 != 0) throw std::invalid_argument("E must have shape (k, 3, 3)");
  const size_t k = E.size() / 9;
  std::vector<double> R(9 * k), t(3 * k), M1(k), cost(k);
  std::vector<uint8_t> valid(k);
  {
    nb::gil_scoped_release release;
    Identified id;
    for (size_t j = 0; j < k; ++j) {
      Mat3 Ej;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Ej(a, b) = E.data()[9 * j + 3 * a + b];
      identify(Ej, P, wp, with_cost ? CostMode::Always : CostMode::Never, &id);
      put_pose(id.pose, &R[9 * j], &t[3 * j]);
      valid[j] = id.valid;
      M1[j] = id.M1;
      cost[j] = id.cost;
    }
  }
  nb::dict d;
  d["R"] = to_numpy(std::move(R), {k, 3, 3});
  d["t"] = to_numpy(std::move(t), {k, 3});
  d["valid"] = to_numpy_t<uint8_t>(std::move(valid), {k});
  d["M1"] = to_numpy(std::move(M1), {k});
  d["cost"] = to_numpy(std::move(cost), {k});
  return d;
}

GncOptions gnc_options(const nb::dict& o) {
  GncOptions g;
  auto get = [&](const char* key, auto def) {
    using T = decltype(def);
    return o.contains(key) ? nb::cast<T>(o[key]) : def;
  };
  g.schedule = static_cast<Schedule>(get("schedule", 0));
  g.scale = static_cast<Scale>(get("scale", 0));
  g.scale_value = get("scale_value", 0.0);
  g.c_factor = get("c_factor", g.c_factor);
  g.noise_bound = get("noise_bound", 0.0);
  g.max_iterations = get("max_iterations", g.max_iterations);
  g.eps0 = get("eps0", g.eps0);
  g.sigma_floor = get("sigma_floor", g.sigma_floor);
  g.mu_factor = get("mu_factor", g.mu_factor);
  g.mu0 = get("mu0", 0.0);
  g.residual = static_cast<Residual>(get("residual", static_cast<int>(Residual::LiGT)));
  g.all_candidates = get("all_candidates", false);
  g.min_sample = get("min_sample", g.min_sample);
  g.cycle_period = get("cycle_period", g.cycle_period);
  if (g.max_iterations < 1) throw std::invalid_argument("max_iterations must be >= 1");
  if (static_cast<int>(g.residual) < 0 || static_cast<int>(g.residual) >= kNumResiduals) throw std::invalid_argument("unknown residual");
  return g;
}

nb::dict gnc_batch(const ArrayIn& f1, const ArrayIn& f2, const std::optional<ArrayIn>& w0, const nb::dict& opts, bool check_signals) {
  const Stack S = stack_of(f1, f2, w0);
  GncOptions g = gnc_options(opts);
  // Ctrl-C between iterations (a concurrency trial: 200k matches and 1000 iterations ran 8.6 s past it);
  // only from Python's main thread, where the handlers run (as the robust loops, bind_robust.cpp)
  PythonSignals signals;
  if (check_signals) g.interrupted = [&signals]() { return signals(); };
  const size_t h = S.h, n = S.n;
  std::vector<double> R(9 * h), t(3 * h), W(h * n), V(h * n), c(h);
  std::vector<int64_t> it(h);
  std::vector<uint8_t> conv(h);
  {
    nb::gil_scoped_release release;
    GncResult r;
    for (size_t i = 0; i < h; ++i) {
      gnc_irls(S.at(i), S.w_at(i), g, &r);
      put_pose(r.pose, &R[9 * i], &t[3 * i]);
      std::copy(r.weights.begin(), r.weights.end(), W.begin() + n * i);
      std::copy(r.residuals.begin(), r.residuals.end(), V.begin() + n * i);
      c[i] = r.c;
      it[i] = r.iterations;
      conv[i] = r.converged;
      if (r.interrupted) break;
    }
  }
  signals.rethrow();
  nb::dict d;
  d["R"] = to_numpy(std::move(R), {h, 3, 3});
  d["t"] = to_numpy(std::move(t), {h, 3});
  d["weights"] = to_numpy(std::move(W), {h, n});
  d["residuals"] = to_numpy(std::move(V), {h, n});
  d["c"] = to_numpy(std::move(c), {h});
  d["num_iterations"] = to_numpy_t<int64_t>(std::move(it), {h});
  d["converged"] = to_numpy_t<uint8_t>(std::move(conv), {h});
  return d;
}

}  // namespace

GncOptions gnc_options_from(const nb::dict& o) { return gnc_options(o); }

}  // namespace poseonly

POSEONLY_BIND(lirp) {
  using namespace poseonly;
  m.def(
      "epipolar_singular_values",
      [](const BearingsIn& f1, const BearingsIn& f2) {
        const Points P = points_of(f1, f2);
        Vec9 s;
        {
          GilRelease release(static_cast<double>(P.n));
          s = epipolar_singular_values(P);
        }
        std::vector<double> out(s.data(), s.data() + 9);
        return to_numpy(std::move(out), {9});
      },
      nb::arg("f1"), nb::arg("f2"),
      "Singular values (9,), descending, of the n x 9 epipolar matrix of bearings f1, f2 (n, 3) (zeros beyond n).");
  m.def("lirp_batch", &lirp_batch, nb::arg("f1"), nb::arg("f2"), nb::arg("w") = nb::none(), nb::arg("all_costs") = true,
        "LiRP (Alg. 1) on h stacked problems f1, f2 (h, n, 3), weights (h, n) or None: the 18 candidates "
        "(cand_E, cand_R, cand_t, cand_valid, cand_M1, cand_cost), the identified best (R, t, E, best), "
        "singular_values (h, 9), d_min, d_min_C2.");
  m.def("lirp_one", &lirp_one, nb::arg("f1"), nb::arg("f2"), nb::arg("w") = nb::none(), nb::arg("all_costs") = true,
        nb::arg("rank_tol") = 1e-9,
        "LiRP (Alg. 1) on one problem, bearings f1, f2 (n, 3), weights (n,) or None: (cand_E, cand_R, cand_t, "
        "cand_valid, cand_cost, singular_values, best, d_min, d_min_C2, rank, R, t, E): R, t the best candidate's pose, E = [t]x R.");
  m.def("lirp_bearings", &lirp_bearings, nb::arg("f1"), nb::arg("f2"), nb::arg("w").none(), nb::arg("rank_tol"), nb::arg("zero"),
        nb::arg("min_points"),
        "The public LiRP in one call on rows f1, f2 (n, 3) of any finite length (scaled to unit bearings) and weights (n,) or None: "
        "lirp_one's tuple with every cost, or None where the checked path must decide (a NaN / inf or zero row, rows all ending in 1, "
        "a negative or non-finite weight, fewer than min_points rows).");
  m.def("identify", &identify_batch, nb::arg("E"), nb::arg("f1"), nb::arg("f2"), nb::arg("w") = nb::none(),
        nb::arg("with_cost") = true,
        "Pose-only identification of k essential matrices E (k, 3, 3) on bearings (n, 3): R, t, valid, M1, cost.");
  m.def("gnc_irls_batch", &gnc_batch, nb::arg("f1"), nb::arg("f2"), nb::arg("w0") = nb::none(), nb::arg("options") = nb::dict(), nb::arg("check_signals") = false,
        "GNC-IRLS (Alg. 2) on h stacked problems (h, n, 3) with LiRP; options: schedule (0 ms-tls, 1 gnc-tls), "
        "scale (0 median, 1 mad, 2 fixed), scale_value, c_factor, noise_bound, max_iterations, eps0, sigma_floor, "
        "mu_factor, mu0, residual, all_candidates, min_sample, cycle_period; check_signals: run Python's signal handlers between "
        "iterations (from the main thread) and raise what they raise (KeyboardInterrupt).");
  m.attr("LIRP_CANDIDATES") = kLirpCandidates;
}
