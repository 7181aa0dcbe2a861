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

// The mixture's scale s and inlier share g at fixed nu on fixed errors r (EM from the given s, g, at
// most `steps` steps, until s moves by at most tol relative and g by tol): false when fewer than
// kMinInliers expected inliers remain. `p` (optional) gets the posteriors at the result.
bool fit_scale(const std::vector<double>& r, double Tr, double nu, double floor, int steps, double tol, double* s, double* g,
               std::vector<double>* p) {
  for (int e = 0; e < steps; ++e) {
    const InlierModel M(*s, nu);
    const double out_density = (1.0 - *g) / Tr;
    int nT = 0;
    double sp = 0.0, spur2 = 0.0;
    for (double x : r) {
      if (!(x < Tr)) continue;
      ++nT;
      const double lin = *g * M.density(x);
      const double pi = lin / (lin + out_density);
      sp += pi;
      spur2 += pi * M.precision(x) * x * x;
    }
    if (sp < kMinInliers) return false;
    const double s0 = *s, g0 = *g;
    *s = std::clamp(std::sqrt(spur2 / sp), floor, Tr);
    *g = std::clamp(sp / std::max(nT, 1), 1e-6, 1.0 - 1e-9);
    if (std::abs(*s - s0) <= tol * s0 && std::abs(*g - g0) <= tol) break;
  }
  if (p) {
    const InlierModel M(*s, nu);
    const double out_density = (1.0 - *g) / Tr;
    p->resize(r.size());
    for (size_t i = 0; i < r.size(); ++i) {
      const double lin = r[i] < Tr ? *g * M.density(r[i]) : 0.0;
      (*p)[i] = r[i] < Tr ? lin / (lin + out_density) : 0.0;
    }
  }
  return true;
}

// observed log-likelihood of the errors (a match at or beyond T counts at T's density)
double log_likelihood(const std::vector<double>& r, double Tr, double nu, double s, double g) {
  const InlierModel M(s, nu);
  const double out_density = (1.0 - g) / Tr;
  double ll = 0.0;
  for (double x : r) ll += std::log(g * M.density(std::min(x, Tr)) + out_density);
  return ll;
}

// nu maximising the profile likelihood max_{s, g} L(s, g, nu) over kNuGrid on an even subsample of
// the errors below T (the first grid point's EM starts from the given s, g, each next one from the
// previous one's fit)
double select_nu(const std::vector<double>& r, double Tr, double floor, double s, double g) {
  std::vector<double> sub;
  int nT = 0;
  for (double x : r) nT += x < Tr;
  const int stride = std::max(1, (nT + kNuSample - 1) / kNuSample);
  int k = 0;
  for (double x : r)
    if (x < Tr && k++ % stride == 0) sub.push_back(x);
  double best_nu = INFINITY, best_ll = -INFINITY;
  double sv = s, gv = g;
  for (double nu : kNuGrid) {
    if (!fit_scale(sub, Tr, nu, floor, kNuEmSteps, kNuEmTol, &sv, &gv, nullptr)) {
      sv = s, gv = g;
      continue;
    }
    const double ll = log_likelihood(sub, Tr, nu, sv, gv);
    if (ll > best_ll) best_ll = ll, best_nu = nu;
  }
  return best_nu;
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

void ml_refine(const Points& P, const Pose& start, const MlOptions& opt, MlResult* out) {
  const double Tr = opt.range;
  out->pose = start;
  std::vector<double> r, p(P.n, 0.0);
  sampson_all(P, out->pose, &r);
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
  std::nth_element(in.begin(), in.begin() + in.size() / 2, in.end());
  const double sigma0 = std::max(1.4826 * in[in.size() / 2], opt.sigma_floor);
  const double g0 = std::min(static_cast<double>(in.size()) / P.n, 0.99);
  out->sigma_start = sigma0;
  double sigma = sigma0, g = g0, nu = INFINITY;
  for (int k = 0; k < opt.rounds; ++k) {
    if (opt.student && k < kNuRounds) {
      nu = select_nu(r, Tr, opt.sigma_floor, sigma0, g0);
      sigma = sigma0, g = g0;
    }
    // E: the mixture's parameters to convergence on the current errors, then the posteriors
    if (!fit_scale(r, Tr, nu, opt.sigma_floor, kEmSteps, kEmTol, &sigma, &g, &p)) break;
    // M: the pose maximising sum p_i log f(r_i): weighted least squares (Gaussian) or, for the t,
    // the Cauchy loss of scale sqrt(nu) s with the posteriors as outer weights (its IRLS weights are
    // the t's precisions, recomputed at every LM step)
    RefineOptions ro;
    ro.max_iterations = opt.lm_iterations;
    ro.tol = 1e-10;
    if (std::isfinite(nu)) {
      ro.loss = RefineLoss::Cauchy;
      ro.loss_scale = std::sqrt(nu) * sigma;
      ro.weights_outside = true;
    } else {
      ro.loss = RefineLoss::Linear;
    }
    Pose next = out->pose;
    refine_sampson(P, p.data(), ro, &next);
    if (!(next.R.allFinite() && next.t.allFinite())) break;
    const double moved = std::max(rotation_angle(next.R, out->pose.R), (next.t - out->pose.t).norm());
    out->pose = next;
    out->rounds = k + 1;
    sampson_all(P, out->pose, &r);
    // a fixed point of the EM: the next round would repeat this one (its nu choice included: the
    // errors did not move)
    if (moved <= opt.pose_tol) break;
  }
  // the t's parameters at the returned pose (warm-started; the Gaussian stage reports those of its
  // last E-step, as before)
  if (std::isfinite(nu)) {
    double sv = sigma, gv = g;
    if (fit_scale(r, Tr, nu, opt.sigma_floor, kEmSteps, kEmTol, &sv, &gv, nullptr)) sigma = sv, g = gv;
  }
  // final posteriors at the returned pose
  const InlierModel M(sigma, nu);
  const double out_density = (1.0 - g) / Tr;
  out->log_likelihood = log_likelihood(r, Tr, nu, sigma, g);
  for (int i = 0; i < P.n; ++i) {
    const double lin = r[i] < Tr ? g * M.density(r[i]) : 0.0;
    p[i] = r[i] < Tr ? lin / (lin + out_density) : 0.0;
  }
  out->sigma = sigma;
  out->nu = nu;
  out->inlier_fraction = g;
  out->decision = decision(M, g, Tr);
  if (M.student()) {
    double sg = sigma0, gg = g0;
    const bool fitted = fit_scale(r, Tr, INFINITY, opt.sigma_floor, kEmSteps, kEmTol, &sg, &gg, nullptr);
    out->decision_gauss = fitted ? decision(InlierModel(sg, INFINITY), gg, Tr) : 0.0;
    out->sigma_gauss = fitted ? sg : 0.0;
  } else {
    out->decision_gauss = out->decision;
    out->sigma_gauss = sigma;
  }
  out->posterior = p;
}

}  // namespace poseonly
