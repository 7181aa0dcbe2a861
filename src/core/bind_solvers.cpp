// Bindings of the minimal solver and the refinements (GIL released around the numeric work).
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>

#include <limits>
#include <string>

#include "arrays.h"
#include "fivept.h"
#include "refine.h"
#include "register.h"

namespace poseonly {
namespace {

nb::tuple poses_to_numpy(const std::vector<Pose>& poses) {
  const size_t k = poses.size();
  std::vector<double> R(9 * k), t(3 * k);
  for (size_t h = 0; h < k; ++h) put_pose(poses[h], R.data() + 9 * h, t.data() + 3 * h);
  return nb::make_tuple(to_numpy(std::move(R), {k, size_t{3}, size_t{3}}), to_numpy(std::move(t), {k, size_t{3}}));
}

nb::tuple fivept_py(const BearingsIn& f1, const BearingsIn& f2) {
  const Points P = points_of(f1, f2);
  if (P.n != 5) throw std::invalid_argument("fivept needs exactly 5 bearings per view, shape (5, 3)");
  std::vector<Pose> poses;
  {
    nb::gil_scoped_release release;
    fivept_poses(P, &poses);
  }
  return poses_to_numpy(poses);
}

NpArray fivept_essentials_py(const BearingsIn& f1, const BearingsIn& f2) {
  const Points P = points_of(f1, f2);
  if (P.n != 5) throw std::invalid_argument("fivept_essentials needs exactly 5 bearings per view, shape (5, 3)");
  std::vector<Mat3> E;
  {
    nb::gil_scoped_release release;
    fivept_essentials(P, &E);
  }
  const size_t k = E.size();
  std::vector<double> out(9 * k);
  for (size_t h = 0; h < k; ++h)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out[9 * h + 3 * i + j] = E[h](i, j);
  return to_numpy(std::move(out), {k, size_t{3}, size_t{3}});
}

// one construction of the five-point solver (tests, benchmarks/fivept_paths.py): path -1 auto, 0 Nister,
// 1 the action matrix; returns (E (k, 3, 3), the construction that produced E: 0 or 1, or -2 where the
// sample is rank-deficient or the construction failed its test)
nb::tuple fivept_essentials_path_py(const BearingsIn& f1, const BearingsIn& f2, int path) {
  const Points P = points_of(f1, f2);
  if (P.n != 5) throw std::invalid_argument("fivept_essentials_path needs exactly 5 bearings per view, shape (5, 3)");
  if (path < -1 || path > 1) throw std::invalid_argument("path must be -1 (auto), 0 (Nister) or 1 (action matrix)");
  std::vector<Mat3> E;
  FiveptPath used;
  {
    nb::gil_scoped_release release;
    used = fivept_essentials_path(P, static_cast<FiveptPath>(path), &E);
  }
  const size_t k = E.size();
  std::vector<double> out(9 * k);
  for (size_t h = 0; h < k; ++h)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out[9 * h + 3 * i + j] = E[h](i, j);
  return nb::make_tuple(to_numpy(std::move(out), {k, size_t{3}, size_t{3}}), static_cast<int>(used));
}

using SamplesIn = nb::ndarray<const double, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

nb::tuple fivept_batch_py(const SamplesIn& f1, const SamplesIn& f2) {
  if (f1.shape(1) != 5 || f1.shape(2) != 3 || f2.shape(1) != 5 || f2.shape(2) != 3)
    throw std::invalid_argument("fivept_batch needs bearings of shape (b, 5, 3)");
  if (f1.shape(0) != f2.shape(0)) throw std::invalid_argument("f1 and f2 must hold the same number of samples");
  const size_t b = f1.shape(0);
  std::vector<Pose> all;
  std::vector<int64_t> index;
  {
    nb::gil_scoped_release release;
    all.reserve(4 * b);
    index.reserve(4 * b);
    std::vector<Pose> poses;
    poses.reserve(10);
    for (size_t s = 0; s < b; ++s) {
      const Points P{f1.data() + 15 * s, f2.data() + 15 * s, 5};
      fivept_poses(P, &poses);
      for (const Pose& p : poses) {
        all.push_back(p);
        index.push_back(static_cast<int64_t>(s));
      }
    }
  }
  nb::tuple Rt = poses_to_numpy(all);
  const size_t m = index.size();
  return nb::make_tuple(Rt[0], Rt[1], to_numpy_t<int64_t>(std::move(index), {m}));
}

RefineLoss loss_of(const std::string& name) {
  if (name == "linear") return RefineLoss::Linear;
  if (name == "soft_l1") return RefineLoss::SoftL1;
  if (name == "huber") return RefineLoss::Huber;
  if (name == "cauchy") return RefineLoss::Cauchy;
  if (name == "arctan") return RefineLoss::Arctan;
  if (name == "truncated") return RefineLoss::Truncated;
  if (name == "truncated_multi") return RefineLoss::TruncatedMulti;
  throw std::invalid_argument("unknown loss '" + name + "'; choose linear, soft_l1, huber, cauchy, arctan, truncated or truncated_multi");
}

int normalization_of(const std::string& name) {
  if (name == "none") return 0;
  if (name == "theta2") return 1;
  if (name == "angular") return 2;
  throw std::invalid_argument("unknown normalization '" + name + "'; choose none, theta2 or angular");
}

RefineOptions options_of(const std::string& loss, std::optional<double> loss_scale, int max_iterations, double tol) {
  RefineOptions o;
  o.loss = loss_of(loss);
  if (loss_scale) {
    if (!(std::isfinite(*loss_scale) && *loss_scale > 0.0)) throw std::invalid_argument("loss_scale must be positive and finite");
    o.loss_scale = *loss_scale;
  } else {
    o.loss_scale = 0.0;  // default scale (refine.h)
  }
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be >= 1");
  o.max_iterations = max_iterations;
  if (!(tol >= 0.0)) throw std::invalid_argument("tol must be >= 0");
  o.tol = tol;
  return o;
}

Pose checked_pose(const ArrayIn& R, const ArrayIn& t) {
  if (R.ndim() != 2 || R.shape(0) != 3 || R.shape(1) != 3) throw std::invalid_argument("R must have shape (3, 3)");
  if (t.ndim() != 1 || t.shape(0) != 3) throw std::invalid_argument("t must have shape (3,)");
  Pose p = pose_of(R, t);
  if (!p.R.allFinite() || !p.t.allFinite()) throw std::invalid_argument("R and t must be finite");
  if ((p.R.transpose() * p.R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-6 || p.R.determinant() < 0.0)
    throw std::invalid_argument("R must be a rotation matrix (R^T R = I, det R = +1)");
  const double mx = p.t.cwiseAbs().maxCoeff();  // scaled first: the norm of a t near 1e200 overflows
  if (!(mx > 0.0)) throw std::invalid_argument("t must be non-zero");
  p.t /= mx;
  const double nt = p.t.norm();
  if (!(mx * nt > 1e-12)) throw std::invalid_argument("t must be non-zero");
  p.t /= nt;
  return p;
}

Points checked_points(const BearingsIn& f1, const BearingsIn& f2, int min_points) {
  const Points P = points_of(f1, f2);
  if (P.n < min_points)
    throw std::invalid_argument("the refinement needs at least " + std::to_string(min_points) + " correspondences");
  for (int i = 0; i < 3 * P.n; ++i)
    if (!std::isfinite(P.f1[i]) || !std::isfinite(P.f2[i])) throw std::invalid_argument("bearings must be finite");
  return P;
}

const double* checked_weights(const std::optional<VectorIn>& w, int n) {
  const double* wp = weights_of(w, n);
  if (wp)
    for (int i = 0; i < n; ++i)
      if (!(std::isfinite(wp[i]) && wp[i] >= 0.0)) throw std::invalid_argument("weights must be finite and non-negative");
  return wp;
}

nb::tuple refine_result(const Pose& p, const RefineStats& s) {
  auto [R, t] = pose_arrays(p);
  nb::dict d;
  d["iterations"] = s.iterations;
  d["evaluations"] = s.evaluations;
  d["status"] = s.status;
  d["initial_cost"] = s.initial_cost;
  d["final_cost"] = s.final_cost;
  d["loss_scale"] = s.loss_scale;
  d["positive_depth_fraction"] = s.positive_depth_fraction;
  return nb::make_tuple(R, t, d);
}

nb::tuple refine_sampson_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2,
                            const std::optional<VectorIn>& w, const std::string& loss, std::optional<double> loss_scale,
                            int max_iterations, double tol) {
  const Points P = checked_points(f1, f2, kRefineMinPoints);
  const double* wp = checked_weights(w, P.n);
  Pose pose = checked_pose(R, t);
  const RefineOptions o = options_of(loss, loss_scale, max_iterations, tol);
  RefineStats s;
  {
    nb::gil_scoped_release release;
    s = refine_sampson(P, wp, o, &pose);
  }
  return refine_result(pose, s);
}

nb::tuple refine_ligt_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2,
                         const std::optional<VectorIn>& w, const std::string& normalization, const std::string& loss,
                         std::optional<double> loss_scale, int max_iterations, double tol) {
  const Points P = checked_points(f1, f2, kRefineMinPoints);
  const double* wp = checked_weights(w, P.n);
  Pose pose = checked_pose(R, t);
  const int norm = normalization_of(normalization);
  const RefineOptions o = options_of(loss, loss_scale, max_iterations, tol);
  RefineStats s;
  {
    nb::gil_scoped_release release;
    s = refine_ligt(P, wp, o, norm, &pose);
  }
  return refine_result(pose, s);
}

// residuals and chart Jacobians of the refinements at chart point x (tests: finite differences)
nb::tuple refine_residuals_py(int kind, const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2,
                              const VectorIn& x, const std::optional<VectorIn>& w) {
  if (kind < 0 || kind > 3) throw std::invalid_argument("kind must be 0 (sampson) or 1 + LiGT normalization (1..3)");
  const Points P = points_of(f1, f2);
  const double* wp = checked_weights(w, P.n);
  const Pose pose = checked_pose(R, t);
  if (x.shape(0) != 5) throw std::invalid_argument("x must have shape (5,)");
  std::vector<double> r, J;
  {
    nb::gil_scoped_release release;
    refine_residuals(P, wp, pose, x.data(), kind, &r, &J);
  }
  const size_t m = r.size();
  return nb::make_tuple(to_numpy(std::move(r), {m}), to_numpy(std::move(J), {m, size_t{5}}));
}

// first-order pose covariance (refine.h pose_covariance); t None: a rotation without translation
nb::tuple pose_covariance_py(const ArrayIn& R, const std::optional<ArrayIn>& t, const BearingsIn& f1, const BearingsIn& f2,
                             const std::optional<VectorIn>& w, double threshold, double noise_floor) {
  const Points P = checked_points(f1, f2, 0);
  if (!(threshold >= 0.0) || !std::isfinite(threshold)) throw std::invalid_argument("threshold must be finite and >= 0");
  if (!(noise_floor >= 0.0) || !std::isfinite(noise_floor)) throw std::invalid_argument("noise_floor must be finite and >= 0");
  const double* wp = checked_weights(w, P.n);
  Pose pose;
  if (t) {
    pose = checked_pose(R, *t);
  } else {
    if (R.ndim() != 2 || R.shape(0) != 3 || R.shape(1) != 3) throw std::invalid_argument("R must have shape (3, 3)");
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) pose.R(i, j) = R.data()[3 * i + j];
    if (!pose.R.allFinite() || (pose.R.transpose() * pose.R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-6 || pose.R.determinant() < 0.0)
      throw std::invalid_argument("R must be a finite rotation matrix (R^T R = I, det R = +1)");
  }
  PoseCovariance c;
  {
    GilRelease release(static_cast<double>(P.n));
    c = pose_covariance(P, wp, pose, t.has_value(), threshold, noise_floor);
  }
  std::vector<double> Cr(9), Ct(9);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) Cr[3 * a + b] = c.rotation(a, b), Ct[3 * a + b] = c.translation(a, b);
  return nb::make_tuple(to_numpy(std::move(Cr), {3, 3}), to_numpy(std::move(Ct), {3, 3}), c.sigma, c.matches, c.ok);
}

