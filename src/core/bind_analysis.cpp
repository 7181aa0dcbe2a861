// Bindings of the final-pose analysis (chance counts, homography twin), GIL released.
#include <nanobind/stl/optional.h>

#include "analysis.h"
#include "arrays.h"
#include "register.h"

namespace poseonly {

using PermIn = nb::ndarray<const int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

static int check_perm(const PermIn& perm, int n) {
  if (static_cast<int>(perm.shape(1)) != n) throw std::invalid_argument("perm must have shape (reps, n)");
  const int64_t* p = perm.data();
  for (size_t k = 0; k < perm.size(); ++k)
    if (p[k] < 0 || p[k] >= n) throw std::invalid_argument("perm entries must be indices in [0, n)");
  return static_cast<int>(perm.shape(0));
}

static int64_t chance_count_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, const PermIn& perm,
                               double tau) {
  const Points P = points_of(f1, f2);
  const Pose pose = pose_of(R, t);
  const int reps = check_perm(perm, P.n);
  GilRelease release(static_cast<double>(reps) * P.n);
  return chance_count_sampson(pose, P, perm.data(), reps, tau);
}

static int64_t rotation_chance_count_py(const ArrayIn& R, const BearingsIn& f1, const BearingsIn& f2, const PermIn& perm, double chord2) {
  const Points P = points_of(f1, f2);
  if (R.size() != 9) throw std::invalid_argument("R must be (3, 3)");
  Mat3 M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M(i, j) = R.data()[3 * i + j];
  const int reps = check_perm(perm, P.n);
  GilRelease release(static_cast<double>(reps) * P.n);
  return chance_count_rotation(M, P, perm.data(), reps, chord2);
}

static nb::object homography_twin_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2) {
  const Points P = points_of(f1, f2);
  const Pose pose = pose_of(R, t);
  Pose tw;
  double planarity = 0.0;
  bool ok;
  {
    nb::gil_scoped_release release;
    ok = homography_twin(pose, P, &tw, &planarity);
  }
  if (!ok) return nb::none();
  auto [Ro, to] = pose_arrays(tw);
  return nb::make_tuple(Ro, to, planarity);
}

static nb::object homography_twin_dlt_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double max_transfer) {
  const Points P = points_of(f1, f2);
  const Pose pose = pose_of(R, t);
  Pose tw;
  bool ok;
  {
    nb::gil_scoped_release release;
    ok = homography_twin_dlt(pose, P, max_transfer, &tw);
  }
  if (!ok) return nb::none();
  auto [Ro, to] = pose_arrays(tw);
  return nb::make_tuple(Ro, to);
}

static nb::object decompose_homography_py(const ArrayIn& H) {
  if (H.size() != 9) throw std::invalid_argument("H must be (3, 3)");
  Mat3 M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M(i, j) = H.data()[3 * i + j];
  HomographyDecomposition d;
  if (!decompose_homography(M, &d)) return nb::none();
  std::vector<double> Ro(36), To(12), No(12);
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) Ro[9 * k + 3 * i + j] = d.R[k](i, j);
      To[3 * k + i] = d.T[k](i);
      No[3 * k + i] = d.N[k](i);
    }
  return nb::make_tuple(to_numpy(std::move(Ro), {4, 3, 3}), to_numpy(std::move(To), {4, 3}), to_numpy(std::move(No), {4, 3}));
}

static nb::tuple select_by_support_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, double tau) {
  const Points P = points_of(f1, f2);
  const Pose pose = pose_of(R, t);
  if (!(tau > 0.0 && std::isfinite(tau))) throw std::invalid_argument("tau must be finite and > 0");
  Pose out;
  {
    nb::gil_scoped_release release;
    out = select_by_support(pose, P, tau);
  }
  auto [Ro, to] = pose_arrays(out);
  return nb::make_tuple(Ro, to);
}

