// EM + weighted Sampson LM; see ml_refine.h.
#include "ml_refine.h"

#include <algorithm>
#include <cmath>

#include "refine.h"
#include "residuals.h"

namespace poseonly {
namespace {

constexpr double kSqrt2OverPi = 0.7978845608028654;
constexpr double kLogPi = 1.1447298858494002;
constexpr int kMinInliers = 6;
constexpr int kEmSteps = 50;          // EM steps on fixed residuals per round
constexpr double kEmTol = 1e-6;       // relative change of s (absolute of g) that ends them
constexpr int kBisections = 60;       // the decision residual's root find
// nu's profile likelihood on a grid (the pose is insensitive to nu within a grid step), the Gaussian
// (nu = inf) included: on Gaussian errors it wins and the stage is MLESAC's exactly
constexpr double kNuGrid[] = {INFINITY, 30.0, 10.0, 5.0, 3.0, 2.0, 1.5, 1.0};
constexpr int kNuRounds = 2;          // nu is chosen at the start pose and after the first pose step
constexpr int kNuSample = 512;        // ... on at most this many of the errors below T (evenly strided)
constexpr int kNuEmSteps = 30;        // EM steps per grid point (warm-started from the previous one)
constexpr double kNuEmTol = 1e-3;
// with per-match noise scales c_i (relative to their median), the inliers' scale is s c_i^alpha,
// alpha chosen with nu by the profile likelihood: 0 (the scales say nothing), 1/2, 1 (the noise
// proportional to the scale, as a keypoint's localisation error to its detection scale)
constexpr double kAlphaGrid[] = {0.0, 0.5, 1.0};
constexpr double kMaxScaleRatio = 32.0;  // relative scales are clamped to [1/32, 32] (pose-step weights
                                         // within 1e3 of the median's at alpha = 1; SIFT sizes span ~1-100x)

// rotation angle of R1 R0^T (radians), stable for small angles
double rotation_angle(const Mat3& R1, const Mat3& R0) {
  const Mat3 D = R1 * R0.transpose();
  const Vec3 w(D(2, 1) - D(1, 2), D(0, 2) - D(2, 0), D(1, 0) - D(0, 1));
  return std::atan2(0.5 * w.norm(), 0.5 * (D.trace() - 1.0));
}

void sampson_all(const Points& P, const Pose& pose, std::vector<double>* r) {
  const PoseTerms T(pose);
  r->resize(P.n);
  for (int i = 0; i < P.n; ++i) (*r)[i] = sampson(T.E, P.a(i), P.b(i));
}

// x^e for x in (0, 1] and e a multiple of 1/4 (integer powers and square roots; the grid's
// exponents (nu + 1) / 2 all are), else std::pow
double quarter_pow(double x, double e) {
  const double q = 4.0 * e;
  if (!(q == std::floor(q) && q >= 0.0 && q < 256.0)) return std::pow(x, e);
  int m = static_cast<int>(q) >> 2;
  const int f = static_cast<int>(q) & 3;
  double y = 1.0, b = x;
  for (; m; m >>= 1, b *= b)
    if (m & 1) y *= b;
  if (f) {
    const double h = std::sqrt(x), qq = std::sqrt(h);
    y *= f == 1 ? qq : f == 2 ? h : h * qq;
  }
  return y;
}

// The inlier density of |r|: half-t of scale s and nu dof (finite nu) or half-normal of scale s.
struct InlierModel {
  double s, nu, log_norm, norm;
  bool student() const { return std::isfinite(nu); }
  InlierModel(double s_, double nu_) : s(s_), nu(nu_) {
    log_norm = student() ? std::log(2.0) + std::lgamma(0.5 * (nu + 1.0)) - std::lgamma(0.5 * nu) - 0.5 * (std::log(nu) + kLogPi) - std::log(s)
                         : std::log(kSqrt2OverPi / s);
    norm = std::exp(log_norm);
  }
  // f(r), without a transcendental call for the t on the grid (the EM's inner loop)
  double density(double r) const {
    const double z2 = (r / s) * (r / s);
    return student() ? norm * quarter_pow(1.0 / (1.0 + z2 / nu), 0.5 * (nu + 1.0)) : norm * std::exp(-0.5 * z2);
  }
  double log_density(double r) const {
    const double z2 = (r / s) * (r / s);
    return student() ? log_norm - 0.5 * (nu + 1.0) * std::log1p(z2 / nu) : log_norm - 0.5 * z2;
  }
  // the t's latent precision (nu + 1) / (nu + z^2): the M-step's weight of an inlier (1: Gaussian)
  double precision(double r) const {
    const double z2 = (r / s) * (r / s);
    return student() ? (nu + 1.0) / (nu + z2) : 1.0;
  }
};

// The E-step's per-match terms on a block [i0, i0 + m) of the errors: the posterior
// pi = g q f(q r) / (g q f(q r) + (1 - g) / T) and pi w(q r) (q r)^2 with w the t's latent precision
// (1: Gaussian), f and w those of M; the same operations per match as M.density and M.precision
// (bit-identical), in loops over the block's matches so that they run on SIMD lanes (an AVX2 clone
// chosen at load time; no FMA). Matches at or beyond T get unused values (the caller skips them); the
// t's density is computed for them too (vectorised), the Gaussian's scalar exp only below T.
constexpr int kEmBlock = 64;

POSEONLY_SIMD_CLONES
void em_terms_block(const InlierModel& M, double g, double out_density, double Tr, const double* r, const double* q, int m, double* pi, double* term) {
  const double s = M.s, nu = M.nu, norm = M.norm;
  double z[kEmBlock], z2[kEmBlock], dens[kEmBlock];
  for (int i = 0; i < m; ++i) {
    const double qi = q ? q[i] : 1.0;
    z[i] = qi * r[i];
    z2[i] = (z[i] / s) * (z[i] / s);
  }
  if (M.student()) {
    // norm * quarter_pow(1 / (1 + z2 / nu), (nu + 1) / 2), its exponent the same for every match
    const double e = 0.5 * (nu + 1.0);
    double x[kEmBlock];
    for (int i = 0; i < m; ++i) x[i] = 1.0 / (1.0 + z2[i] / nu);
    const double qe = 4.0 * e;
    if (!(qe == std::floor(qe) && qe >= 0.0 && qe < 256.0)) {
      for (int i = 0; i < m; ++i) dens[i] = norm * std::pow(x[i], e);
    } else {
      const int f = static_cast<int>(qe) & 3;
      double y[kEmBlock], b[kEmBlock];
      for (int i = 0; i < m; ++i) y[i] = 1.0, b[i] = x[i];
      for (int k = static_cast<int>(qe) >> 2; k; k >>= 1) {
        if (k & 1)
          for (int i = 0; i < m; ++i) y[i] *= b[i];
        for (int i = 0; i < m; ++i) b[i] *= b[i];
      }
      if (f)
        for (int i = 0; i < m; ++i) {
          const double h = std::sqrt(x[i]), hh = std::sqrt(h);
          y[i] *= f == 1 ? hh : f == 2 ? h : h * hh;
        }
      for (int i = 0; i < m; ++i) dens[i] = norm * y[i];
    }
  } else {
    for (int i = 0; i < m; ++i) dens[i] = r[i] < Tr ? norm * std::exp(-0.5 * z2[i]) : 0.0;  // exp is scalar: only where used
  }
  for (int i = 0; i < m; ++i) {
    const double qi = q ? q[i] : 1.0;
    const double lin = g * qi * dens[i];
    pi[i] = lin / (lin + out_density);
    const double prec = M.student() ? (nu + 1.0) / (nu + z2[i]) : 1.0;
    term[i] = pi[i] * prec * z[i] * z[i];
  }
}

// Regularised incomplete beta I_x(a, b) (Numerical Recipes' betacf continued fraction, Lentz's method).
double incomplete_beta(double a, double b, double x) {
  if (!(x > 0.0)) return 0.0;
  if (!(x < 1.0)) return 1.0;
  const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x));
  const bool flip = x > (a + 1.0) / (a + b + 2.0);
  const double aa = flip ? b : a, bb = flip ? a : b, xx = flip ? 1.0 - x : x;
  constexpr double tiny = 1e-300, eps = 1e-14;
  double c = 1.0, d = 1.0 - (aa + bb) * xx / (aa + 1.0);
  d = 1.0 / (std::abs(d) < tiny ? tiny : d);
  double h = d;
  for (int m = 1; m <= 200; ++m) {
    const int m2 = 2 * m;
    double num = m * (bb - m) * xx / ((aa + m2 - 1.0) * (aa + m2));
    d = 1.0 + num * d, c = 1.0 + num / c;
    d = 1.0 / (std::abs(d) < tiny ? tiny : d), c = std::abs(c) < tiny ? tiny : c;
    h *= d * c;
    num = -(aa + m) * (aa + bb + m) * xx / ((aa + m2) * (aa + m2 + 1.0));
    d = 1.0 + num * d, c = 1.0 + num / c;
    d = 1.0 / (std::abs(d) < tiny ? tiny : d), c = std::abs(c) < tiny ? tiny : c;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < eps) break;
  }
  const double fr = front / aa * h;  // I_x(a, b) = fr, or 1 - fr with the roles of a, b and x, 1 - x swapped
  return flip ? 1.0 - fr : fr;
}

