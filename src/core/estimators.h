// Estimators for the generic loop of ransac.h: the relative-pose estimator of the default method,
// the paper's GNC-RANSAC estimator (Algorithm 3) and a 2-D line estimator (tests of the loop).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "common.h"
#include "gnc.h"
#include "lirp.h"
#include "refine.h"
#include "residuals.h"

namespace poseonly {

enum class MinimalSolver : int { FivePoint = 0, LiRP6 = 1 };

// max(rotation angle of Ra^T Rb, angle between ta and tb), degrees
inline double pose_distance_deg(const Pose& a, const Pose& b) {
  const double c = std::clamp(0.5 * ((a.R.transpose() * b.R).trace() - 1.0), -1.0, 1.0);
  const double ct = std::clamp(a.t.dot(b.t) / std::max(a.t.norm() * b.t.norm(), kTiny), -1.0, 1.0);
  return 57.29577951308232 * std::max(std::acos(c), std::acos(ct));
}
// Local optimisation of a new best model: warm-started TLS IRLS on all-candidate LiRP (the pose-only
// LO), or Levenberg-Marquardt on the Sampson error with a Cauchy loss at the threshold (PoseLib's
// choice of a non-minimal refinement, with a smooth loss).
// SampsonTruncated / SampsonMulti: the same LM with the truncated quadratic of MsacScorer /
// MultiMsacScorer (refine.h), i.e. the search's own score at the threshold (PoseLib's LO loss).
// SampsonCauchyMulti: the Cauchy LM, then SampsonMulti's from its result (a wide basin first, then the
// score itself, as LO+'s shrinking thresholds).
// SampsonCauchyTruncated: the same with SampsonTruncated's loss second. SampsonCauchyAuto: the
// second stage of SampsonCauchyMulti only where the matches within the threshold at the Cauchy pose
// have a median error below kLoAutoMedianShare thresholds, i.e. where the threshold is well above the
// noise (Gaussian noise of sigma < ~0.45 thresholds: a few % of the inliers beyond it) and truncating
// at it discards almost no inlier; with noise near the threshold the Cauchy pose is kept.
// The two-stage LOs offer both stages' poses as candidates (local_candidates): the caller scores each by
// its own objective and keeps the best, since the second stage's loss lowers its own cost on the LO's
// window, not necessarily the search's score (cheirality, keypoint_once, a strided window).
enum class LocalOpt : int { LiRPGnc = 0, SampsonLM = 1, SampsonTruncated = 2, SampsonMulti = 3, SampsonCauchyMulti = 4, SampsonCauchyTruncated = 5, SampsonCauchyAuto = 6 };
constexpr double kLoAutoMedianShare = 0.3;
// SampsonCauchyAuto's gate needs this many errors within the threshold: on fewer, the 5-parameter fit
// shrinks the errors (by ~sqrt((k - 5) / k)) enough to pass noise near the threshold as low
constexpr int kLoAutoMinErrors = 20;

// The five-point solver (fivept.cpp): poses whose sample points all have positive depths.
void fivept_poses(const Points& p, std::vector<Pose>* out);

// Minimal hypotheses on bearings, Sampson residual on the sphere, LO by warm-started TLS IRLS on
// all-candidate LiRP (the candidate minimising the weighted residual kept) with `lo_residual`,
// from the model's inliers, on the points within `lo_window` thresholds.
class RelativePoseEstimator {
 public:
  static constexpr int kLoCandidates = 2;  // the most poses local_candidates offers
  struct Options {
    MinimalSolver solver = MinimalSolver::FivePoint;
    double lo_threshold = 1e-3;  // the LO's fixed TLS bound (radians)
    double lo_window = 4.0;      // LO sees points with Sampson error < lo_window * lo_threshold
    double lo_mu0 = 1e3;         // start at (near) hard TLS
    int lo_iterations = 10;
    Residual lo_residual = Residual::SampsonChiral;
    LocalOpt lo = LocalOpt::LiRPGnc;
    int lm_iterations = 25;
    // > 0: the LO runs on an evenly strided subset of at most this many of its window's points (the
    // LO'd model is rescored on all points; its cost on a big pair is the LM's)
    int lo_max_points = 0;
  };
  using Model = Pose;
  using Terms = PoseTerms;