using InlierMask = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

// (leverage (n,), veto (n,) uint8, group, tested): refine.h leverage_veto
nb::tuple leverage_veto_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, const InlierMask& inliers,
                           double decision, double max_leverage) {
  const Points P = checked_points(f1, f2, 0);
  if (static_cast<int>(inliers.shape(0)) != P.n) throw std::invalid_argument("inliers must have shape (n,)");
  if (!(decision > 0.0) || !std::isfinite(decision)) throw std::invalid_argument("decision must be finite and > 0");
  if (!(max_leverage > 0.0 && max_leverage <= 1.0)) throw std::invalid_argument("max_leverage must lie in (0, 1]");
  const Pose pose = checked_pose(R, t);
  static_assert(sizeof(bool) == 1, "numpy bool is one byte");
  const auto* inl = reinterpret_cast<const uint8_t*>(inliers.data());
  LeverageVeto v;
  {
    GilRelease release(static_cast<double>(P.n));
    v = leverage_veto(P, inl, pose, decision, max_leverage);
  }
  const size_t n = static_cast<size_t>(P.n);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> Ro(9, nan), to(3, nan);
  if (v.tested) {
    const Vec3 tu = v.others.t.normalized();
    for (int a = 0; a < 3; ++a) {
      to[a] = tu(a);
      for (int b = 0; b < 3; ++b) Ro[3 * a + b] = v.others.R(a, b);
    }
  }
  if (v.group.size() != n) v.group.assign(n, 0);
  return nb::make_tuple(to_numpy(std::move(v.leverage), {n}), to_numpy_t<uint8_t>(std::move(v.veto), {n}), to_numpy_t<uint8_t>(std::move(v.group), {n}), v.tested,
                        to_numpy(std::move(Ro), {3, 3}), to_numpy(std::move(to), {3}));
}