// P(r >= x) for an inlier's error r (the half-normal or half-t of M)
double inlier_survival(const InlierModel& M, double x) {
  const double z = x / M.s;
  if (!M.student()) return std::erfc(z / std::sqrt(2.0));
  return incomplete_beta(0.5 * M.nu, 0.5, M.nu / (M.nu + z * z));
}

// kBandQuantiles evenly spaced quantiles of the inverse noise scales q of the matches below T: the
// inliers' tail of band_g_max averaged over them (an inlier's error r_i has P(r_i >= x) = S(q_i x))
constexpr int kBandQuantiles = 5;

// The largest inlier share g of the nT matches below T that the matches just outside the band allow:
// a wrong match's Sampson error has a flat density near 0, so the `near` matches in [T, 2T), less the
// inliers' own expected tail there (sp P(T <= r < 2T) / P(r < T), sp the expected inliers below T;
// averaged over the quantiles qk of the inverse noise scales, none: q = 1), say that about b as many of
// the matches below T are outliers: g <= 1 - b / nT. Without it the EM's g goes to 1 whenever the band
// itself shows no outlier density, the p = 1/2 decision then moves to the band's edge, and outliers the
// pose has bent towards pass the cross-fit's veto (sim_hard's second motion: 2.5 px decisions at 0.29 px
// noise). Wrong matches that cluster just outside the band (a second motion, a repeated structure)
// would make that bound collapse g (to the point where EM stops), so it is softened to the share with
// the b matches counted as extra outliers, sp / (nT + b), where it is the lower: g stays within
// [sp / (nT + b), sp / nT].
double band_g_max(const InlierModel& M, double Tr, int nT, double near, double sp, const std::vector<double>& qk) {
  if (nT <= 0 || near <= 0) return 1.0 - 1e-9;
  double ratio = 0.0;
  const int m = qk.empty() ? 1 : static_cast<int>(qk.size());
  for (int k = 0; k < m; ++k) {
    const double qi = qk.empty() ? 1.0 : qk[k];
    const double s1 = inlier_survival(M, qi * Tr), s2 = inlier_survival(M, 2.0 * qi * Tr), below = 1.0 - s1;
    ratio += below > 0.0 ? (s1 - s2) / below : 0.0;
  }
  const double b = std::max(near - sp * ratio / m, 0.0);
  return std::clamp(std::max(1.0 - b / nT, sp / (nT + b)), 1e-6, 1.0 - 1e-9);
}