static nb::tuple parallax_ratio_py(const ArrayIn& R, const BearingsIn& f1, const BearingsIn& f2, const ArrayIn& v, double tau,
                                   double band, double sel_chord2, int min_matches, int irls_rounds, double cauchy_c,
                                   double chi2_median, double min_parallax, double noise_floor) {
  const Points P = points_of(f1, f2);
  if (R.size() != 9) throw std::invalid_argument("R must be (3, 3)");
  if (v.ndim() != 1 || static_cast<int>(v.shape(0)) != P.n) throw std::invalid_argument("v_pose must have shape (n,)");
  if (!(tau > 0.0 && std::isfinite(tau))) throw std::invalid_argument("tau must be finite and > 0");
  if (min_matches < 1 || irls_rounds < 0) throw std::invalid_argument("min_matches must be >= 1 and irls_rounds >= 0");
  Mat3 M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M(i, j) = R.data()[3 * i + j];
  ParallaxOptions o;
  o.band = band;
  o.sel_chord2 = sel_chord2;
  o.min_matches = min_matches;
  o.irls_rounds = irls_rounds;
  o.cauchy_c = cauchy_c;
  o.chi2_median = chi2_median;
  o.min_parallax = min_parallax;
  if (!(noise_floor >= 0.0) || !std::isfinite(noise_floor)) throw std::invalid_argument("noise_floor must be finite and >= 0");
  o.noise_floor = noise_floor;
  ParallaxResult r;
  {
    GilRelease release(static_cast<double>(irls_rounds + 2) * P.n);
    r = parallax_ratio(M, P, v.data(), tau, o);
  }
  if (!r.refit) return nb::make_tuple(r.ratio, r.noise, nb::none());
  std::vector<double> Ro(9);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Ro[3 * i + j] = r.R(i, j);
  return nb::make_tuple(r.ratio, r.noise, to_numpy(std::move(Ro), {3, 3}));
}

using MaskIn = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

static const uint8_t* mask_of(const MaskIn& mask, int n) {
  if (static_cast<int>(mask.shape(0)) != n) throw std::invalid_argument("mask must have shape (n,)");
  static_assert(sizeof(bool) == 1, "numpy bool is one byte");
  return reinterpret_cast<const uint8_t*>(mask.data());
}

static nb::tuple counts_of(const SupportComparison& s) { return nb::make_tuple(s.a, s.b, s.only_a, s.only_b); }

static nb::tuple compare_support_py(const ArrayIn& Ra, const ArrayIn& ta, const ArrayIn& Rb, const ArrayIn& tb, const BearingsIn& f1,
                                    const BearingsIn& f2, double thr, bool far_neutral) {
  const Points P = points_of(f1, f2);
  const Pose a = pose_of(Ra, ta), b = pose_of(Rb, tb);
  SupportComparison s;
  {
    GilRelease release(2.0 * P.n);
    s = compare_support(a, b, P, thr, far_neutral);
  }
  return counts_of(s);
}

static nb::object analyse_twin_py(const ArrayIn& R, const ArrayIn& t, const BearingsIn& f1, const BearingsIn& f2, const MaskIn& mask,
                                  double tau) {
  const Points P = points_of(f1, f2);
  const Pose pose = pose_of(R, t);
  const uint8_t* m = mask_of(mask, P.n);
  if (!(tau > 0.0 && std::isfinite(tau))) throw std::invalid_argument("tau must be finite and > 0");
  TwinAnalysis r;
  {
    nb::gil_scoped_release release;
    r = analyse_twin(pose, P, m, tau);
  }
  if (!r.found && !r.compared) return nb::none();
  // planarity: the triangulated plane's (None where only the DLT fallback found the twin)
  nb::object planarity = r.found ? nb::object(nb::float_(r.planarity)) : nb::none();
  if (!r.compared) return nb::make_tuple(planarity, nb::none());
  auto [Ro, to] = pose_arrays(r.twin);
  return nb::make_tuple(planarity, nb::make_tuple(Ro, to, counts_of(r.support)));
}

static double median_rotation_angle_py(const ArrayIn& R, const BearingsIn& f1, const BearingsIn& f2, const MaskIn& mask) {
  const Points P = points_of(f1, f2);
  if (R.size() != 9) throw std::invalid_argument("R must be (3, 3)");
  const uint8_t* m = mask_of(mask, P.n);
  Mat3 M;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M(i, j) = R.data()[3 * i + j];
  GilRelease release(static_cast<double>(P.n));
  return median_rotation_angle(M, P, m);
}

}  // namespace poseonly

