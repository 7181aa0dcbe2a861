// Undistortion of normalized image coordinates (poseonly.cameras.Camera.unproject; numpy reference:
// tests/reference/cameras.py). Newton's method per point with the analytic Jacobian, stopping at a
// relative step of `tol` or after `max_iter` steps; where it fails, a fallback from the radial map's
// root on its first branch (bracketed), damped Newton for Brown-Conrady; the same operations, in the
// same order, as the numpy reference, so the roots are the same floats.
#pragma once

#include <cstdint>

namespace poseonly {

// Brown-Conrady (COLMAP's SIMPLE_RADIAL ... FULL_OPENCV): k = (k1, k2, p1, p2, k3, k4, k5, k6). For each
// of the n points (xd, yd): the undistorted (u, v) and ok = converged, finite, locally invertible with
// preserved orientation at the root (det J > 0, radial factor > 0), inside the radial map's first fold
// (r -> r rad(r^2) increasing from 0 to |(u, v)|; checked up to r = 573, 89.9 deg off-axis) and
// reproducing (xd, yd) to 1e-9 (relative). n must fit an int (the binding checks).
void undistort_brown(const double* xd, const double* yd, int n, const double k[8], double tol, int max_iter, double* u, double* v,
                     uint8_t* ok);

// OpenCV fisheye: theta with theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8) = rd, k = (k1, k2, k3, k4);
// ok = converged, finite, 0 <= theta < pi, before the polynomial's first fold (the map increasing from 0
// to theta) and reproducing rd to 1e-9 (relative).
void undistort_fisheye(const double* rd, int n, const double k[4], double tol, int max_iter, double* theta, uint8_t* ok);

// COLMAP's thin-prism fisheye models, whose distortion acts on the equidistant coordinates (uu, vv) =
// theta (x, y) / |(x, y)|: kind 0 THIN_PRISM_FISHEYE, k = (k1, k2, p1, p2, k3, k4, sx1, sy1, 0, 0, 0, 0);
// kind 1 RAD_TAN_THIN_PRISM_FISHEYE (Aria's Fisheye624), k = (k0, ..., k5, p0, p1, s0, s1, s2, s3). For each
// of the n distorted points (xd, yd): the equidistant (uu, vv) and ok = converged, finite, theta =
// |(uu, vv)| before the radial part's first fold and below pi, the Jacobian's determinant > 0 at the root
// and reproducing (xd, yd) to 1e-9 (relative). Newton's method from the distorted point with the analytic
// Jacobian; where it fails, the radial part's bracketed root as the start of damped Newton (as Brown's).
void undistort_prism(const double* xd, const double* yd, int n, int kind, const double k[12], double tol, int max_iter, double* uu,
                     double* vv, uint8_t* ok);

}  // namespace poseonly