// the matches in [T, 2T)
int near_band(const std::vector<double>& r, double Tr) {
  int near = 0;
  for (double x : r) near += x >= Tr && x < 2.0 * Tr;
  return near;
}

// The mixture's scale s and inlier share g at fixed nu on fixed errors r (EM from the given s, g, at
// most `steps` steps, until s moves by at most tol relative and g by tol): false when fewer than
// kMinInliers expected inliers remain. `p` (optional) gets the posteriors at the result.
// q (optional, as r): per-match inverse noise scales, the inlier density of r_i being q_i f(q_i r_i).
// near: the matches in [T, 2T) of the full error set, scaled to r's if r is a subsample (band_g_max).
bool fit_scale(const std::vector<double>& r, const std::vector<double>* q, double Tr, double nu, double floor, int steps, double tol,
               double* s, double* g, std::vector<double>* p, double near) {
  const int n = static_cast<int>(r.size());
  int nT = 0;  // the matches below T (fixed errors)
  for (int i = 0; i < n; ++i) nT += r[i] < Tr;
  std::vector<double> qk;  // quantiles of the inverse noise scales below T (band_g_max)
  if (q && near > 0.0 && nT > 0) {
    std::vector<double> qs;
    qs.reserve(nT);
    for (int i = 0; i < n; ++i)
      if (r[i] < Tr) qs.push_back((*q)[i]);
    size_t from = 0;  // the quantiles in increasing order, each selection on the part above the previous one
    for (int k = 0; k < kBandQuantiles; ++k) {
      const size_t at = std::max(from, static_cast<size_t>((k + 0.5) / kBandQuantiles * qs.size()));
      std::nth_element(qs.begin() + static_cast<std::ptrdiff_t>(from), qs.begin() + static_cast<std::ptrdiff_t>(at), qs.end());
      qk.push_back(qs[at]);
      from = at + 1 < qs.size() ? at + 1 : at;
    }
  }
  double pib[kEmBlock], tb[kEmBlock];
  for (int e = 0; e < steps; ++e) {
    const InlierModel M(*s, nu);
    const double out_density = (1.0 - *g) / Tr;
    double sp = 0.0, spur2 = 0.0;
    for (int i0 = 0; i0 < n; i0 += kEmBlock) {
      const int m = std::min(kEmBlock, n - i0);
      em_terms_block(M, *g, out_density, Tr, r.data() + i0, q ? q->data() + i0 : nullptr, m, pib, tb);
      for (int k = 0; k < m; ++k) {
        if (!(r[i0 + k] < Tr)) continue;
        sp += pib[k];
        spur2 += tb[k];
      }
    }
    if (sp < kMinInliers) return false;
    const double s0 = *s, g0 = *g;
    *s = std::clamp(std::sqrt(spur2 / sp), floor, Tr);
    *g = std::clamp(sp / std::max(nT, 1), 1e-6, band_g_max(M, Tr, nT, near, sp, qk));
    if (std::abs(*s - s0) <= tol * s0 && std::abs(*g - g0) <= tol) break;
  }
  if (p) {
    const InlierModel M(*s, nu);
    const double out_density = (1.0 - *g) / Tr;
    p->resize(r.size());
    for (int i0 = 0; i0 < n; i0 += kEmBlock) {
      const int m = std::min(kEmBlock, n - i0);
      em_terms_block(M, *g, out_density, Tr, r.data() + i0, q ? q->data() + i0 : nullptr, m, pib, tb);
      for (int k = 0; k < m; ++k) (*p)[i0 + k] = r[i0 + k] < Tr ? pib[k] : 0.0;
    }
  }
  return true;
}

