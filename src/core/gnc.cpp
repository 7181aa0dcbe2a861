// GNC-IRLS (Algorithm 2); see gnc.h. Per iteration k:
//  1. R, t = weighted LiRP with w^(k) (its PPO-best candidate, or with all_candidates the valid
//     candidate minimising sum_i w_i v_i);
//  2. v = residuals of all points;  3. c = noise_bound, or c_factor * max(sigma, floor) with
//     sigma = 1.4826 median|v| (Alg. 2 as printed) or 1.4826 MAD (the paper's text);
//  4. TLS weights;  5. eps = sum w v, converged when |eps - eps_prev| <= eps0 |eps|;
//  6. mu: Peng's superlinear update (MS-TLS) or x1.4 (GNC-TLS).
// Limit-cycle exit: with an adaptive c the binary weight vectors often cycle (periods 2-5); once
// W_{k+1} = W_{k+1-p} with every weight vector binary since, later iterations repeat with period p,
// so the remaining stopping tests are evaluated on the stored cycle and the loop ends where the
// full loop would, with the same outputs (tests compare with the reference loop).
#include "gnc.h"

#include <algorithm>

#include "lirp.h"

namespace poseonly {
namespace {

double median_of(std::vector<double>& a) {
  const size_t n = a.size();
  const size_t k = n / 2;
  std::nth_element(a.begin(), a.begin() + k, a.end());
  const double hi = a[k];
  if (n % 2) return hi;
  const double lo = *std::max_element(a.begin(), a.begin() + k);
  return 0.5 * (lo + hi);
}

double noise_bound(const std::vector<double>& vf, const GncOptions& o, std::vector<double>* scratch) {
  if (o.noise_bound > 0.0) return o.noise_bound;
  double s;
  if (o.scale == Scale::Fixed) {
    s = o.scale_value;
  } else {
    scratch->assign(vf.begin(), vf.end());
    for (double& x : *scratch) x = std::abs(x);
    const double med = median_of(*scratch);
    if (o.scale == Scale::Median) {
      s = kMadToSigma * med;
    } else {
      scratch->assign(vf.begin(), vf.end());
      for (double& x : *scratch) x = std::abs(std::abs(x) - med);
      s = kMadToSigma * median_of(*scratch);
    }
  }
  return o.c_factor * std::max(s, o.sigma_floor);
}

double initial_mu(const std::vector<double>& vf, double c, Schedule schedule) {
  double vmax2 = 0.0;
  for (double x : vf) vmax2 = std::max(vmax2, x * x);
  const double r = vmax2 / std::max(c * c, kTiny);
  if (schedule == Schedule::MsTls) {
    const double mu = 1.0 / (5.0 * r - 1.0);
    return (std::isfinite(mu) && mu > 1e-6) ? mu : 1e-6;
  }
  const double mu = 1.0 / (2.0 * r - 1.0);
  return (std::isfinite(mu) && mu > 0.0) ? mu : kMuCap;  // all inside the bound: TLS = LS
}

double update_mu(double mu, const GncOptions& o) {
  const double nm = (o.schedule == Schedule::MsTls && mu < 1.0) ? o.mu_factor * std::sqrt(mu) : o.mu_factor * mu;
  return std::min(nm, kMuCap);
}

Pose solve(const Points& P, const double* w, const GncOptions& o, LirpResult* lr) {
  lirp(P, w, false, lr);
  if (!o.all_candidates) return lr->id[lr->best].pose;
  bool any_valid = false;
  for (const auto& c : lr->id) any_valid |= c.valid;
  int pick = lr->best;
  double best = kInf;
  for (int k = 0; k < kLirpCandidates; ++k) {
    if (any_valid && !lr->id[k].valid) continue;
    const PoseTerms pt(lr->id[k].pose);
    double s = 0.0;
    for (int i = 0; i < P.n; ++i) {
      const double wi = w ? w[i] : 1.0;
      if (wi != 0.0) s += wi * residual(o.residual, pt, P.a(i), P.b(i));
    }
    if (std::isfinite(s) && s < best) {
      best = s;
      pick = k;
    }
  }
  return lr->id[pick].pose;
}

struct Slot {
  Pose pose;
  std::vector<double> v;
  double c = 0.0, eps = 0.0;
};

}  // namespace

double tls_weight(double v, double c, double mu, Schedule schedule) {
  v = std::abs(v);
  if (schedule == Schedule::MsTls) {
    if (v <= c) return 1.0;
    if (v >= (mu + 1.0) / mu * c) return 0.0;
    return (mu + 1.0) * c / std::max(v, kTiny) - mu;
  }
  const double v2 = v * v, c2 = c * c;
  if (v2 <= mu / (mu + 1.0) * c2) return 1.0;
  if (v2 >= (mu + 1.0) / mu * c2) return 0.0;
  return std::sqrt(c2 * mu * (mu + 1.0) / std::max(v2, kTiny)) - mu;
}

void gnc_irls(const Points& P, const double* w0, const GncOptions& o, GncResult* out) {
  const int n = P.n;
  std::vector<double> w(n, 1.0);
  if (w0) std::copy(w0, w0 + n, w.begin());
  const int Pmax = std::max(o.cycle_period, 0);
  const int S = Pmax + 1;
  std::vector<Slot> H(Pmax ? S : 0);
  std::vector<std::vector<double>> HW(Pmax ? S : 0);
  if (Pmax) HW[0] = w;
  int nb_last = -1;  // last iteration whose new weights were not all 0 or 1
  const int K = o.max_iterations - 1;
  std::vector<double> v(n), vf(n), wn(n), scratch;
  double mu = 0.0, eps_prev = kInf;
  LirpResult lr;
  out->converged = false;
  out->interrupted = false;
  for (int k = 0; k < o.max_iterations; ++k) {
    if (k > 0 && o.interrupted && o.interrupted()) {
      out->interrupted = true;
      break;
    }
    const Pose pose = solve(P, w.data(), o, &lr);
    const PoseTerms pt(pose);
    for (int i = 0; i < n; ++i) {
      const double x = residual(o.residual, pt, P.a(i), P.b(i));
      const bool fin = std::isfinite(x);
      v[i] = fin ? x : kInf;
      vf[i] = fin ? x : 0.0;
    }
    const double c = noise_bound(vf, o, &scratch);
    const double mu_a = k == 0 ? (o.mu0 > 0.0 ? o.mu0 : initial_mu(vf, c, o.schedule)) : mu;
    double eps = 0.0;
    int nonzero = 0;
    bool binary = true;
    for (int i = 0; i < n; ++i) {
      wn[i] = tls_weight(v[i], c, mu_a, o.schedule);
      eps += wn[i] * vf[i];
      nonzero += wn[i] > 0.0;
      binary &= (wn[i] == 0.0 || wn[i] == 1.0);
    }
    const bool done = std::abs(eps - eps_prev) <= o.eps0 * std::max(std::abs(eps), kTiny);
    const bool starving = nonzero < o.min_sample;
    if (!starving) w = wn;
    out->pose = pose;
    out->residuals = v;
    out->c = c;
    out->iterations = k + 1;
    out->converged = out->converged || done;
    eps_prev = eps;
    mu = update_mu(mu_a, o);
    if (done || starving) break;
    if (!Pmax) continue;
    Slot& sl = H[k % S];
    sl.pose = pose;
    sl.v = v;
    sl.c = c;
    sl.eps = eps;
    HW[(k + 1) % S] = w;
    if (!binary) nb_last = k;
    if (k >= K || nb_last >= k || !(mu >= mu_a)) continue;
    // W_{k+1} = W_{k+1-p} with binary weights since: the iterations repeat with period p
    int period = 0;
    for (int p = 1; p <= std::min(Pmax, k + 1); ++p) {
      if (nb_last < k + 1 - p && HW[(k + 1 - p) % S] == w) {
        period = p;
        break;
      }
    }
    if (!period) continue;
    const int base = k + 1 - period;
    int jf = K;
    bool conv = false;
    for (int m = 1; m <= Pmax; ++m) {
      const int j = k + m;
      if (m > period || j > K) break;
      const double e_cur = H[(base + (j - base) % period) % S].eps;
      const double e_prev = H[(base + (j - 1 - base) % period) % S].eps;
      if (std::abs(e_cur - e_prev) <= o.eps0 * std::max(std::abs(e_cur), kTiny)) {
        jf = j;
        conv = true;
        break;
      }
    }
    const int jmap = base + (jf - base) % period;
    const Slot& r = H[jmap % S];
    out->pose = r.pose;
    out->residuals = r.v;
    out->c = r.c;
    w = HW[(jmap + 1) % S];
    out->iterations = jf + 1;
    out->converged = conv;
    break;
  }
  out->weights = w;
}

}  // namespace poseonly
