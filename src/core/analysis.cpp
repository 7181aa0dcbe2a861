#include "analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <vector>

#include "estimators.h"
#include "lirp.h"
#include "refine.h"
#include "residuals.h"

namespace poseonly {

int64_t chance_count_sampson(const Pose& pose, const Points& P, const int64_t* perm, int reps, double tau) {
  // sampson() of a re-paired match (f1_i, f2_j) from E f1_i and E^T f2_j computed once per bearing: the
  // same operations in the same order as sampson_terms (bit for bit), without the 3x3 products per pair
  const PoseTerms pt(pose);
  const Mat3& E = pt.E;
  const size_t n = static_cast<size_t>(P.n);
  std::vector<double> a(3 * n), sa(n), b(3 * n), sb(n);
  for (size_t i = 0; i < n; ++i) {
    const double x1 = P.f1[3 * i], y1 = P.f1[3 * i + 1], z1 = P.f1[3 * i + 2];
    const double a0 = E(0, 0) * x1 + E(0, 1) * y1 + E(0, 2) * z1;
    const double a1 = E(1, 0) * x1 + E(1, 1) * y1 + E(1, 2) * z1;
    const double a2 = E(2, 0) * x1 + E(2, 1) * y1 + E(2, 2) * z1;
    a[3 * i] = a0, a[3 * i + 1] = a1, a[3 * i + 2] = a2, sa[i] = a0 * a0 + a1 * a1 + a2 * a2;
    const double x2 = P.f2[3 * i], y2 = P.f2[3 * i + 1], z2 = P.f2[3 * i + 2];
    const double b0 = E(0, 0) * x2 + E(1, 0) * y2 + E(2, 0) * z2;
    const double b1 = E(0, 1) * x2 + E(1, 1) * y2 + E(2, 1) * z2;
    const double b2 = E(0, 2) * x2 + E(1, 2) * y2 + E(2, 2) * z2;
    b[3 * i] = b0, b[3 * i + 1] = b1, b[3 * i + 2] = b2, sb[i] = b0 * b0 + b1 * b1 + b2 * b2;
  }
  int64_t hits = 0;
  for (int r = 0; r < reps; ++r) {
    const int64_t* p = perm + static_cast<int64_t>(r) * P.n;
    for (size_t i = 0; i < n; ++i) {
      const size_t j = static_cast<size_t>(p[i]);
      const double* f2 = P.f2 + 3 * j;
      const double num = f2[0] * a[3 * i] + f2[1] * a[3 * i + 1] + f2[2] * a[3 * i + 2];
      const double den = sa[i] + sb[j] - 2.0 * num * num;
      hits += std::abs(num) / std::sqrt(den < kTiny ? kTiny : den) < tau;
    }
  }
  return hits;
}

int64_t chance_count_rotation(const Mat3& R, const Points& P, const int64_t* perm, int reps, double chord2) {
  std::vector<Vec3> Ra(P.n);
  for (int i = 0; i < P.n; ++i) Ra[i] = R * P.a(i);
  int64_t hits = 0;
  for (int r = 0; r < reps; ++r) {
    const int64_t* p = perm + static_cast<int64_t>(r) * P.n;
    for (int i = 0; i < P.n; ++i) hits += (Ra[i] - P.b(static_cast<int>(p[i]))).squaredNorm() < chord2;
  }
  return hits;
}

namespace {

Mat3 project_to_so3(const Mat3& M) {
  Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

double rotation_error_deg(const Mat3& A, const Mat3& B) {
  // angle of A^T B: atan2(|axis| , cos) is exact near 0 and 180 deg
  const Mat3 M = A.transpose() * B;
  const double c = 0.5 * (M.trace() - 1.0);
  const Vec3 s(M(2, 1) - M(1, 2), M(0, 2) - M(2, 0), M(1, 0) - M(0, 1));
  return 57.29577951308232 * std::atan2(0.5 * s.norm(), c);
}

}  // namespace

bool decompose_homography(const Mat3& H0, HomographyDecomposition* out) {
  if (!H0.allFinite()) return false;
  const Eigen::JacobiSVD<Mat3> s0(H0);
  const double s2 = s0.singularValues()(1);
  if (!(s2 > 0.0)) return false;
  const Mat3 H = H0 / s2;
  Eigen::JacobiSVD<Mat3> svd(H.transpose() * H, Eigen::ComputeFullV);
  Mat3 V = svd.matrixV();
  if (V.determinant() < 0.0) V = -V;
  const Vec3 S = svd.singularValues();
  const double s1 = S(0), s3 = S(2);
  const Vec3 v1 = V.col(0), v2 = V.col(1), v3 = V.col(2);
  const double den = std::sqrt(std::max(s1 - s3, kTiny));
  const double a = std::sqrt(std::max(1.0 - s3, 0.0)), b = std::sqrt(std::max(s1 - 1.0, 0.0));
  const Vec3 Hv2 = H * v2;
  for (int k = 0; k < 2; ++k) {
    const Vec3 u = (a * v1 + (k ? -b : b) * v3) / den;
    const Vec3 n = v2.cross(u);
    const Vec3 Hu = H * u;
    Mat3 U, W;
    U << v2, u, n;
    W << Hv2, Hu, Hv2.cross(Hu);
    // exact for an exact homography; noise leaves W U^T slightly off SO(3)
    const Mat3 R = project_to_so3(W * U.transpose());
    const Vec3 T = (H - R) * n;
    for (int sgn = 0; sgn < 2; ++sgn) {
      const int j = 2 * k + sgn;
      out->R[j] = R;
      out->T[j] = sgn ? Vec3(-T) : T;
      out->N[j] = sgn ? Vec3(-n) : n;
    }
  }
  return true;
}

namespace {

// The decomposition of H other than (R, t) itself: of the physically valid ones (more than half of the
// matches P in front of camera 1 on the plane's side), the closest to the pose is the pose; the next
// is the twin (homography_twin, homography_twin_dlt).
bool twin_of_homography(const Pose& pose, const Mat3& H, const Points& P, Pose* twin) {
  const Mat3& R = pose.R;
  const Vec3 t = pose.t.norm() > 0.0 ? Vec3(pose.t.normalized()) : pose.t;
  HomographyDecomposition dec;
  if (!decompose_homography(H, &dec)) return false;
  // physically valid: more than half of the inliers in front of camera 1 on the plane's side
  std::array<int, 4> cand{};
  int nc = 0;
  for (int j = 0; j < 4; ++j) {
    int front = 0;
    for (int i = 0; i < P.n; ++i) front += P.a(i).dot(dec.N[j]) > 0.0;
    if (2 * front > P.n && dec.T[j].norm() > 1e-12) cand[nc++] = j;
  }
  if (nc < 2) return false;
  // the decomposition closest to (R, t) is the pose itself; the other valid one is the twin
  std::array<double, 4> err{};
  for (int k = 0; k < nc; ++k) {
    const Vec3 tn = dec.T[cand[k]].normalized();
    err[k] = rotation_error_deg(R, dec.R[cand[k]]) + 57.29577951308232 * std::acos(std::clamp(tn.dot(t), -1.0, 1.0));
  }
  std::array<int, 4> order{};
  std::iota(order.begin(), order.begin() + nc, 0);
  std::stable_sort(order.begin(), order.begin() + nc, [&](int x, int y) { return err[x] < err[y]; });
  const int j = cand[order[1]];
  twin->R = dec.R[j];
  twin->t = dec.T[j].normalized();
  return true;
}

}  // namespace

bool homography_twin(const Pose& pose, const Points& P, Pose* twin, double* planarity) {
  const Mat3& R = pose.R;
  const Vec3 t = pose.t.norm() > 0.0 ? Vec3(pose.t.normalized()) : pose.t;
  // midpoint triangulation of the rays z1 R f1 + t and z2 f2 (geometry.triangulate_midpoint), in frame 1
  std::vector<Vec3> X;
  X.reserve(P.n);
  for (int i = 0; i < P.n; ++i) {
    const Vec3 a = R * P.a(i);
    const Vec3 b = P.b(i);
    const double ab = a.dot(b), at = a.dot(t), bt = b.dot(t);
    const double d = 1.0 - ab * ab;
    if (!(d > kParallelRays)) continue;  // zero depths: not in front
    const double z1 = (ab * bt - at) / d, z2 = (bt - ab * at) / d;
    if (!(z1 > 0.0 && z2 > 0.0)) continue;
    X.push_back(R.transpose() * (0.5 * (z1 * a + t + z2 * b) - t));
  }
  const int m = static_cast<int>(X.size());
  if (m < 4) return false;
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : X) c += x;
  c /= m;
  Eigen::MatrixX3d Xc(m, 3);
  for (int i = 0; i < m; ++i) Xc.row(i) = (X[i] - c).transpose();
  if (!Xc.allFinite()) return false;
  const Eigen::JacobiSVD<Eigen::MatrixX3d> svd(Xc, Eigen::ComputeThinV);
  Vec3 n = svd.matrixV().col(2);
  double d = n.dot(c);
  if (d < 0.0) {
    n = -n;
    d = -d;
  }
  *planarity = svd.singularValues()(2) / std::max(svd.singularValues()(1), kTiny);
  if (!(d > 0.0 && std::isfinite(d))) return false;
  return twin_of_homography(pose, R + t * n.transpose() / d, P, twin);
}

namespace {

constexpr double kDltPlanarShare = 0.9;  // homography_twin_dlt: the share of matches H must carry (TWIN_SUPPORT_RATIO)
// fit_homography: H is undetermined (a null space of two or more dimensions: collinear matches, or four
// with three on a line) when the second smallest singular value of the stacked rows is below this
// fraction of the largest (eigenvalues of their Gram matrix: its square)
constexpr double kHomographyRankRtol = 1e-6;

// The sign-fixed homography of the matches P fitted directly: the unit H minimising sum |f2 x H f1|^2
// (DLT on the bearings, all three rows of each cross product; the eigenvector of the smallest
// eigenvalue of the 9 x 9 normal matrix), signed so that H f1 points along f2 for most matches.
bool fit_homography(const Points& P, Mat3* H) {
  if (P.n < 4) return false;
  Eigen::Matrix<double, 9, 9> M = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i = 0; i < P.n; ++i) {
    const Vec3 a = P.a(i), b = P.b(i);
    // rows of [b]x (I kron a^T): (b x H a)_k = sum_j c_kj (H a)_j, with h = vec(H) row-major
    const Mat3 B = skew(b);
    Eigen::Matrix<double, 3, 9> A;
    for (int k = 0; k < 3; ++k)
      for (int r = 0; r < 3; ++r) A.block<1, 3>(k, 3 * r) = B(k, r) * a.transpose();
    M.noalias() += A.transpose() * A;
  }
  if (!M.allFinite()) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> es(M);
  if (es.info() != Eigen::Success) return false;
  const double lmax = es.eigenvalues()(8);
  if (!(lmax > 0.0) || !(es.eigenvalues()(1) > kHomographyRankRtol * kHomographyRankRtol * lmax)) return false;
  const Eigen::Matrix<double, 9, 1> h = es.eigenvectors().col(0);
  for (int r = 0; r < 3; ++r) H->row(r) = h.segment<3>(3 * r).transpose();
  int along = 0;
  for (int i = 0; i < P.n; ++i) along += (*H * P.a(i)).dot(P.b(i)) > 0.0;
  if (2 * along < P.n) *H = -*H;
  return H->allFinite();
}

}  // namespace