// observed log-likelihood of the errors (a match at or beyond T counts at T's density)
double log_likelihood(const std::vector<double>& r, const std::vector<double>* q, double Tr, double nu, double s, double g) {
  const InlierModel M(s, nu);
  const double out_density = (1.0 - g) / Tr;
  double ll = 0.0;
  for (size_t i = 0; i < r.size(); ++i) {
    const double qi = q ? (*q)[i] : 1.0;
    ll += std::log(g * qi * M.density(qi * std::min(r[i], Tr)) + out_density);
  }
  return ll;
}

// q_i = c_i^-alpha for the relative scales c (alpha on kAlphaGrid)
void inverse_scales(const std::vector<double>& c, double alpha, std::vector<double>* q) {
  q->resize(c.size());
  for (size_t i = 0; i < c.size(); ++i) (*q)[i] = alpha == 0.0 ? 1.0 : alpha == 1.0 ? 1.0 / c[i] : 1.0 / std::sqrt(c[i]);
}

// (nu, alpha) maximising the profile likelihood max_{s, g} L(s, g, nu, alpha) over kNuGrid (only
// inf when !student) x kAlphaGrid (only 0 without scales c) on an even subsample of the errors below
// T (per alpha, the first grid point's EM starts from the given s, g, each next one from the previous
// one's fit)
void select_tails(const std::vector<double>& r, const std::vector<double>& c, bool student, double Tr, double floor, double s, double g,
                  double* nu_out, double* alpha_out) {
  std::vector<double> sub, csub, q;
  int nT = 0;
  for (double x : r) nT += x < Tr;
  const int near_all = near_band(r, Tr);  // from all the errors (the subsample holds only those below T)
  const int stride = std::max(1, (nT + kNuSample - 1) / kNuSample);
  int k = 0;
  for (size_t i = 0; i < r.size(); ++i)
    if (r[i] < Tr && k++ % stride == 0) {
      sub.push_back(r[i]);
      if (!c.empty()) csub.push_back(c[i]);
    }
  const double near_sub = nT > 0 ? near_all * static_cast<double>(sub.size()) / nT : 0.0;  // scaled to the subsample
  double best_ll = -INFINITY;
  *nu_out = INFINITY, *alpha_out = 0.0;
  for (double alpha : kAlphaGrid) {
    if (alpha != 0.0 && c.empty()) break;
    inverse_scales(csub, alpha, &q);
    const std::vector<double>* qp = c.empty() ? nullptr : &q;
    double sv = s, gv = g;
    for (double nu : kNuGrid) {
      if (!student && std::isfinite(nu)) continue;
      if (!fit_scale(sub, qp, Tr, nu, floor, kNuEmSteps, kNuEmTol, &sv, &gv, nullptr, near_sub)) {
        sv = s, gv = g;
        continue;
      }
      const double ll = log_likelihood(sub, qp, Tr, nu, sv, gv);
      if (ll > best_ll) best_ll = ll, *nu_out = nu, *alpha_out = alpha;
    }
  }
}