  RelativePoseEstimator(const Points& P, const Options& o) : P_(P), o_(o), soa_(P) {}
  int sample_size() const { return o_.solver == MinimalSolver::FivePoint ? 5 : 6; }
  int num_data() const { return P_.n; }
  Terms terms(const Model& m) const { return PoseTerms(m); }
  double residual(const Terms& T, int i) const { return sampson(T.E, P_.a(i), P_.b(i)); }
  // residual(T, i) for i in [i0, i0 + m) into out: the scorers' hot loop (ransac.h), vectorised
  void residual_block(const Terms& T, int i0, int m, double* out) const { sampson_block(T.E, soa_, i0, m, out); }
  // the same with kChiralPenalty where the point is behind either camera (sampson_chiral)
  void residual_block_chiral(const Terms& T, int i0, int m, double* out) const {
    sampson_block(T.E, soa_, i0, m, out);
    chiral_block(T.R, T.t, soa_, i0, m, out);
  }
  double success_probability(double r) const { return std::pow(r, sample_size()); }
  // max(rotation angle, angle between the translation directions), degrees
  double distance(const Model& a, const Model& b) const { return pose_distance_deg(a, b); }
  // the cosine of the model's parallax: the middle element (index size / 2) of cos angle(R f1_i, f2_i)
  // over the inliers, i.e. the cosine of their median angle between the two rays once the rotation is
  // removed (1 without inliers); RansacOptions::floor_parallax compares it
  double parallax_cos(const Model& m, const std::vector<int>& inliers) const {
    if (inliers.empty()) return 1.0;
    par_.clear();
    for (int i : inliers) par_.push_back((m.R * P_.a(i)).dot(P_.b(i)));
    auto mid = par_.begin() + static_cast<std::ptrdiff_t>(par_.size() / 2);
    std::nth_element(par_.begin(), mid, par_.end());
    return *mid;
  }

  void generate(const std::vector<int>& s, std::vector<Model>* models) {
    buf_.clear();
    for (int i : s) buf_.push(P_.f1 + 3 * i, P_.f2 + 3 * i);
    if (o_.solver == MinimalSolver::FivePoint) {
      fivept_poses(buf_.view(), models);
    } else {
      lirp(buf_.view(), nullptr, false, &lr_);
      models->push_back(lr_.id[lr_.best].pose);
    }
  }

  bool refine(Model* m, const std::vector<int>& inliers) { return local_optimization(m, inliers, o_.lo_threshold); }
  // The LO's candidates at the search's bound (ransac.h scores each; see local_candidates).
  int refine_candidates(const Model& m, const std::vector<int>& inliers, Model* out) { return local_candidates(m, inliers, o_.lo_threshold, out); }

  // The LO step at an explicit bound `thr` (also the default method's final stage): its last candidate.
  bool local_optimization(Model* m, const std::vector<int>& inliers, double thr) {
    Model c[kLoCandidates];
    const int k = local_candidates(*m, inliers, thr, c);
    if (k == 0) return false;
    *m = c[k - 1];
    return true;
  }

  // The LO of `m` at the bound `thr`: writes 0 (failed), 1 or, for a two-stage LO whose second stage
  // ran, 2 poses (the first stage's, then the second's) to `out` and returns their number.
  int local_candidates(const Model& m, const std::vector<int>& inliers, double thr, Model* out) {
    if (static_cast<int>(inliers.size()) < kLirpMinPoints) return 0;
    const PoseTerms T(m);
    buf_.clear();
    w0_.clear();
    size_t j = 0;
    for (int i = 0; i < P_.n; ++i) {
      while (j < inliers.size() && inliers[j] < i) ++j;
      const bool in = j < inliers.size() && inliers[j] == i;
      if (!(sampson(T.E, P_.a(i), P_.b(i)) < o_.lo_window * thr) && !in) continue;
      buf_.push(P_.f1 + 3 * i, P_.f2 + 3 * i);
      w0_.push_back(in ? 1.0 : 0.0);
    }
    if (buf_.view().n < kLirpMinPoints) return 0;
    if (o_.lo_max_points > 0 && buf_.view().n > o_.lo_max_points) {  // an evenly strided subset
      const int nw = buf_.view().n, stride = (nw + o_.lo_max_points - 1) / o_.lo_max_points;
      PointBuffer sub;
      std::vector<double> w;
      for (int i = 0; i < nw; i += stride) {
        sub.push(buf_.f1.data() + 3 * i, buf_.f2.data() + 3 * i);
        w.push_back(w0_[i]);
      }
      buf_ = std::move(sub);
      w0_ = std::move(w);
    }
    if (o_.lo != LocalOpt::LiRPGnc) {
      RefineOptions ro;
      ro.loss_scale = thr;
      ro.max_iterations = o_.lm_iterations;
      ro.tol = 1e-10;
      Pose p = m;
      const int k = two_stage();  // the second stage's slot
      if (k) {
        ro.loss = RefineLoss::Cauchy;  // wide first (Cauchy's basin), then the score's
        refine_sampson(buf_.view(), nullptr, ro, &p);
        if (!(p.R.allFinite() && p.t.allFinite())) return 0;
        out[0] = p;
        if (o_.lo == LocalOpt::SampsonCauchyAuto) {
          const Points V = buf_.view();
          const PoseTerms Tp(p);
          within_.clear();
          for (int i = 0; i < V.n; ++i) {
            const double r = sampson(Tp.E, V.a(i), V.b(i));
            if (r < thr) within_.push_back(r);
          }
          bool low_noise = static_cast<int>(within_.size()) >= kLoAutoMinErrors;
          if (low_noise) {
            auto mid = within_.begin() + within_.size() / 2;
            std::nth_element(within_.begin(), mid, within_.end());
            low_noise = *mid < kLoAutoMedianShare * thr;
          }
          if (!low_noise) return 1;
        }
      }
      ro.loss = o_.lo == LocalOpt::SampsonLM ? RefineLoss::Cauchy
                : o_.lo == LocalOpt::SampsonTruncated || o_.lo == LocalOpt::SampsonCauchyTruncated ? RefineLoss::Truncated
                : RefineLoss::TruncatedMulti;
      refine_sampson(buf_.view(), nullptr, ro, &p);  // every point in the window; the loss bounds outliers
      if (!(p.R.allFinite() && p.t.allFinite())) return k;  // the first stage's pose, or none
      out[k] = p;
      return k + 1;
    }
    GncOptions g;
    g.noise_bound = thr;
    g.max_iterations = o_.lo_iterations;
    g.mu0 = o_.lo_mu0;
    g.residual = o_.lo_residual;
    g.all_candidates = true;
    GncResult r;
    gnc_irls(buf_.view(), w0_.data(), g, &r);
    if (!(r.pose.R.allFinite() && r.pose.t.allFinite())) return 0;
    out[0] = r.pose;
    return 1;
  }