nb::tuple refine_normal_equations_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, const VectorIn& x,
                                     const std::optional<VectorIn>& w, bool blocks, const std::string& loss, double loss_scale,
                                     bool weights_outside, const std::optional<VectorIn>& residual_weights) {
  const Points P = points_of(f1, f2);
  const double* wp = checked_weights(w, P.n);
  const double* vp = checked_weights(residual_weights, P.n);
  const Pose pose = checked_pose(R, t);
  if (x.shape(0) != 5) throw std::invalid_argument("x must have shape (5,)");
  if (!(loss_scale > 0.0 && std::isfinite(loss_scale))) throw std::invalid_argument("loss_scale must be finite and > 0");
  const RefineLoss L = loss_of(loss);
  std::vector<double> H(25), g(5);
  double cost;
  {
    nb::gil_scoped_release release;
    cost = refine_normal_equations(P, wp, pose, x.data(), blocks, H.data(), g.data(), L, loss_scale, weights_outside, vp);
  }
  return nb::make_tuple(cost, to_numpy(std::move(H), {size_t{5}, size_t{5}}), to_numpy(std::move(g), {size_t{5}}));
}

}  // namespace
}  // namespace poseonly

POSEONLY_BIND(solvers) {
  using namespace poseonly;
  m.def("fivept", &fivept_py, nb::arg("f1"), nb::arg("f2"),
        "Stewenius five-point on unit bearings f1, f2 (5, 3): the chiral poses (R (k, 3, 3), unit t (k, 3)), "
        "k <= 10, one per real essential matrix that has a decomposition with all five points in front of both "
        "cameras.");
  m.def("fivept_essentials", &fivept_essentials_py, nb::arg("f1"), nb::arg("f2"),
        "The real essential matrices E (k, 3, 3) of the five-point problem f1, f2 (5, 3): unit Frobenius norm, "
        "largest entry positive, k <= 10.");
  m.def("_fivept_essentials_path", &fivept_essentials_path_py, nb::arg("f1"), nb::arg("f2"), nb::arg("path"),
        "One construction of the five-point solver (tests): path -1 the automatic choice, 0 Nister's elimination, 1 the "
        "action matrix. Returns (E (k, 3, 3), the construction that produced E: 0 or 1, or -2 where the sample is "
        "rank-deficient or the construction failed its test).");
  m.def("fivept_batch", &fivept_batch_py, nb::arg("f1"), nb::arg("f2"),
        "fivept on b stacked samples f1, f2 (b, 5, 3) in one call: (R (m, 3, 3), t (m, 3), sample index (m,) int64).");
  m.def("refine_sampson", &refine_sampson_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        nb::arg("w") = nb::none(), nb::arg("loss") = "linear", nb::arg("loss_scale") = nb::none(),
        nb::arg("max_iterations") = 50, nb::arg("tol") = 1e-12,
        "Levenberg-Marquardt on SO(3) x S^2 of sum_i w_i s^2 rho(r_i^2 / s^2), r_i the Sampson distance (radians). "
        "R (3, 3), t (3,) start; f1, f2 (n, 3) unit bearings, n >= 6; w (n,) or None; loss linear | soft_l1 | huber | "
        "cauchy | arctan (scipy semantics) | truncated (min(s, 1): MSAC) | truncated_multi (min(s, 1) + 4 min(s, 1/4) + 16 min(s, 1/16): the default search's score); loss_scale s (None: 1.4826 median_i sqrt(w_i) |r_i| at the start); "
        "max_iterations caps cost evaluations. Returns (R, unit t, stats dict); t's sign is the weighted majority of "
        "positive pose-only depths.");
  m.def("refine_ligt", &refine_ligt_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        nb::arg("w") = nb::none(), nb::arg("normalization") = "none", nb::arg("loss") = "linear",
        nb::arg("loss_scale") = nb::none(), nb::arg("max_iterations") = 50, nb::arg("tol") = 1e-12,
        "LiGTopt (poseonly.refine.ligt.ligt_refine(..., solver='lm')): LM on IRLS normal equations of "
        "sum_i s^2 rho(|sqrt(w_i) L~_i t|^2 / s^2) with normalization none | theta2 | angular; other arguments as "
        "refine_sampson. Returns (R, unit t, stats dict).");
  m.def("leverage_veto", &leverage_veto_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("inliers"),
        nb::arg("decision"), nb::arg("max_leverage"),
        "The leverage test (refine.h leverage_veto): each inlier's leverage h_i in the least-squares Sampson fit of the inliers "
        "(inliers (n,) bool) at (R, t); the inliers with h_i > max_leverage tested together against the least-squares fit of "
        "the others, vetoed where |r_i| > decision sqrt(1 + J_i H^-1 J_i^T) there. Returns (leverage (n,), veto (n,) uint8, "
        "group (n,) uint8 (the inliers peeled off), tested, R (3, 3), unit t (3,) of the others' fit (NaN where not tested)).");
  m.def("pose_covariance", &pose_covariance_py, nb::arg("R"), nb::arg("t").none(), nb::arg("f1"), nb::arg("f2"),
        nb::arg("w") = nb::none(), nb::arg("threshold") = 0.0, nb::arg("noise_floor") = 0.0,
        "First-order covariance sigma^2 (J^T J)^-1 of the pose (R (3, 3), t (3,)) fitted by least squares on the Sampson "
        "errors of the matches f1, f2 (n, 3) with w_i > 0 (w (n,): inverse variances up to a constant or a 0 / 1 mask; "
        "None: all), sigma = 1.4826 median |sqrt(w_i) r_i| (threshold > 0: the matches were selected by |r| < threshold and "
        "sigma solves the truncated median; inf, not ok, where the threshold does not resolve the noise); the covariance "
        "has the small-sample factor k / (k - p) (the returned sigma not). t None: a rotation without translation (its chord residuals). "
        "Returns (rotation covariance (3, 3) in radians^2 of the left perturbation exp([d]x) R, translation covariance "
        "(3, 3) of the unit t (rank 2, tangent to t; zero without t), sigma (radians), matches used, ok); not ok "
        "(covariances inf): too few matches, a zero scale or a parameter the matches do not constrain.");
  m.def("_refine_normal_equations", &refine_normal_equations_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        nb::arg("x"), nb::arg("w") = nb::none(), nb::arg("blocks") = true, nb::arg("loss") = "linear", nb::arg("loss_scale") = 1.0,
        nb::arg("weights_outside") = false, nb::arg("residual_weights") = nb::none(),
        "Test helper: the Sampson LM's cost, H (5, 5) and g (5,) at chart point x around (R, t) (the loss of scale loss_scale; "
        "the residuals scaled by sqrt(w), or with weights_outside w multiplying the loss and the residual weights inside it), "
        "through the SIMD blocks (blocks=True, the LM's path) or point by point.");
  m.def("_refine_residuals", &refine_residuals_py, nb::arg("kind"), nb::arg("R"), nb::arg("t"), nb::arg("f1"),
        nb::arg("f2"), nb::arg("x"), nb::arg("w") = nb::none(),
        "Test helper: stacked residuals r (m,) and their Jacobian (m, 5) w.r.t. the refinement chart x = (w, v) "
        "around (R, t) at x (5,); kind 0 Sampson, 1 + normalization LiGT.");
}
