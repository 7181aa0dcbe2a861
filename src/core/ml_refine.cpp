// EM + weighted Sampson LM; see ml_refine.h.
#include "ml_refine.h"

#include <algorithm>
#include <cmath>

#include "refine.h"
#include "residuals.h"

namespace poseonly {
namespace {

constexpr double kSqrt2OverPi = 0.7978845608028654;
constexpr int kMinInliers = 6;
constexpr int kEmSteps = 50;     // EM steps on fixed residuals per round
constexpr double kEmTol = 1e-6;  // relative change of sigma (absolute of g) that ends them

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

}  // namespace

void ml_refine(const Points& P, const Pose& start, const MlOptions& opt, MlResult* out) {
  const double Tr = opt.range;
  out->pose = start;
  std::vector<double> r, p(P.n, 0.0);
  sampson_all(P, out->pose, &r);
  // start: sigma from the median of the errors within half the range, g from their share
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
  double sigma = std::max(1.4826 * in[in.size() / 2], opt.sigma_floor);
  out->sigma_start = sigma;
  double g = std::min(static_cast<double>(in.size()) / P.n, 0.99);
  RefineOptions ro;
  ro.loss = RefineLoss::Linear;
  ro.max_iterations = opt.lm_iterations;
  ro.tol = 1e-10;
  // one EM step on the current residuals: posteriors, then sigma and g; false when too few inliers
  auto em_step = [&](bool update) {
    int nT = 0;
    double sp = 0.0, spr2 = 0.0;
    for (int i = 0; i < P.n; ++i) {
      if (!(r[i] < Tr)) {
        p[i] = 0.0;
        continue;
      }
      ++nT;
      const double z = r[i] / sigma;
      const double lin = g * kSqrt2OverPi / sigma * std::exp(-0.5 * z * z);
      p[i] = lin / (lin + (1.0 - g) / Tr);
      sp += p[i];
      spr2 += p[i] * r[i] * r[i];
    }
    if (sp < kMinInliers) return false;
    if (update) {
      sigma = std::clamp(std::sqrt(spr2 / sp), opt.sigma_floor, Tr);
      g = std::clamp(sp / std::max(nT, 1), 1e-6, 1.0 - 1e-9);
    }
    return true;
  };
  for (int k = 0; k < opt.rounds; ++k) {
    // the mixture's parameters to convergence on the current residuals (cheap: O(n) per step)
    bool ok = true;
    for (int e = 0; e < kEmSteps && ok; ++e) {
      const double s0 = sigma, g0 = g;
      ok = em_step(true);
      if (std::abs(sigma - s0) <= kEmTol * s0 && std::abs(g - g0) <= kEmTol) break;
    }
    if (!ok || !em_step(false)) break;
    Pose next = out->pose;
    refine_sampson(P, p.data(), ro, &next);
    if (!(next.R.allFinite() && next.t.allFinite())) break;
    const double moved = std::max(rotation_angle(next.R, out->pose.R), (next.t - out->pose.t).norm());
    out->pose = next;
    out->rounds = k + 1;
    sampson_all(P, out->pose, &r);
    if (moved <= opt.pose_tol) break;  // a fixed point of the EM: the next round would repeat this one
  }
  // final posteriors at the returned pose; the log-likelihood counts a match at or beyond T as an
  // outlier at T's density (so poses that push matches out of range gain nothing)
  double loglik = 0.0;
  for (int i = 0; i < P.n; ++i) {
    const double z = std::min(r[i], Tr) / sigma;
    const double lin = g * kSqrt2OverPi / sigma * std::exp(-0.5 * z * z);
    loglik += std::log(lin + (1.0 - g) / Tr);
    p[i] = r[i] < Tr ? lin / (lin + (1.0 - g) / Tr) : 0.0;
  }
  out->log_likelihood = loglik;
  out->sigma = sigma;
  out->inlier_fraction = g;
  // p = 1/2 where g N+(r) = (1 - g) / T: r = sigma sqrt(2 ln(g T sqrt(2/pi) / ((1 - g) sigma)))
  const double arg = g * Tr * kSqrt2OverPi / ((1.0 - g) * sigma);
  out->decision = arg > 1.0 ? std::min(sigma * std::sqrt(2.0 * std::log(arg)), Tr) : 0.0;
  out->posterior = p;
}

}  // namespace poseonly