 private:
  bool two_stage() const { return o_.lo == LocalOpt::SampsonCauchyMulti || o_.lo == LocalOpt::SampsonCauchyTruncated || o_.lo == LocalOpt::SampsonCauchyAuto; }

  Points P_;
  Options o_;
  SoaPoints soa_;
  PointBuffer buf_;
  std::vector<double> w0_;
  std::vector<double> within_;  // SampsonCauchyAuto: the window's errors within the threshold
  mutable std::vector<double> par_;
  LirpResult lr_;
};

// Algorithm 3's estimator: a sample of n_s points is fitted by GNC-IRLS (Algorithm 2) from uniform
// weights; the residual (v_LiGT in the paper) decides inliers; refine = GNC-IRLS on the inlier set.
// A sample is "good" when it holds a majority (>= 60 %) of inliers: its probability is the
// binomial tail, the adaptive-stop rule of the paper's rationale.
class GncRansacEstimator {
 public:
  using Model = Pose;
  using Terms = PoseTerms;
  GncRansacEstimator(const Points& P, int sample_size, const GncOptions& g) : P_(P), ns_(sample_size), g_(g) {}
  int sample_size() const { return ns_; }
  int num_data() const { return P_.n; }
  Terms terms(const Model& m) const { return PoseTerms(m); }
  double residual(const Terms& T, int i) const { return poseonly::residual(g_.residual, T, P_.a(i), P_.b(i)); }
  double success_probability(double r) const {
    const int need = static_cast<int>(std::ceil(0.6 * ns_));
    double p = 0.0;  // P(Bin(ns, r) >= need)
    for (int k = need; k <= ns_; ++k)
      p += std::exp(std::lgamma(ns_ + 1.0) - std::lgamma(k + 1.0) - std::lgamma(ns_ - k + 1.0) +
                    (k ? k * std::log(r) : 0.0) + (ns_ - k ? (ns_ - k) * std::log1p(-r) : 0.0));
    return std::min(p, 1.0 - 1e-12);
  }
  // max(rotation angle, angle between the translation directions), degrees
  double distance(const Model& a, const Model& b) const { return pose_distance_deg(a, b); }
  void generate(const std::vector<int>& s, std::vector<Model>* models) {
    fit(s, nullptr);
    models->push_back(last_.pose);
  }
  bool refine(Model* m, const std::vector<int>& inliers) {
    if (static_cast<int>(inliers.size()) < kLirpMinPoints) return false;
    fit(inliers, nullptr);
    *m = last_.pose;
    return m->R.allFinite() && m->t.allFinite();
  }
  const GncResult& last() const { return last_; }