POSEONLY_BIND(analysis) {
  using namespace poseonly;
  m.def("chance_count", &chance_count_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("perm"), nb::arg("tau"),
        "Re-paired matches (f1[i], f2[perm[r, i]]) that are Sampson inliers (< tau) of (R, unit t); perm (reps, n) int64.");
  m.def("rotation_chance_count", &rotation_chance_count_py, nb::arg("R"), nb::arg("f1"), nb::arg("f2"), nb::arg("perm"),
        nb::arg("chord2"), "Re-paired matches with |R f1[i] - f2[perm[r, i]]|^2 < chord2; perm (reps, n) int64.");
  m.def("homography_twin", &homography_twin_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"),
        "The homography twin of (R, t) on its inliers f1, f2 (n, 3): (R_twin (3, 3), unit t_twin (3,), planarity) or None.");
  m.def("homography_twin_dlt", &homography_twin_dlt_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("max_transfer"),
        "The twin of (R, t) from the homography fitted to its inliers f1, f2 (n, 3) directly (DLT), if it carries 90 % of them to within "
        "max_transfer radians: (R_twin (3, 3), unit t_twin (3,)) or None.");
  m.def("select_by_support", &select_by_support_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("tau"),
        "The default method's pose-only choice (poseonly.robust.default.select_by_support): (R, t).");
  m.def(
      "log_binom_sf",
      [](int64_t k, int64_t n, double p) {
        if (std::isnan(p)) return std::numeric_limits<double>::quiet_NaN();
        GilRelease release(static_cast<double>(n - k));  // the terms summed
        return log_binom_sf(k, n, p);
      },
      nb::arg("k"), nb::arg("n"), nb::arg("p"), "log P(Bin(n, p) >= k) (log-sum-exp of the terms; no underflow; NaN for a NaN p).");
  m.def("compare_support", &compare_support_py, nb::arg("R_a"), nb::arg("t_a"), nb::arg("R_b"), nb::arg("t_b"), nb::arg("f1"),
        nb::arg("f2"), nb::arg("thr"), nb::arg("far_neutral") = false,
        "Cheirality-consistent supports of two poses (sampson_chiral < thr): (under a, under b, a only, b only); far_neutral: a "
        "match whose rays are parallel to within thr under a pose (|R f1 x f2| < thr) counts for it by its Sampson error alone.");
  m.def("analyse_twin", &analyse_twin_py, nb::arg("R"), nb::arg("t"), nb::arg("f1"), nb::arg("f2"), nb::arg("mask"), nb::arg("tau"),
        "The status analysis's planar twin of (R, t) from the matches in mask (its inliers): None without a twin "
        "decomposition, (planarity, None) when the twin fails the support screen, else (planarity, (R_twin, "
        "t_twin, (pose support, twin support, pose only, twin only))) with the polished twin compared at min(tau, 0.5).");
  m.def("median_rotation_angle", &median_rotation_angle_py, nb::arg("R"), nb::arg("f1"), nb::arg("f2"), nb::arg("mask"),
        "Median angle (radians) between R f1 and f2 over the matches in mask (NaN when none).");
  m.def("parallax_ratio", &parallax_ratio_py, nb::arg("R"), nb::arg("f1"), nb::arg("f2"), nb::arg("v_pose"), nb::arg("tau"),
        nb::arg("band"), nb::arg("sel_chord2"), nb::arg("min_matches"), nb::arg("irls_rounds"), nb::arg("cauchy_c"),
        nb::arg("chi2_median"), nb::arg("min_parallax"), nb::arg("noise_floor") = 0.0,
        "The pure-rotation test's precision check (poseonly.analysis.parallax_ratio): (ratio, noise, R (3, 3) or None).");
  m.def("decompose_homography", &decompose_homography_py, nb::arg("H"),
        "The four (R (4, 3, 3), t/d (4, 3), n (4, 3)) of a calibrated homography, or None when H is not finite or singular.");
}