bool homography_twin_dlt(const Pose& pose, const Points& P, double max_transfer, Pose* twin) {
  Mat3 H;
  if (!fit_homography(P, &H)) return false;
  // planar in the images: H carries kDltPlanarShare of the matches to within max_transfer (a low-parallax
  // scene of depth is not: its H misses the parallax, and a twin from it is an artefact of the fit)
  int near = 0;
  for (int i = 0; i < P.n; ++i) {
    const Vec3 h = H * P.a(i), b = P.b(i);
    near += std::atan2(h.cross(b).norm(), h.dot(b)) < max_transfer;
  }
  if (!(near >= kDltPlanarShare * P.n)) return false;
  return twin_of_homography(pose, H, P, twin);
}

int support_count(const Pose& pose, const Points& P, double thr) {
  const PoseTerms T(pose);
  int k = 0;
  for (int i = 0; i < P.n; ++i) k += sampson_chiral(T, P.a(i), P.b(i)) < thr;
  return k;
}

namespace {

constexpr double kTwinSupportScreen = 0.3;  // analysis.plausible_twin: twin support >= 30 % of the pose's
constexpr double kPolishWindow = 1.5;       // polish and screen at 1.5 tau
constexpr int kPolishIterations = 20;
constexpr double kPolishTol = 1e-12;
constexpr int kLigtAngular = 2;             // refine_ligt normalization code of "angular"
constexpr double kMaxSupportThreshold = 0.5;
constexpr int kTwinMinInliers = 6;  // analysis.planar_twin: no twin from fewer inliers
// analyse_twin's DLT fallback: the transfer angle within which the homography must carry the inliers,
// in units of tau (two views' errors, as the rotation-only model's 2 tau in pure_rotation_test)
constexpr double kDltTransferFactor = 2.0;
// select_by_support: a candidate this close to the search's pose (pose_distance_deg; the challengers'
// distinct-basin distance, RansacOptions::challenger_distance) is another estimate of the same pose,
// not an alternative: a support count cannot rank two estimates of one pose (a noisier linear solve
// wins by one match as often as not), and the ML stage starts from what this choice returns
constexpr double kSameBasinDeg = 1.0;

bool is_rotation(const Mat3& R) {
  return R.allFinite() && (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() <= 1e-6 && R.determinant() >= 0.0;
}

}  // namespace

Pose polish_candidate(const Pose& pose, const Points& P, double tau) {
  const double thr = kPolishWindow * tau;
  const double nt = pose.t.norm();
  if (!is_rotation(pose.R) || !pose.t.allFinite() || !(nt > 1e-12)) return pose;
  Pose p = pose;
  p.t /= nt;
  const PoseTerms T(p);
  PointBuffer buf;
  const double thr_c = std::min(thr, kMaxSupportThreshold);
  for (int i = 0; i < P.n; ++i)
    if (sampson_chiral(T, P.a(i), P.b(i)) < thr_c) buf.push(P.f1 + 3 * i, P.f2 + 3 * i);
  if (buf.view().n < kRefineMinPoints) {
    buf.clear();
    for (int i = 0; i < P.n; ++i)
      if (sampson(T.E, P.a(i), P.b(i)) < thr) buf.push(P.f1 + 3 * i, P.f2 + 3 * i);
    if (buf.view().n < kRefineMinPoints) return pose;
  }
  RefineOptions o;
  o.loss = RefineLoss::Cauchy;
  o.loss_scale = tau;
  o.max_iterations = kPolishIterations;
  o.tol = kPolishTol;
  refine_ligt(buf.view(), nullptr, o, kLigtAngular, &p);
  return (p.R.allFinite() && p.t.allFinite()) ? p : pose;
}

namespace {

Pose unit_pose(const Pose& p) {
  Pose q = p;
  const double nt = q.t.norm();
  if (nt > 0.0) q.t /= nt;
  return q;
}

}  // namespace

namespace {

// Does pose T explain match (f1, f2) at thr: cheirality-consistent Sampson inlier, or with far_neutral a
// Sampson inlier whose rays are parallel to within thr. Why: a forward-moving camera's far points, whose
// parallax is below the noise, triangulate behind the true pose about half the time, and a rival of
// another rotation, for which they have parallax, keeps its own (a SLAM trial: KITTI ORB pairs whose
// pose was 0.02 deg off were called ambiguous against a rival 6.4 deg off, 69 of 1079 inliers dropped)
bool explains(const PoseTerms& T, const Vec3& f1, const Vec3& f2, double thr, bool far_neutral) {
  if (sampson_chiral(T, f1, f2) < thr) return true;
  return far_neutral && (T.R * f1).cross(f2).norm() < thr && sampson(T.E, f1, f2) < thr;
}

}  // namespace

SupportComparison compare_support(const Pose& a, const Pose& b, const Points& P, double thr, bool far_neutral) {
  const PoseTerms Ta(unit_pose(a)), Tb(unit_pose(b));
  SupportComparison s;
  for (int i = 0; i < P.n; ++i) {
    const bool ia = explains(Ta, P.a(i), P.b(i), thr, far_neutral), ib = explains(Tb, P.a(i), P.b(i), thr, far_neutral);
    s.a += ia;
    s.b += ib;
    s.only_a += ia && !ib;
    s.only_b += ib && !ia;
  }
  return s;
}

namespace {

// The homography twin of `pose` (unit t) from the matches `source` (its inliers), screened by its
// cheirality-consistent support on all matches `P` at min(1.5 tau, 0.5) (at least 30 % of the pose's:
// the twin of a non-planar scene keeps a few per cent, an unpolished planar twin 40-65 %) and polished.
// The pose-only choice (select_by_support) and the status analysis (analyse_twin) share it.
struct ScreenedTwin {
  bool found = false;   // a twin decomposition exists (planarity set)
  bool passed = false;  // it passed the screen (twin set, polished)
  double planarity = 0.0;
  Pose twin;
};

// the screen and polish of a twin candidate `tw` (ScreenedTwin::passed, twin)
void screen_twin(const Pose& pose, const Pose& tw, const Points& P, double tau, ScreenedTwin* out) {
  const double thr_s = std::min(kPolishWindow * tau, kMaxSupportThreshold);
  const int s0 = support_count(pose, P, thr_s), s1 = support_count(tw, P, thr_s);
  if (!(s1 >= kTwinSupportScreen * std::max(s0, 1))) return;
  out->passed = true;
  out->twin = polish_candidate(tw, P, tau);
}

ScreenedTwin screened_twin(const Pose& pose, const Points& source, const Points& P, double tau) {
  ScreenedTwin out;
  Pose tw;
  if (!homography_twin(pose, source, &tw, &out.planarity)) return out;
  out.found = true;
  screen_twin(pose, tw, P, tau, &out);
  return out;
}

}  // namespace

TwinAnalysis analyse_twin(const Pose& pose, const Points& P, const uint8_t* mask, double tau) {
  TwinAnalysis out;
  PointBuffer sel;
  for (int i = 0; i < P.n; ++i)
    if (mask[i]) sel.push(P.f1 + 3 * i, P.f2 + 3 * i);
  if (sel.view().n < kTwinMinInliers) return out;
  ScreenedTwin st = screened_twin(unit_pose(pose), sel.view(), P, tau);
  out.found = st.found;
  out.planarity = st.planarity;
  if (!st.passed) {
    // the homography fitted to the inliers directly: where the plane through the triangulated inliers
    // misses it (forward motion triangulates the points near the focus of expansion poorly, and towards
    // a plane the twins nearly merge: the first-order covariance then misses their valley)
    Pose tw;
    if (homography_twin_dlt(unit_pose(pose), sel.view(), kDltTransferFactor * tau, &tw)) screen_twin(unit_pose(pose), tw, P, tau, &st);
  }
  if (!st.passed) return out;
  out.compared = true;
  out.twin = st.twin;
  out.support = compare_support(pose, out.twin, P, std::min(tau, kMaxSupportThreshold));
  return out;
}

double median_rotation_angle(const Mat3& R, const Points& P, const uint8_t* mask) {
  std::vector<double> ang;
  ang.reserve(static_cast<size_t>(P.n));
  for (int i = 0; i < P.n; ++i) {
    if (!mask[i]) continue;
    const Vec3 a = R * P.a(i);
    const double c = a(0) * P.f2[3 * i] + a(1) * P.f2[3 * i + 1] + a(2) * P.f2[3 * i + 2];
    ang.push_back(std::acos(std::clamp(c, -1.0, 1.0)));
  }
  return median_of(&ang);
}

Pose select_by_support(const Pose& pose0, const Points& P, double tau) {
  Pose pose = pose0;
  const double nt = pose.t.norm();
  if (nt > 0.0) pose.t /= nt;
  PointBuffer sel;
  {
    const PoseTerms T(pose);
    for (int i = 0; i < P.n; ++i)
      if (sampson(T.E, P.a(i), P.b(i)) < tau) sel.push(P.f1 + 3 * i, P.f2 + 3 * i);
  }
  const Points S = sel.view();
  if (S.n < kLirpMinPoints) return pose0;
  Identified id;
  identify(essential(pose), S, nullptr, CostMode::Never, &id);
  const Pose base = id.pose;
  const double thr = std::min(tau, kMaxSupportThreshold);
  const int inl = support_count(base, P, thr);
  LirpResult lr;
  lirp(S, nullptr, false, &lr);
  std::vector<Pose> cand;
  cand.reserve(kLirpCandidates + 2);
  cand.push_back(base);
  for (int k = 0; k < kLirpCandidates; ++k) cand.push_back(lr.id[k].pose);
  const ScreenedTwin st = screened_twin(base, S, P, tau);
  if (st.passed) cand.push_back(st.twin);
  int best = 0, best_sup = -1;
  for (size_t k = 0; k < cand.size(); ++k) {
    if (k > 0 && !(pose_distance_deg(cand[k], base) >= kSameBasinDeg)) continue;
    const int s = support_count(cand[k], P, thr);
    if (s > best_sup) {
      best_sup = s;
      best = static_cast<int>(k);
    }
  }
  return best_sup > inl ? cand[best] : base;
}

double log_binom_sf(int64_t k, int64_t n, double p) {
  if (k <= 0) return 0.0;
  if (k > n || p <= 0.0) return -std::numeric_limits<double>::infinity();
  if (p >= 1.0) return 0.0;
  static std::mutex mu;
  static std::vector<double> lf{0.0};  // lf[j] = log j!
  std::lock_guard<std::mutex> lock(mu);
  if (static_cast<int64_t>(lf.size()) <= n) {
    const int64_t m = std::max<int64_t>(n + 1, 2 * static_cast<int64_t>(lf.size()));
    lf.reserve(static_cast<size_t>(m));
    for (int64_t i = static_cast<int64_t>(lf.size()); i < m; ++i) lf.push_back(lf.back() + std::log(static_cast<double>(i)));
  }
  const double lp = std::log(p), lq = std::log1p(-p);
  double mx = -std::numeric_limits<double>::infinity();
  for (int64_t j = k; j <= n; ++j) mx = std::max(mx, lf[n] - lf[j] - lf[n - j] + j * lp + (n - j) * lq);
  double sum = 0.0;
  for (int64_t j = k; j <= n; ++j) sum += std::exp(lf[n] - lf[j] - lf[n - j] + j * lp + (n - j) * lq - mx);
  return mx + std::log(sum);
}

double median_of(std::vector<double>* x) {
  std::vector<double>& a = *x;
  const size_t n = a.size();
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  for (double v : a)
    if (std::isnan(v)) return std::numeric_limits<double>::quiet_NaN();
  const size_t k = n / 2;
  std::nth_element(a.begin(), a.begin() + k, a.end());
  const double hi = a[k];
  if (n % 2) return hi;
  return (*std::max_element(a.begin(), a.begin() + k) + hi) / 2.0;
}

ParallaxResult parallax_ratio(const Mat3& R0, const Points& P, const double* v, double tau, const ParallaxOptions& o) {
  ParallaxResult out;
  out.R = R0;
  std::vector<int> sel;
  sel.reserve(P.n);
  for (int i = 0; i < P.n; ++i)
    if (v[i] < o.band * tau && (R0 * P.a(i) - P.b(i)).squaredNorm() < o.sel_chord2) sel.push_back(i);
  if (static_cast<int>(sel.size()) < o.min_matches) {
    out.ratio = out.noise = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  const size_t m = sel.size();
  std::vector<double> e2(m), tmp(m);
  for (size_t j = 0; j < m; ++j) e2[j] = v[sel[j]] * v[sel[j]];
  tmp = e2;
  const double med_e2 = std::max(median_of(&tmp), o.chi2_median * o.noise_floor * o.noise_floor);
  const double s2 = med_e2 / o.chi2_median;
  Mat3 R = R0;
  if (s2 > 0.0) {
    const double k = 1.0 / (o.cauchy_c * o.cauchy_c * s2);
    for (int r = 0; r < o.irls_rounds; ++r) {
      Mat3 C = Mat3::Zero();
      for (int i : sel) {
        const double w = 1.0 / (1.0 + 0.5 * (R * P.a(i) - P.b(i)).squaredNorm() * k);
        C += P.b(i) * (w * P.a(i)).transpose();
      }
      R = project_to_so3(C);
    }
  }
  for (size_t j = 0; j < m; ++j) tmp[j] = 0.5 * (R * P.a(sel[j]) - P.b(sel[j])).squaredNorm() - e2[j];
  const double med_par = median_of(&tmp);
  const double floor = o.min_parallax * tau;
  if (!(med_par > floor * floor))
    out.ratio = 0.0;  // no parallax beyond rounding (noise-free pure rotations, identical images)
  else if (med_e2 > 0.0)
    out.ratio = med_par / med_e2;
  else
    out.ratio = std::numeric_limits<double>::infinity();  // parallax without noise
  out.noise = std::sqrt(s2) / tau;
  out.R = R;
  out.refit = true;
  return out;
}

}  // namespace poseonly