 private:
  void fit(const std::vector<int>& idx, const double* w0) {
    buf_.clear();
    for (int i : idx) buf_.push(P_.f1 + 3 * i, P_.f2 + 3 * i);
    gnc_irls(buf_.view(), w0, g_, &last_);
  }
  Points P_;
  int ns_;
  GncOptions g_;
  PointBuffer buf_;
  GncResult last_;
};

// Rotation-only model X2 ~ R X1 (pure rotation: no parallax): 2-point hypotheses (the frame of the
// two rays and their normal in each view), residual the chord |R f1 - f2|, refine = Kabsch on the
// inliers. The pure-rotation test of poseonly.analysis runs it through the same loop.
class RotationEstimator {
 public:
  using Model = Mat3;
  using Terms = Mat3;
  explicit RotationEstimator(const Points& P) : P_(P), soa_(P) {}
  int sample_size() const { return 2; }
  int num_data() const { return P_.n; }
  Terms terms(const Model& m) const { return m; }
  // squared chord |R a - b|^2 (no square root in the hot loop: callers threshold at chord^2)
  double residual(const Terms& R, int i) const {
    const double* a = P_.f1 + 3 * i;
    const double* b = P_.f2 + 3 * i;
    return chord2_terms(R, a[0], a[1], a[2], b[0], b[1], b[2]);
  }
  void residual_block(const Terms& R, int i0, int m, double* out) const { chord2_block(R, soa_, i0, m, out); }
  double success_probability(double r) const { return r * r; }
  double distance(const Model& a, const Model& b) const {
    return 57.29577951308232 * std::acos(std::clamp(0.5 * ((a.transpose() * b).trace() - 1.0), -1.0, 1.0));
  }
  void generate(const std::vector<int>& s, std::vector<Model>* models) {
    const Vec3 a1 = P_.a(s[0]), a2 = P_.a(s[1]), b1 = P_.b(s[0]), b2 = P_.b(s[1]);
    Mat3 Fa, Fb;
    if (!frame(a1, a2, &Fa) || !frame(b1, b2, &Fb)) return;
    models->push_back(Fb * Fa.transpose());
  }
  // Kabsch: the rotation minimising sum |b_i - R a_i|^2 over the inliers
  bool refine(Model* m, const std::vector<int>& inl) {
    if (inl.size() < 3) return false;
    Mat3 C = Mat3::Zero();
    for (int i : inl) C += P_.b(i) * P_.a(i).transpose();
    Eigen::JacobiSVD<Mat3> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
    const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
    if (!R.allFinite()) return false;
    *m = R;
    return true;
  }

 private:
  SoaPoints soa_;
  static bool frame(const Vec3& u, const Vec3& v, Mat3* F) {
    const Vec3 w = u.cross(v);
    const double nw = w.norm();
    if (!(nw > 1e-12)) return false;
    F->col(0) = u;
    F->col(1) = w / nw;
    F->col(2) = u.cross(F->col(1));
    return true;
  }
  Points P_;
};

// A 2-D line a x + b y + c = 0 (a^2 + b^2 = 1) from 2 points; refine = total least squares on the
// inliers. It exists to test that the loop is generic (ransac_test.cc in COLMAP does the same).
struct Line {
  double a = 1.0, b = 0.0, c = 0.0;
};
class LineEstimator {
 public:
  using Model = Line;
  using Terms = Line;
  LineEstimator(const double* xy, int n) : xy_(xy), n_(n) {}
  int sample_size() const { return 2; }
  int num_data() const { return n_; }
  Terms terms(const Model& m) const { return m; }
  double residual(const Terms& l, int i) const { return std::abs(l.a * xy_[2 * i] + l.b * xy_[2 * i + 1] + l.c); }
  double success_probability(double r) const { return r * r; }
  // angle between the lines' normals (degrees, sign-free) plus their offset difference
  double distance(const Model& p, const Model& q) const {
    const double c = std::min(1.0, std::abs(p.a * q.a + p.b * q.b));
    return std::acos(c) * 57.29577951308232 + std::abs(std::abs(p.c) - std::abs(q.c));
  }
  void generate(const std::vector<int>& s, std::vector<Model>* models) {
    const double dx = xy_[2 * s[1]] - xy_[2 * s[0]], dy = xy_[2 * s[1] + 1] - xy_[2 * s[0] + 1];
    const double nrm = std::hypot(dx, dy);
    if (!(nrm > 0.0)) return;
    Line l{-dy / nrm, dx / nrm, 0.0};
    l.c = -(l.a * xy_[2 * s[0]] + l.b * xy_[2 * s[0] + 1]);
    models->push_back(l);
  }
  bool refine(Model* m, const std::vector<int>& inl) {
    if (inl.size() < 2) return false;
    double mx = 0.0, my = 0.0;
    for (int i : inl) {
      mx += xy_[2 * i];
      my += xy_[2 * i + 1];
    }
    mx /= inl.size();
    my /= inl.size();
    Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
    for (int i : inl) {
      const Eigen::Vector2d d(xy_[2 * i] - mx, xy_[2 * i + 1] - my);
      S += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S);
    const Eigen::Vector2d nv = es.eigenvectors().col(0);  // normal: the smallest eigenvalue's vector
    *m = Line{nv(0), nv(1), -(nv(0) * mx + nv(1) * my)};
    return true;
  }

 private:
  const double* xy_;
  int n_;
};

}  // namespace poseonly