// the residual where the posterior is 1/2: g f(r) = (1 - g) / T (f decreases in r; 0 when no r < T
// qualifies, T when all do)
double decision(const InlierModel& M, double g, double Tr) {
  const double level = std::log((1.0 - g) / Tr / g);
  if (!(M.log_density(0.0) > level)) return 0.0;
  if (!(M.log_density(Tr) < level)) return Tr;
  if (!M.student()) return M.s * std::sqrt(2.0 * (M.log_norm - level));  // closed form
  double lo = 0.0, hi = Tr;
  for (int b = 0; b < kBisections; ++b) {
    const double mid = 0.5 * (lo + hi);
    (M.log_density(mid) > level ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

// the band refit of MlOptions::band_start: LM on the plain Sampson least squares, to convergence
constexpr int kBandIterations = 100;
constexpr double kBandTol = 1e-14;
// ... on the matches within this many noise scales (EM's start scale: 1.4826 median of the errors
// below T / 2) of the given pose, at most T: the kernel is wide against the noise, not against the
// outlier range (real SIFT noise is ~0.3 px at T = 3 px, where the whole range holds structured outliers)
constexpr double kBandSigmas = 3.0;

void ml_refine(const Points& P, const Pose& start, const MlOptions& opt, MlResult* out, const double* scales) {
  const double Tr = opt.range;
  out->pose = start;
  std::vector<double> r, p(P.n, 0.0);
  sampson_all(P, out->pose, &r);
  if (opt.band_start) {
    std::vector<double> half;
    for (double x : r)
      if (x < 0.5 * Tr) half.push_back(x);
    double width = Tr;
    if (!half.empty()) {
      std::nth_element(half.begin(), half.begin() + half.size() / 2, half.end());
      width = std::min(Tr, kBandSigmas * std::max(1.4826 * half[half.size() / 2], opt.sigma_floor));
    }
    PointBuffer band;
    for (int i = 0; i < P.n; ++i)
      if (r[i] < width) band.push(P.f1 + 3 * i, P.f2 + 3 * i);
    if (band.view().n >= kMinInliers) {
      RefineOptions ro;
      ro.loss = RefineLoss::Linear;
      ro.loss_scale = 1.0;
      ro.max_iterations = kBandIterations;
      ro.tol = kBandTol;
      Pose b = out->pose;
      b.t.normalize();
      refine_sampson(band.view(), nullptr, ro, &b);
      if (b.R.allFinite() && b.t.allFinite()) {
        out->pose = b;
        sampson_all(P, out->pose, &r);
      }
    }
  }
  // start: s from the median of the errors within half the range, g from their share
  std::vector<double> in;
  for (double x : r)
    if (x < 0.5 * Tr) in.push_back(x);
  if (static_cast<int>(in.size()) < kMinInliers) {
    out->sigma = 0.0;
    out->inlier_fraction = 0.0;
    out->posterior.assign(P.n, 0.0);
    return;
  }
  // the relative noise scales c_i = scale_i / median (empty without scales)
  std::vector<double> c;
  if (scales) {
    c.assign(scales, scales + P.n);
    std::vector<double> tmp;
    for (double x : c)
      if (std::isfinite(x) && x > 0.0) tmp.push_back(x);
    if (tmp.empty()) tmp.push_back(1.0);
    const size_t h = tmp.size() / 2;
    std::nth_element(tmp.begin(), tmp.begin() + h, tmp.end());
    double med = tmp[h];
    if (tmp.size() % 2 == 0) med = 0.5 * (med + *std::max_element(tmp.begin(), tmp.begin() + h));  // numpy's median
    for (double& x : c) x = (std::isfinite(x) && x > 0.0 && med > 0.0) ? std::clamp(x / med, 1.0 / kMaxScaleRatio, kMaxScaleRatio) : 1.0;
  }
  std::nth_element(in.begin(), in.begin() + in.size() / 2, in.end());
  const double sigma0 = std::max(1.4826 * in[in.size() / 2], opt.sigma_floor);
  const double g0 = std::min(static_cast<double>(in.size()) / P.n, 0.99);
  out->sigma_start = sigma0;
  const bool warm = opt.sigma_init > 0.0 && opt.g_init > 0.0 && opt.g_init < 1.0;
  double sigma = warm ? std::max(opt.sigma_init, opt.sigma_floor) : sigma0, g = warm ? opt.g_init : g0, nu = INFINITY, alpha = 0.0;
  std::vector<double> q;  // inverse noise scales c_i^-alpha (empty: all 1)
  const std::vector<double>* qp = nullptr;
  if (opt.fixed_tails) {
    nu = opt.nu, alpha = c.empty() ? 0.0 : opt.alpha;
    if (alpha != 0.0) inverse_scales(c, alpha, &q), qp = &q;
  }
  std::vector<double> v;  // the pose step's weights
  for (int k = 0; k < opt.rounds; ++k) {
    if (!opt.fixed_tails && (opt.student || !c.empty()) && k < kNuRounds) {
      const double alpha_before = alpha;
      select_tails(r, c, opt.student, Tr, opt.sigma_floor, sigma0, g0, &nu, &alpha);
      // the EM restarts from its start after a choice (as the t always did); the Gaussian without
      // the scales (alpha = 0 again) carries on as the stage without scales does
      if (opt.student || alpha != alpha_before) sigma = sigma0, g = g0;
      qp = nullptr;
      if (alpha != 0.0) inverse_scales(c, alpha, &q), qp = &q;
    }
    // E: the mixture's parameters to convergence on the current errors, then the posteriors
    if (!fit_scale(r, qp, Tr, nu, opt.sigma_floor, kEmSteps, kEmTol, &sigma, &g, &p, near_band(r, Tr))) break;
    // M: the pose maximising sum p_i log f(q_i r_i): weighted least squares with weights p_i q_i^2
    // (Gaussian) or, for the t, the Cauchy loss of scale sqrt(nu) s on q_i r_i with the posteriors as
    // outer weights (its IRLS weights are the t's precisions, recomputed at every LM step)
    RefineOptions ro;
    ro.max_iterations = opt.lm_iterations;
    ro.tol = 1e-10;
    const double* w = p.data();
    if (std::isfinite(nu)) {
      ro.loss = RefineLoss::Cauchy;
      ro.loss_scale = std::sqrt(nu) * sigma;
      ro.weights_outside = true;
      if (qp) {
        v.resize(P.n);
        for (int i = 0; i < P.n; ++i) v[i] = q[i] * q[i];
        ro.residual_weights = v.data();
      }
    } else {
      ro.loss = RefineLoss::Linear;
      if (qp) {
        v.resize(P.n);
        for (int i = 0; i < P.n; ++i) v[i] = p[i] * q[i] * q[i];
        w = v.data();
      }
    }
    Pose next = out->pose;
    refine_sampson(P, w, ro, &next);
    if (!(next.R.allFinite() && next.t.allFinite())) break;
    const double moved = std::max(rotation_angle(next.R, out->pose.R), (next.t - out->pose.t).norm());
    out->pose = next;
    out->rounds = k + 1;
    sampson_all(P, out->pose, &r);
    // a fixed point of the EM: the next round would repeat this one (its nu choice included: the
    // errors did not move)
    if (moved <= opt.pose_tol) break;
  }
  if (opt.pose_only) {
    // the last E-step's parameters; the statistics at the returned pose were not computed
    out->sigma = sigma, out->nu = nu, out->alpha = alpha, out->inlier_fraction = g;
    out->sigma_gauss = out->decision = out->decision_gauss = out->log_likelihood = NAN;
    out->posterior = p;
    return;
  }
  // the t's parameters at the returned pose (warm-started; the Gaussian stage reports those of its
  // last E-step, as before)
  if (std::isfinite(nu) || qp) {
    double sv = sigma, gv = g;
    if (fit_scale(r, qp, Tr, nu, opt.sigma_floor, kEmSteps, kEmTol, &sv, &gv, nullptr, near_band(r, Tr))) sigma = sv, g = gv;
  }
  // final posteriors at the returned pose
  const InlierModel M(sigma, nu);
  const double out_density = (1.0 - g) / Tr;
  out->log_likelihood = log_likelihood(r, qp, Tr, nu, sigma, g);
  for (int i = 0; i < P.n; ++i) {
    const double qi = qp ? q[i] : 1.0;
    const double lin = r[i] < Tr ? g * qi * M.density(qi * r[i]) : 0.0;
    p[i] = r[i] < Tr ? lin / (lin + out_density) : 0.0;
  }
  out->sigma = sigma;
  out->nu = nu;
  out->alpha = alpha;
  out->inlier_fraction = g;
  out->decision = decision(M, g, Tr);
  if (M.student() || qp) {
    double sg = sigma0, gg = g0;
    const bool fitted = fit_scale(r, nullptr, Tr, INFINITY, opt.sigma_floor, kEmSteps, kEmTol, &sg, &gg, nullptr, near_band(r, Tr));
    out->decision_gauss = fitted ? decision(InlierModel(sg, INFINITY), gg, Tr) : 0.0;
    out->sigma_gauss = fitted ? sg : 0.0;
  } else {
    out->decision_gauss = out->decision;
    out->sigma_gauss = sigma;
  }
  out->posterior = p;
}

namespace {

// A pose's Sampson inliers below `decision` as poseonly.residuals.v_sampson computes the errors: t divided
// by its norm sqrt(t0 t0 + t1 t1 + t2 t2) first (the Python call's normalisation, in the same order).
PoseTerms unit_terms(const Pose& p) {
  Pose q = p;
  const double tn = std::sqrt(p.t(0) * p.t(0) + p.t(1) * p.t(1) + p.t(2) * p.t(2));
  if (tn > 0.0) q.t = p.t / tn;
  return PoseTerms(q);
}

bool ml_ok(const MlResult& m) { return m.rounds > 0 && m.pose.R.allFinite() && m.pose.t.allFinite(); }

}  // namespace

bool ml_cross_fit(const Points& P, const Pose& pose, const CrossFitOptions& opt, const double* scales, Pose* out, int* vetoed,
                  std::vector<uint8_t>* veto_out) {
  const int n = P.n, folds = opt.folds;
  *vetoed = 0;
  if (folds < 2 || n < folds) return false;
  std::vector<char> held(n, 0);
  PointBuffer sub;
  std::vector<double> sc;
  for (int j = 0; j < folds; ++j) {
    sub.clear();
    sc.clear();
    for (int i = 0; i < n; ++i) {
      if (i % folds == j) continue;
      sub.push(P.f1 + 3 * i, P.f2 + 3 * i);
      if (scales) sc.push_back(scales[i]);
    }
    MlResult m;
    ml_refine(sub.view(), pose, opt.fold, &m, scales ? sc.data() : nullptr);
    if (!ml_ok(m)) return false;
    const PoseTerms T = unit_terms(m.pose);
    for (int i = j; i < n; i += folds) held[i] = residual(Residual::Sampson, T, P.a(i), P.b(i)) < opt.decision;
  }
  const PoseTerms T0 = unit_terms(pose);
  std::vector<char> veto(n, 0);
  int agree = 0;
  for (int i = 0; i < n; ++i) {
    const bool own = residual(Residual::Sampson, T0, P.a(i), P.b(i)) < opt.decision;
    agree += own && held[i];
    veto[i] = own && !held[i];
    *vetoed += veto[i];
  }
  if (agree < opt.min_agree) {
    *vetoed = 0;
    return false;
  }
  if (veto_out) veto_out->assign(veto.begin(), veto.end());
  if (*vetoed == 0) {
    *out = pose;
    return true;
  }
  sub.clear();
  sc.clear();
  for (int i = 0; i < n; ++i) {
    if (veto[i]) continue;
    sub.push(P.f1 + 3 * i, P.f2 + 3 * i);
    if (scales) sc.push_back(scales[i]);
  }
  MlResult m;
  ml_refine(sub.view(), pose, opt.final, &m, scales ? sc.data() : nullptr);
  if (!ml_ok(m)) return false;
  *out = m.pose;
  return true;
}

}  // namespace poseonly
