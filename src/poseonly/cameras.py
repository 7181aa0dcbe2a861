"""Camera models: pixels <-> unit bearing vectors for real, distorted cameras.

A :class:`Camera` holds a COLMAP camera model (the same names, parameter orders and distortion
equations as COLMAP's ``src/colmap/sensor/models.h``) and lifts pixels ``(n, 2)`` to unit bearings
``(n, 3)`` (:meth:`Camera.unproject`) or projects camera-frame points ``(n, 3)`` to pixels
(:meth:`Camera.project`). Every perspective model of COLMAP 3.12 / 4 is supported natively (projection in
numpy; iterative undistortion in the compiled core, closed forms in numpy):

==============================  ==============================================================
``SIMPLE_PINHOLE``              ``f, cx, cy``
``PINHOLE``                     ``fx, fy, cx, cy``
``SIMPLE_RADIAL``               ``f, cx, cy, k``
``RADIAL``                      ``f, cx, cy, k1, k2``
``OPENCV``                      ``fx, fy, cx, cy, k1, k2, p1, p2``
``FULL_OPENCV``                 ``fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6``
``OPENCV_FISHEYE``              ``fx, fy, cx, cy, k1, k2, k3, k4`` (equidistant, ``theta_d(theta)``)
``SIMPLE_RADIAL_FISHEYE``       ``f, cx, cy, k`` (``OPENCV_FISHEYE`` with ``k1 = k``)
``RADIAL_FISHEYE``              ``f, cx, cy, k1, k2``
``SIMPLE_FISHEYE``, ``FISHEYE``   ``f, cx, cy`` / ``fx, fy, cx, cy`` (equidistant, no distortion)
``THIN_PRISM_FISHEYE``          ``fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1``
``RAD_TAN_THIN_PRISM_FISHEYE``  ``fx, fy, cx, cy, k0 .. k5, p0, p1, s0 .. s3`` (Aria's Fisheye624)
``FOV``                         ``fx, fy, cx, cy, omega`` (Devernay-Faugeras; closed form)
``SIMPLE_DIVISION``, ``DIVISION`` ``f, cx, cy, k`` / ``fx, fy, cx, cy, k`` (Fitzgibbon; closed form)
``EUCM``                        ``fx, fy, cx, cy, alpha, beta`` (closed form)
==============================  ==============================================================

COLMAP's spherical ``EQUIRECTANGULAR`` model is not supported (it has no focal length for the
pixel threshold). Where COLMAP's own unprojection is limited to the forward hemisphere (its
normalized plane), the fisheye, division and EUCM models here return the rays their image covers
beyond 90 deg as well (COLMAP's ``CamRayFromImg`` does the same for the fisheye models).

Undistortion is Newton's method per point with the analytic Jacobian (2-D for the Brown-Conrady and
thin-prism models, 1-D in ``theta`` for the fisheye polynomial), started at the distorted point and
stopped when its step is below :data:`NEWTON_TOL` (relative), in the core with the GIL released
(``src/core/cameras.cpp``; the numpy version it replaced for the Brown and fisheye-polynomial models, the
same roots bit for bit, is ``tests/reference/cameras.py``; the thin-prism models are tested against
scipy's root finder and pycolmap). Where it fails (on strong distortion it can oscillate, or land past
the radial map's first fold: a SLAM user's trial found in-image pixels of a fisheye and of a rational
camera refused), a fallback takes over: the root of the increasing radial map on its first branch (a
bracketed Newton / bisection; for the fisheye polynomial it is the root), then, for the 2-D models,
Newton steps halved until the residual decreases. Points with no root on the physical branch
(outside the region where the distortion is invertible, or outside the image disc of a closed-form
model) raise :class:`ValueError` naming how many and the first index.

Pixel convention: a camera maps pixels in the convention of its parameters, which
:func:`poseonly.estimate_relative_pose` assumes its pixels share. COLMAP's parameters (``cameras.txt``, a
``pycolmap.Camera``, the command line's ``--camera-params``) put the centre of the top-left pixel at
``(0.5, 0.5)``; OpenCV's keypoints (:mod:`poseonly.features`) at ``(0, 0)``. Where poseonly lifts its
own SIFT keypoints through such a camera (``poseonly relpose IMG1 IMG2 --camera-model ...``,
``poseonly sfm --camera-model ...``, :func:`poseonly.sfm.pairwise.image_view_graph` with ``camera``) it
adds :data:`OPENCV_TO_COLMAP_PX` first, and the COLMAP model it writes holds the shifted keypoints.

:func:`as_camera` accepts a :class:`Camera`, a ``pycolmap.Camera`` (duck-typed: ``model_name``,
``width``, ``height``, ``params``; pycolmap is not imported), a PoseLib/COLMAP-style dict
``{"model", "width", "height", "params"}``, a dict ``{"K", "dist"[, "fisheye"]}`` or a tuple ``(K, dist)``
with OpenCV distortion coefficients ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])``. Four coefficients are
``cv2.undistortPoints``' ``(k1, k2, p1, p2)``; ``cv2.fisheye``'s ``(k1, k2, k3, k4)`` need the flag:
``(K, dist, True)`` or ``{"K": K, "dist": dist, "fisheye": True}`` (read as ``(k1, k2, p1, p2)``, a
fisheye's coefficients give wrong poses: a user's trial, 6-10 deg off with status ``ok``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import _core
from .geometry import InputError, NonFiniteInputError, as_coordinates, as_real_array, nonfinite_rows_error, pair_focal

__all__ = ["MODELS", "NEWTON_TOL", "OPENCV_TO_COLMAP_PX", "Camera", "as_camera", "as_colmap_camera", "camera_from_text", "from_opencv", "lift_pair", "read_colmap_cameras"]

# model name -> parameter names (COLMAP order)
MODELS: dict[str, tuple[str, ...]] = {
    "SIMPLE_PINHOLE": ("f", "cx", "cy"),
    "PINHOLE": ("fx", "fy", "cx", "cy"),
    "SIMPLE_RADIAL": ("f", "cx", "cy", "k"),
    "RADIAL": ("f", "cx", "cy", "k1", "k2"),
    "OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"),
    "OPENCV_FISHEYE": ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"),
    "FULL_OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    "FOV": ("fx", "fy", "cx", "cy", "omega"),
    "SIMPLE_RADIAL_FISHEYE": ("f", "cx", "cy", "k"),
    "RADIAL_FISHEYE": ("f", "cx", "cy", "k1", "k2"),
    "THIN_PRISM_FISHEYE": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1"),
    "RAD_TAN_THIN_PRISM_FISHEYE": ("fx", "fy", "cx", "cy", "k0", "k1", "k2", "k3", "k4", "k5", "p0", "p1", "s0", "s1", "s2", "s3"),
    "SIMPLE_DIVISION": ("f", "cx", "cy", "k"),
    "DIVISION": ("fx", "fy", "cx", "cy", "k"),
    "SIMPLE_FISHEYE": ("f", "cx", "cy"),
    "FISHEYE": ("fx", "fy", "cx", "cy"),
    "EUCM": ("fx", "fy", "cx", "cy", "alpha", "beta"),
}
# the families (how a model maps pixels to bearings)
_BROWN = frozenset({"SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV", "FULL_OPENCV"})
_FISHEYE_POLY = frozenset({"OPENCV_FISHEYE", "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE", "SIMPLE_FISHEYE", "FISHEYE"})
_PRISM_KIND = {"THIN_PRISM_FISHEYE": 0, "RAD_TAN_THIN_PRISM_FISHEYE": 1}  # the core's undistort_prism kinds
_DIVISION = frozenset({"SIMPLE_DIVISION", "DIVISION"})
NEWTON_TOL = 1e-12  # relative step size at which Newton's undistortion stops
# added to OpenCV pixels (integer values at pixel centres) to get COLMAP's (centres at + 0.5)
OPENCV_TO_COLMAP_PX = 0.5
NEWTON_MAX_ITER = 100
_FISHEYE_EPS = 1e-12  # below this normalized radius a fisheye point is on the axis (no distortion)
# a projected pixel must lift back onto its direction within this distance of unit vectors (radians)
PROJECT_ROUND_TRIP_TOL = 1e-8
# lift_pair refuses pixels this far outside a camera's declared image (a fraction of its larger side, at least
# IMAGE_MARGIN_MIN_PX): a detector's keypoints are inside, up to the pixel convention and sub-pixel refinement
IMAGE_MARGIN_FRACTION = 0.01
IMAGE_MARGIN_MIN_PX = 2.0


def _brown_params(model: str, p: np.ndarray) -> tuple[float, ...]:
    """``(k1, k2, p1, p2, k3, k4, k5, k6)`` of a Brown-Conrady model (zeros where absent)."""
    z = 0.0
    if model == "SIMPLE_RADIAL":
        return (p[3], z, z, z, z, z, z, z)
    if model == "RADIAL":
        return (p[3], p[4], z, z, z, z, z, z)
    if model == "OPENCV":
        return (p[4], p[5], p[6], p[7], z, z, z, z)
    if model == "FULL_OPENCV":
        return tuple(float(v) for v in p[4:12])
    return (z,) * 8


def _fisheye_params(model: str, p: tuple[float, ...]) -> tuple[float, float, float, float]:
    """``(k1, k2, k3, k4)`` of ``theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)`` for the
    equidistant fisheye family (zeros where absent)."""
    if model == "OPENCV_FISHEYE":
        return (p[4], p[5], p[6], p[7])
    if model == "SIMPLE_RADIAL_FISHEYE":
        return (p[3], 0.0, 0.0, 0.0)
    if model == "RADIAL_FISHEYE":
        return (p[3], p[4], 0.0, 0.0)
    return (0.0, 0.0, 0.0, 0.0)  # SIMPLE_FISHEYE, FISHEYE: equidistant


def _prism_params(model: str, p: tuple[float, ...]) -> np.ndarray:
    """The 12 coefficients of the core's ``undistort_prism`` (``THIN_PRISM_FISHEYE``'s 8 padded)."""
    k = np.zeros(12)
    extra = p[4:]
    k[: len(extra)] = extra
    return k


def _fisheye_bearings(uu: np.ndarray, vv: np.ndarray) -> np.ndarray:
    """Equidistant coordinates (``theta = |(uu, vv)|`` off the axis) -> bearings ``(n, 3)`` (unnormalised)."""
    with np.errstate(all="ignore"):  # the rows of unconverged points (NaN or inf) are set to NaN by the caller
        theta = np.hypot(uu, vv)
        s = np.where(theta > _FISHEYE_EPS, np.sin(theta) / theta, 1.0)
        return np.column_stack([uu * s, vv * s, np.cos(theta)])


@dataclass(frozen=True)
class Camera:
    """A calibrated camera: ``model`` (a key of :data:`MODELS`), image ``width``/``height`` (pixels,
    0 when unknown) and ``params`` in COLMAP order."""

    model: str
    width: int
    height: int
    params: tuple[float, ...]

    def __post_init__(self) -> None:
        if isinstance(self.model, str):  # COLMAP's names in any case, as the dict and text forms take them
            object.__setattr__(self, "model", self.model.upper())
        if not isinstance(self.model, str) or self.model not in MODELS:
            raise InputError(f"unsupported camera model {self.model!r}; supported: {sorted(MODELS)}")
        names = MODELS[self.model]
        try:
            if self.params is None or np.iscomplexobj(self.params) or isinstance(self.params, (str, bytes)):
                raise TypeError
            raw = np.asarray(self.params, dtype=object).ravel()
            if any(isinstance(v, (str, bytes, bool, np.bool_)) for v in raw):  # "900" or True is not a number (a trial)
                raise TypeError
            params = tuple(float(v) for v in np.asarray(self.params, dtype=float).ravel())
        except (TypeError, ValueError):
            raise InputError(f"camera parameters must be real numbers, got {self.params!r}") from None
        object.__setattr__(self, "params", params)
        for side in ("width", "height"):
            object.__setattr__(self, side, _whole_pixels(getattr(self, side), side))
        if len(self.params) != len(names):
            raise InputError(f"camera model {self.model} takes {len(names)} parameters ({', '.join(names)}), got {len(self.params)}")
        p = np.asarray(self.params, dtype=float)
        if not np.all(np.isfinite(p)):
            raise InputError(f"camera parameters contain NaN or inf: {list(self.params)}")
        if self.focal_xy[0] <= 0 or self.focal_xy[1] <= 0:
            raise InputError(f"camera focal length must be > 0, got {self.focal_xy}")
        if self.width < 0 or self.height < 0:
            raise InputError(f"camera width/height must be >= 0, got {self.width}x{self.height}")
        (cx, cy), (w, h) = self.principal_point, (self.width, self.height)
        if w > 0 and h > 0 and not (0.0 <= cx <= w and 0.0 <= cy <= h):  # normalised units or a swap (a trial)
            raise InputError(
                f"camera principal point ({cx:g}, {cy:g}) lies outside its declared {w}x{h} image: are the parameters in"
                " pixels and in the model's order? (declare width and height 0 for a crop whose principal point is outside)"
            )
        if self.model == "FOV" and not abs(self.params[4]) < np.pi:
            raise InputError(f"FOV camera needs |omega| < pi (the field of view), got omega {self.params[4]}")
        if self.model == "EUCM" and not (0.0 <= self.params[4] <= 1.0 and self.params[5] > 0.0):
            raise InputError(f"EUCM camera needs 0 <= alpha <= 1 and beta > 0 (COLMAP's check), got alpha {self.params[4]}, beta {self.params[5]}")

    # -- parameters ------------------------------------------------------------------------------

    @property
    def focal_xy(self) -> tuple[float, float]:
        p = self.params
        return (p[0], p[0]) if MODELS[self.model][0] == "f" else (p[0], p[1])

    @property
    def principal_point(self) -> tuple[float, float]:
        p = self.params
        return (p[1], p[2]) if MODELS[self.model][0] == "f" else (p[2], p[3])

    @property
    def focal_px(self) -> float:
        """Mean focal length in pixels: converts a pixel threshold to an angle (``tau = px / f``)."""
        fx, fy = self.focal_xy
        return 0.5 * fx + 0.5 * fy  # no overflow

    @property
    def K(self) -> np.ndarray:
        """The ``(3, 3)`` calibration matrix (without the distortion)."""
        (fx, fy), (cx, cy) = self.focal_xy, self.principal_point
        return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])

    @property
    def is_undistorted(self) -> bool:
        """True when the camera is a pinhole camera: a perspective model whose distortion parameters are
        all zero (an EUCM with ``alpha = 0``). The fisheye models are never (equidistant at zero
        distortion: straight lines bend)."""
        if self.model in _FISHEYE_POLY or self.model in _PRISM_KIND:
            return False
        n_base = 3 if MODELS[self.model][0] == "f" else 4  # focal(s) and principal point
        if self.model == "EUCM":
            return self.params[4] == 0.0
        return not any(self.params[n_base:])

    def to_dict(self) -> dict[str, Any]:
        """PoseLib/COLMAP-style ``{"model", "width", "height", "params"}``."""
        return {"model": self.model, "width": self.width, "height": self.height, "params": list(self.params)}

    # -- distortion in normalized coordinates ------------------------------------------------------

    def _distort_brown(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k1, k2, p1, p2, k3, k4, k5, k6 = _brown_params(self.model, np.asarray(self.params))
        r2 = u * u + v * v
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        rad = num / den
        uv = u * v
        return u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u), v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v)

    def _undistort_brown(self, xd: np.ndarray, yd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Newton on ``distort(u, v) = (xd, yd)`` with the analytic 2x2 Jacobian, in the core (GIL
        released); returns ``u, v`` and a mask of the points that converged to the physical root (the map
        locally invertible and orientation-preserving there, ``det J > 0``, the radial factor positive: past
        the distortion's fold Newton can reach a spurious root) and reproduce the distorted point."""
        k = np.array(_brown_params(self.model, np.asarray(self.params)), dtype=np.float64)
        u, v, ok = _core.undistort_brown(np.ascontiguousarray(xd, dtype=np.float64), np.ascontiguousarray(yd, dtype=np.float64), k, NEWTON_TOL, NEWTON_MAX_ITER)
        return u, v, ok.astype(bool)

    def _fisheye_poly(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``theta_d(theta) = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8)`` and its derivative."""
        k1, k2, k3, k4 = _fisheye_params(self.model, self.params)
        t2 = theta * theta
        poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
        dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
        return theta * poly, dpoly

    # -- public mapping ----------------------------------------------------------------------------

    def unproject(self, uv: np.ndarray, invalid: str = "raise") -> np.ndarray:
        """Pixels ``(n, 2)`` -> unit bearing vectors ``(n, 3)`` (camera frame, ``z`` forward).

        Raises :class:`ValueError` for bad shapes / non-finite values, and for points where the
        undistortion does not converge unless ``invalid="nan"`` (their rows are then NaN)."""
        if invalid not in ("raise", "nan"):
            raise InputError(f"invalid must be 'raise' or 'nan', got {invalid!r}")
        uv = _check_points(uv, 2, "uv")
        ok = np.ones(len(uv), bool)
        (fx, fy), (cx, cy) = self.focal_xy, self.principal_point
        xd = (uv[:, 0] - cx) / fx
        yd = (uv[:, 1] - cy) / fy
        if self.model in _FISHEYE_POLY:
            rd = np.hypot(xd, yd)
            k = np.array(_fisheye_params(self.model, self.params), dtype=np.float64)
            theta, ok8 = _core.undistort_fisheye(np.ascontiguousarray(rd), k, NEWTON_TOL, NEWTON_MAX_ITER)  # Newton, GIL released
            ok = ok8.astype(bool)
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(rd > _FISHEYE_EPS, np.sin(theta) / rd, 1.0)
            b = np.column_stack([xd * s, yd * s, np.cos(theta)])
        elif self.model in _PRISM_KIND:
            uu, vv, ok8 = _core.undistort_prism(
                np.ascontiguousarray(xd), np.ascontiguousarray(yd), _PRISM_KIND[self.model], _prism_params(self.model, self.params), NEWTON_TOL, NEWTON_MAX_ITER
            )
            ok = ok8.astype(bool)
            b = _fisheye_bearings(uu, vv)
        elif self.model == "FOV":
            b, ok = _fov_unproject(xd, yd, self.params[4])
        elif self.model in _DIVISION:
            kd = self.params[-1]  # Fitzgibbon: the ray (x, y, 1 + k r^2); past its fold (k r^2 = 1) a ray maps twice
            r2 = xd * xd + yd * yd
            ok = kd * r2 < 1.0 if kd > 0 else np.ones(len(xd), bool)
            b = np.column_stack([xd, yd, 1.0 + kd * r2])
        elif self.model == "EUCM":
            b, ok = _eucm_unproject(xd, yd, self.params[4], self.params[5])
        else:
            if self.is_undistorted:
                u, v = xd, yd
            else:
                u, v, ok = self._undistort_brown(xd, yd)
            b = np.column_stack([u, v, np.ones_like(u)])
        if invalid == "raise":
            _raise_unconverged(ok, uv, self.model)
        b[~ok] = np.nan
        with np.errstate(invalid="ignore"):
            return b / np.linalg.norm(b, axis=1)[:, None]

    def project(self, X: np.ndarray) -> np.ndarray:
        """Camera-frame points or bearings ``(n, 3)`` -> pixels ``(n, 2)``: NaN for the directions the
        camera does not image. Those are, for the perspective models (FOV too), ``z <= 0``; for the
        fisheye models the ``-z`` axis; for the division and EUCM models the directions outside the
        image their model covers; and, for the models undistorted iteratively, every direction whose
        pixel :meth:`unproject` does not lift back onto it: past the distortion's first fold a
        direction comes back folded into the image, onto a pixel whose ray is another direction (as
        COLMAP's and OpenCV's projections give it; a fuzz of random lenses found them)."""
        X = _check_points(X, 3, "X")
        (fx, fy), (cx, cy) = self.focal_xy, self.principal_point
        if self.model in _FISHEYE_POLY or self.model in _PRISM_KIND:
            r = np.hypot(X[:, 0], X[:, 1])
            theta = np.arctan2(r, X[:, 2])
            # theta_d / r: the poly family's distorted radius, or the equidistant one for the thin-prism models
            g = self._fisheye_poly(theta)[0] if self.model in _FISHEYE_POLY else theta
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(r > _FISHEYE_EPS * np.abs(X[:, 2]), g / r, 1.0 / X[:, 2])
            s = np.where((r <= _FISHEYE_EPS * np.abs(X[:, 2])) & (X[:, 2] < 0), np.nan, s)  # the -z axis has no image
            with np.errstate(invalid="ignore"):
                xd, yd = X[:, 0] * s, X[:, 1] * s
            if self.model in _PRISM_KIND:
                xd, yd = _prism_distort(_PRISM_KIND[self.model], _prism_params(self.model, self.params), xd, yd)
        elif self.model == "FOV":
            xd, yd = _fov_project(X, self.params[4])
        elif self.model in _DIVISION:
            xd, yd = _division_project(X, self.params[-1])
        elif self.model == "EUCM":
            xd, yd = _eucm_project(X, self.params[4], self.params[5])
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(X[:, 2] > 0, X[:, 2], np.nan)
            xd, yd = self._distort_brown(X[:, 0] / z, X[:, 1] / z)
        px = np.column_stack([fx * xd + cx, fy * yd + cy])
        iterative = self.model in _FISHEYE_POLY or self.model in _PRISM_KIND or (self.model in _BROWN and not self.is_undistorted)
        fin = np.flatnonzero(np.isfinite(px).all(axis=1))
        if iterative and len(fin) and not (self.model in _FISHEYE_POLY and not any(_fisheye_params(self.model, self.params))):
            with np.errstate(all="ignore"):
                back = self.unproject(px[fin], invalid="nan")
                d = X[fin] / np.abs(X[fin]).max(axis=1)[:, None]  # no overflow in the norm of huge points
                d /= np.linalg.norm(d, axis=1)[:, None]
                off = ~(np.linalg.norm(back - d, axis=1) <= PROJECT_ROUND_TRIP_TOL)
            px[fin[off]] = np.nan
        return px


def _prism_distort(kind: int, k: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """COLMAP's thin-prism distortions of equidistant coordinates ``(u, v)`` (the core's
    ``prism_distort``, without the Jacobian): kind 0 ``THIN_PRISM_FISHEYE``, 1 ``RAD_TAN_THIN_PRISM_FISHEYE``."""
    if kind == 0:
        k1, k2, p1, p2, k3, k4, sx1, sy1 = k[:8]
        r2 = u * u + v * v
        radial = r2 * (k1 + r2 * (k2 + r2 * (k3 + r2 * k4)))
        return (
            u + u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u) + sx1 * r2,
            v + v * radial + 2.0 * p2 * u * v + p1 * (r2 + 2.0 * v * v) + sy1 * r2,
        )
    p0, p1, s0, s1, s2, s3 = k[6:]
    t2 = u * u + v * v
    th = np.zeros_like(t2)
    for c in k[5::-1]:
        th = th * t2 + c
    th = 1.0 + th * t2
    a, b = th * u, th * v
    r2 = a * a + b * b
    return a + 2.0 * p1 * a * b + p0 * (r2 + 2.0 * a * a) + r2 * (s0 + s1 * r2), b + 2.0 * p0 * a * b + p1 * (r2 + 2.0 * b * b) + r2 * (s2 + s3 * r2)


def _fov_unproject(xd: np.ndarray, yd: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """FOV (Devernay-Faugeras): the ray at ``atan(tan(r_d omega) / (2 tan(omega / 2)))`` off the axis,
    as the unnormalised ``(x sin(r_d w) / r_d, y sin(r_d w) / r_d, 2 tan(w / 2) cos(r_d w))`` with
    ``w = |omega|`` (no division by a tangent near 90 deg); the image covers ``r_d w < pi / 2``."""
    w = abs(omega)
    if w == 0.0:
        return np.column_stack([xd, yd, np.ones_like(xd)]), np.ones(len(xd), bool)
    rd = np.hypot(xd, yd)
    ang = rd * w
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(rd > _FISHEYE_EPS, np.sin(ang) / rd, w)
    return np.column_stack([xd * s, yd * s, 2.0 * np.tan(0.5 * w) * np.cos(ang)]), ang < 0.5 * np.pi


def _fov_project(X: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """FOV: ``r_d = atan(2 r tan(omega / 2)) / omega`` of the normalised radius ``r`` (``z > 0``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(X[:, 2] > 0, X[:, 2], np.nan)
        w = abs(omega)
        if w == 0.0:
            return X[:, 0] / z, X[:, 1] / z
        t2 = 2.0 * np.tan(0.5 * w)
        rho = np.hypot(X[:, 0], X[:, 1])
        f = np.where(rho > _FISHEYE_EPS * z, np.arctan2(rho * t2, z) / (rho * w), t2 / (z * w))
        return X[:, 0] * f, X[:, 1] * f


def _division_project(X: np.ndarray, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Division model: the point ``r (x, y)`` with ``r = 2 / (z + sqrt(z^2 - 4 k rho^2))`` (the root on
    the first branch; NaN where the image does not reach the direction)."""
    rho2 = X[:, 0] ** 2 + X[:, 1] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        den = X[:, 2] + np.sqrt(X[:, 2] ** 2 - 4.0 * k * rho2)
        r = np.where(den > 0, 2.0 / den, np.nan)
    return X[:, 0] * r, X[:, 1] * r


def _eucm_unproject(xd: np.ndarray, yd: np.ndarray, alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """EUCM (Khomutenko et al. 2016): the ray ``(x, y, (1 - alpha^2 beta r^2) / (alpha sqrt(1 - (2 alpha -
    1) beta r^2) + 1 - alpha))``; its image is the disc where the square root is real."""
    r2 = xd * xd + yd * yd
    rad = 1.0 - (2.0 * alpha - 1.0) * beta * r2
    with np.errstate(invalid="ignore", divide="ignore"):
        den = alpha * np.sqrt(rad) + (1.0 - alpha)
        mz = (1.0 - alpha * alpha * beta * r2) / den
    return np.column_stack([xd, yd, mz]), (rad >= 0) & (den > 0)


def _eucm_project(X: np.ndarray, alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """EUCM: ``(x, y) / (alpha d + (1 - alpha) z)``, ``d = sqrt(beta (x^2 + y^2) + z^2)``, for the
    directions the model images (``z > -w d``, ``w = alpha / (1 - alpha)`` up to ``alpha = 1/2``, then
    ``(1 - alpha) / alpha``)."""
    d = np.sqrt(beta * (X[:, 0] ** 2 + X[:, 1] ** 2) + X[:, 2] ** 2)
    w = alpha / (1.0 - alpha) if alpha <= 0.5 else (1.0 - alpha) / alpha
    den = alpha * d + (1.0 - alpha) * X[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where((X[:, 2] > -w * d) & (den > 0), 1.0 / den, np.nan)
    return X[:, 0] * s, X[:, 1] * s


def _whole_pixels(v: Any, side: str) -> int:
    """A camera's width or height: a whole number of pixels >= 0 (an integral float too; 0: unknown)."""
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v[()]
    ok = not isinstance(v, (bool, np.bool_)) and isinstance(v, (int, np.integer, float, np.floating)) and np.isfinite(v) and float(v) == round(float(v)) and v >= 0
    if not ok:
        raise InputError(f"camera {side} must be a whole number of pixels (0: unknown), got {v!r}")
    return int(v)


def _check_points(a: Any, d: int, name: str) -> np.ndarray:
    a = as_coordinates(a, name)  # complex, string, boolean ... refused as with K (a trial)
    if a.ndim != 2 or a.shape[1] != d:
        raise InputError(f"{name} must have shape (n, {d}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise nonfinite_rows_error(a, name)
    return a


def _raise_unconverged(ok: np.ndarray, uv: np.ndarray, model: str) -> None:
    if not ok.all():
        bad = np.nonzero(~ok)[0]
        raise InputError(
            f"undistortion ({model}) did not converge for {len(bad)} of {len(uv)} points (first: index "
            f"{bad[0]}, pixel {uv[bad[0]].tolist()}): the points lie outside the region where the "
            "distortion model is invertible (leave such matches out first: np.isfinite(camera.unproject(uv, "
            "invalid='nan')).all(axis=1) marks the points it can lift; poseonly relpose and poseonly.pipeline.relpose_matches "
            "leave such matches out and count them)"
        )


def from_opencv(K: Any, dist: Any = None, width: int = 0, height: int = 0, *, fisheye: bool = False) -> Camera:
    """``K (3, 3)`` + OpenCV distortion coefficients -> :class:`Camera`.

    ``dist``: ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])`` (``cv2.undistortPoints``' order; 4 -> ``OPENCV``,
    5 or 8 -> ``FULL_OPENCV``; 12 or 14 with zero thin-prism / tilt terms as 8; other lengths refused), or with ``fisheye=True`` ``(k1, k2, k3, k4)`` (``cv2.fisheye``) ->
    ``OPENCV_FISHEYE``. ``None`` or all zeros -> ``PINHOLE``. ``K`` must have zero skew."""
    Kf = as_real_array(K, "K")
    if Kf.shape != (3, 3):
        raise InputError(f"K must be a 3x3 matrix, got shape {Kf.shape}")
    if not np.all(np.isfinite(Kf)):
        raise InputError(f"K contains NaN or inf values: {Kf.tolist()}")
    if Kf[2, 2] != 0.0 and np.all(Kf[2, :2] == 0.0):  # a scaled K (s K) is K, as K1= takes it (a trial)
        Kf = Kf / Kf[2, 2]
    if abs(Kf[0, 1]) > 1e-12 * abs(Kf[0, 0]) or np.any(np.abs(Kf[2] - [0, 0, 1]) > 1e-12) or Kf[1, 0] != 0:
        raise InputError(f"K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew), got {Kf.tolist()}")
    base = (Kf[0, 0], Kf[1, 1], Kf[0, 2], Kf[1, 2])
    try:
        d = np.zeros(0) if dist is None else np.asarray(dist, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"distortion coefficients must be real numbers, got {dist!r}") from None
    if not np.all(np.isfinite(d)):
        raise InputError("distortion coefficients contain NaN or inf values")
    if fisheye:
        if len(d) != 4:
            raise InputError(f"fisheye distortion takes 4 coefficients (k1, k2, k3, k4), got {len(d)}")
        return Camera("OPENCV_FISHEYE", width, height, tuple(float(v) for v in (*base, *d)))
    if len(d) not in (0, 4, 5, 8, 12, 14):  # OpenCV's lengths (a 7-vector of zeros was a pinhole: a trial)
        raise InputError(f"OpenCV distortion takes 4, 5, 8, 12 or 14 coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1..s4[, tx, ty]]]]), got {len(d)}")
    if len(d) > 8 and np.any(d[8:]):
        raise InputError(f"thin-prism / tilt distortion coefficients (s1..s4, tx, ty) are not supported, got {d[8:].tolist()}")
    d = d[:8]
    if len(d) == 0 or not np.any(d):
        return Camera("PINHOLE", width, height, tuple(float(v) for v in base))
    if len(d) == 4:
        return Camera("OPENCV", width, height, tuple(float(v) for v in (*base, *d)))
    full = np.zeros(8)
    full[: len(d)] = d  # OpenCV order k1 k2 p1 p2 k3 k4 k5 k6 = FULL_OPENCV's
    return Camera("FULL_OPENCV", width, height, tuple(float(v) for v in (*base, *full)))


def as_camera(spec: Any, name: str = "camera") -> Camera:
    """A :class:`Camera` from any accepted camera description (see the module docstring); an error in
    it names the camera (``name: ...``: which of a rig's calibrations is wrong)."""
    try:
        return _as_camera(spec, name)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(f"{name}") else f"{name}: {msg}") from None


def _as_camera(spec: Any, name: str) -> Camera:
    if isinstance(spec, Camera):
        return spec
    if hasattr(spec, "model_name") and hasattr(spec, "params") and hasattr(spec, "width"):  # pycolmap.Camera
        model = str(spec.model_name)
        if model not in MODELS:
            raise InputError(f"{name}: pycolmap camera model {model} is not supported; supported: {sorted(MODELS)}")
        return Camera(model, spec.width, spec.height, spec.params)
    if isinstance(spec, Mapping):
        if "K" in spec:
            extra = set(spec) - {"K", "dist", "width", "height", "fisheye"}
            if extra:
                raise InputError(f"{name}: unknown keys {sorted(extra)} (K-style camera keys: K, dist, width, height, fisheye)")
            fisheye = spec.get("fisheye", False)
            if not isinstance(fisheye, (bool, np.bool_)):
                raise InputError(f"{name}: fisheye must be True or False, got {fisheye!r}")
            return from_opencv(spec["K"], spec.get("dist"), spec.get("width", 0), spec.get("height", 0), fisheye=bool(fisheye))
        missing = {"model", "params"} - set(spec)
        if missing:
            raise InputError(f"{name}: a camera dict needs keys model, width, height, params (or K, dist); missing {sorted(missing)}")
        extra = set(spec) - {"model", "width", "height", "params"}
        if extra:
            raise InputError(f"{name}: unknown keys {sorted(extra)} (COLMAP-style camera keys: model, width, height, params; the distortion is in params)")
        model = spec["model"]
        if not isinstance(model, str):
            raise InputError(f"{name}: camera model must be a string, got {type(model).__name__}")
        return Camera(model.upper(), spec.get("width", 0), spec.get("height", 0), spec["params"])  # Camera checks params
    if isinstance(spec, tuple) and len(spec) in (2, 3):
        fisheye = spec[2] if len(spec) == 3 else False
        if not isinstance(fisheye, (bool, np.bool_)):
            raise InputError(f"{name}: the third item of a (K, dist, fisheye) tuple must be True or False, got {fisheye!r}")
        return from_opencv(spec[0], spec[1], fisheye=bool(fisheye))
    raise InputError(
        f"{name} must be a poseonly Camera, a pycolmap.Camera, a dict {{model, width, height, params}}, a dict {{K, dist}} or a tuple (K, dist) /"
        f" (K, dist, fisheye); got {type(spec).__name__}"
    )


def as_colmap_camera(spec: Any, name: str = "camera") -> Camera:
    """:func:`as_camera` in COLMAP's pixel convention, for lifting poseonly's own (OpenCV) keypoints
    shifted by :data:`OPENCV_TO_COLMAP_PX`: an OpenCV description (a tuple ``(K, dist)`` or a dict
    with ``K``) has its principal point moved by the same amount; the others (COLMAP, PoseLib, a
    :class:`Camera`) are taken to be in COLMAP's convention already."""
    cam = as_camera(spec, name)
    if not (isinstance(spec, tuple) or (isinstance(spec, Mapping) and "K" in spec)):
        return cam
    p = list(cam.params)
    i = 1 if MODELS[cam.model][0] == "f" else 2  # cx, cy
    p[i] += OPENCV_TO_COLMAP_PX
    p[i + 1] += OPENCV_TO_COLMAP_PX
    return Camera(cam.model, cam.width, cam.height, tuple(p))


def _text_pixels(v: Any, side: str, name: str) -> Any:
    """A width / height given as text (``"640"``) as its integer; anything else as given (Camera checks it)."""
    if isinstance(v, str):
        try:
            return int(v.strip())
        except ValueError:
            raise InputError(f"{name}: camera {side} must be a whole number of pixels, got {v!r}") from None
    return v


def camera_from_text(model: str, params: str, width: int = 0, height: int = 0, name: str = "camera") -> Camera:
    """A :class:`Camera` from a COLMAP model name (any case) and its parameters as text in COLMAP's
    order, separated by commas and / or spaces (as COLMAP's ``--ImageReader.camera_model /
    camera_params``), e.g. ``("SIMPLE_RADIAL", "1200,640,480,-0.05")``; :class:`InputError` naming
    ``name`` otherwise (an empty field, as in ``"800,,320"``, is an error)."""
    if not isinstance(model, str) or not isinstance(params, str):
        raise InputError(f"{name}: the model and the parameters must be text, got {model!r} and {params!r}")
    fields = re.split(r"\s*,\s*|\s+", params.strip())
    if len(fields) > 1 and fields[-1] == "":  # a trailing separator
        fields = fields[:-1]
    try:
        if "" in fields:
            raise ValueError
        values = tuple(float(v) for v in fields)
    except ValueError:
        raise InputError(f"{name}: the parameters must be numbers separated by commas or spaces, got {params!r}") from None
    try:
        w, h = (_text_pixels(v, side, name) for v, side in ((width, "width"), (height, "height")))
        return Camera(model.upper(), w, h, values)  # (Camera checks whole pixels: 640.7 was truncated)
    except InputError as exc:
        raise InputError(f"{name}: {exc}") from None


def read_colmap_cameras(source: str | os.PathLike | Iterable[str], *, skip_unsupported: bool = False) -> dict[int, Camera]:
    """The cameras of a COLMAP ``cameras.txt`` (a path, or its lines): ``{camera_id: Camera}`` from the
    lines ``CAMERA_ID MODEL WIDTH HEIGHT PARAMS...`` (``#`` comments and blank lines skipped); an
    :class:`InputError` naming the line for a malformed one or a repeated id (a SLAM user's trial: a
    ``cameras.txt`` line had no parser). ``skip_unsupported``: leave out the cameras of a model
    :data:`MODELS` does not hold (e.g. ``EQUIRECTANGULAR``) instead of refusing the file (a camera
    trial: one such camera stopped a file whose other cameras were needed)."""
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        if not path.is_file():
            raise InputError(f"cameras file not found: {path}")
        try:
            lines, where = path.read_text(encoding="utf-8").splitlines(), str(path)
        except UnicodeDecodeError as exc:
            raise InputError(f"cameras file {path} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    else:
        lines, where = list(source), "cameras"
    out: dict[int, Camera] = {}
    for no, line in enumerate(lines, 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        f = text.split()
        name = f"{where} line {no}"
        if len(f) < 5:
            raise InputError(f"{name}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS..., got {text!r}")
        try:
            cid, width, height = int(f[0]), int(f[2]), int(f[3])
        except ValueError:
            raise InputError(f"{name}: CAMERA_ID, WIDTH and HEIGHT must be integers, got {text!r}") from None
        if cid < 0:
            raise InputError(f"{name}: camera id {cid} is negative")
        if cid in out:
            raise InputError(f"{name}: camera id {cid} is given twice")
        if skip_unsupported and f[1].upper() not in MODELS:
            continue
        out[cid] = camera_from_text(f[1], " ".join(f[4:]), width, height, name)
    return out


def _check_inside_image(cam: Camera, uv: np.ndarray, name: str) -> None:
    """Refuse pixels ``(n, 2)`` outside ``cam``'s declared image by more than :data:`IMAGE_MARGIN_FRACTION`
    of its larger side (a detector's keypoints are inside): the matches and the camera disagree
    (keypoints of another resolution, or of the other view). Unknown sizes (0) are not checked."""
    w, h = cam.width, cam.height
    if w <= 0 or h <= 0:
        return
    m = max(IMAGE_MARGIN_MIN_PX, IMAGE_MARGIN_FRACTION * max(w, h))
    with np.errstate(invalid="ignore"):
        out = (uv[:, 0] < -m) | (uv[:, 0] > w + m) | (uv[:, 1] < -m) | (uv[:, 1] > h + m)
    if out.any():
        i = int(np.flatnonzero(out)[0])
        raise InputError(
            f"{name}: {int(out.sum())} of {len(uv)} pixels lie outside the camera's declared {w}x{h} image (the first is row {i},"
            f" pixel {uv[i].tolist()}): the matches and the camera disagree (keypoints of another resolution, or of the other"
            " view?); declare width and height 0 to skip this check"
        )


def lift_pair(x1: Any, x2: Any, camera1: Any, camera2: Any = None, invalid: str = "raise") -> tuple[np.ndarray, np.ndarray, float]:
    """Pixels ``(n, 2)`` of two views -> bearings ``(n, 3), (n, 3)`` and the focal length (pixels) for
    the threshold conversion (:func:`poseonly.geometry.pair_focal` of the two cameras'). ``camera2``
    defaults to ``camera1``; ``invalid`` as :meth:`Camera.unproject`'s (``"nan"``: NaN rows for the
    points a camera cannot lift)."""
    c1 = as_camera(camera1, "camera1")
    c2 = c1 if camera2 is None else as_camera(camera2, "camera2")
    for x, nm in ((x1, "x1"), (x2, "x2")):
        a = np.asarray(x)
        if a.ndim == 2 and a.shape[1] == 3:
            raise InputError(f"{nm} has shape (n, 3) (bearing vectors) but a camera was given; pass pixels (n, 2)")
    out = []
    for cam, x, nm in ((c1, x1, "x1"), (c2, x2, "x2")):
        try:
            out.append(cam.unproject(x, invalid))
        except InputError as exc:  # which view (a batch trial: "uv contains NaN" named neither)
            raise (NonFiniteInputError if isinstance(exc, NonFiniteInputError) else InputError)(f"{nm}: {exc}") from None
        _check_inside_image(cam, as_coordinates(x, nm), nm)  # (n, 2): unproject took it
    return out[0], out[1], pair_focal(c1.focal_px, c2.focal_px)
