"""LiRP (Alg. 1) exactness, planar twin, pure rotation, weights and bad input."""

import numpy as np
import pytest

from poseonly import lirp, rotation_error_deg, translation_error_deg
from poseonly.geometry import skew
from poseonly.sim import make_scene


@pytest.mark.parametrize("n", [6, 8, 30, 300])
@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_exact_normal(n, camera):
    for s in range(100):
        sc = make_scene(n, "normal", camera, seed=s)
        r = lirp(sc.f1, sc.f2)
        assert r.status == "ok"
        assert rotation_error_deg(sc.R, r.R) < 1e-6, s
        assert translation_error_deg(sc.t, r.t) < 1e-4, s
        assert r.candidates_E.shape == (18, 3, 3)


def _twin_applies(r, sc, tol=1e-9):
    """A wrong valid candidate explains the data as well as the exact one (the homography twin)."""
    err = rotation_error_deg(sc.R, r.candidates_R)
    exact = err < 1e-6
    best_exact_cost = r.candidate_cost[exact].min()
    wrong = (~exact) & r.candidate_valid & (err > 1e-3)
    return bool(np.any(r.candidate_cost[wrong] <= best_exact_cost + tol))


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_planar_exact_or_twin(camera):
    twins = 0
    for s in range(100):
        sc = make_scene(30, "planar", camera, seed=s)
        r = lirp(sc.f1, sc.f2)
        errs = rotation_error_deg(sc.R, r.candidates_R)
        assert errs.min() < 1e-6, s  # one candidate is always exact
        # rank 6: the result says the twin may be the pick (a researcher's trial found it unflagged)
        assert r.rank == 6 and r.status == "ok" and any("homography twin" in n for n in r.notes), s
        if _twin_applies(r, sc):
            twins += 1
        else:
            assert rotation_error_deg(sc.R, r.R) < 1e-6, s
            assert translation_error_deg(sc.t, r.t) < 1e-4, s
    # the two-fold planar ambiguity applies in a minority of scenes (measured over 500 seeds, n = 30:
    # wide 9.6 % (wrong pick 3.8 %), pinhole 30.4 % (wrong pick 16.8 %; 9.4 % at an earlier code state: a
    # tie-break between equal costs); the narrow view favours the twin)
    assert twins < (20 if camera == "wide" else 45)


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_pure_rotation(camera):
    for s in range(30):
        sc = make_scene(30, "rotation", camera, seed=s)
        r = lirp(sc.f1, sc.f2)
        assert rotation_error_deg(sc.R, r.R) < 1e-6
        assert r.rank == 6 and any("pure rotation" in n for n in r.notes)


def test_normalized_coordinates_input():
    sc = make_scene(30, "normal", "pinhole", seed=3)
    x1 = sc.f1[:, :2] / sc.f1[:, 2:]
    x2 = sc.f2[:, :2] / sc.f2[:, 2:]
    r = lirp(x1, x2)
    assert rotation_error_deg(sc.R, r.R) < 1e-6


def test_zero_weight_on_outliers_is_exact():
    for s in range(20):
        sc = make_scene(60, "normal", outlier_fraction=0.3, seed=s)
        w = sc.inliers.astype(float)
        r = lirp(sc.f1, sc.f2, w)
        assert rotation_error_deg(sc.R, r.R) < 1e-6
        # unweighted LiRP is pulled away by the same outliers
    r0 = lirp(sc.f1, sc.f2)
    assert rotation_error_deg(sc.R, r0.R) > 1e-3


def test_noise_accuracy():
    errs = [rotation_error_deg(sc.R, lirp(sc.f1, sc.f2).R) for sc in (make_scene(30, noise_px=1.0, seed=s) for s in range(50))]
    assert np.median(errs) < 0.5


def test_permutation_invariance_and_swap():
    sc = make_scene(40, noise_px=0.5, seed=7)
    r = lirp(sc.f1, sc.f2)
    p = np.random.default_rng(0).permutation(40)
    rp = lirp(sc.f1[p], sc.f2[p])
    assert rotation_error_deg(r.R, rp.R) < 1e-9
    # swapping the views gives the inverse pose: X1 = R^T X2 - R^T t
    rs = lirp(sc.f2, sc.f1)
    assert rotation_error_deg(r.R.T, rs.R) < 1e-6
    assert translation_error_deg(-r.R.T @ r.t, rs.t) < 1e-4


def test_essential_consistency():
    sc = make_scene(30, noise_px=0.0, seed=1)
    r = lirp(sc.f1, sc.f2)
    E = skew(r.t) @ r.R
    assert np.abs(np.einsum("ni,ij,nj->n", sc.f2, E, sc.f1)).max() < 1e-10
    assert np.allclose(r.E, E, atol=1e-14)  # the package's E (a researcher's trial: it was the raw candidate)
    c = r.candidates_E[r.best]
    assert abs(abs(np.sum(c * E)) / np.linalg.norm(E) - 1.0) < 1e-9  # the candidate up to sign and scale


def test_fewer_than_six_positive_weights_are_degenerate():
    """An IRLS loop can zero all but a few weights: a result with status degenerate, not an error."""
    import poseonly

    sc = make_scene(30, noise_px=0.0, seed=1)
    w = np.zeros(30)
    w[:5] = 1.0
    for fn in (lirp, poseonly.lirp):
        assert fn(sc.f1, sc.f2, w).status == "degenerate"
        assert fn(sc.f1, sc.f2, np.zeros(30)).status == "degenerate"


@pytest.mark.parametrize(
    "f1,f2,w,msg",
    [
        (np.ones((5, 3)), np.ones((5, 3)), None, "at least 6"),
        (np.ones((8, 3)), np.ones((7, 3)), None, "differ in length"),
        (np.full((8, 3), np.nan), np.ones((8, 3)), None, "NaN"),
        (np.ones((8, 3)), np.full((8, 3), np.inf), None, "NaN or inf"),
        (np.zeros((8, 3)), np.ones((8, 3)), None, "zero-length"),
        (np.ones((8, 4)), np.ones((8, 4)), None, "shape"),
        (np.ones((8, 3)), np.ones((8, 3)), -np.ones(8), "non-negative"),
        (np.ones((8, 3)), np.ones((8, 3)), np.ones(7), "weights must have shape"),
        ("abc", np.ones((8, 3)), None, "numeric"),
    ],
)
def test_bad_input(f1, f2, w, msg):
    from poseonly.solvers.lirp import lirp as solver_lirp

    for fn in (lirp, solver_lirp):  # the public function and the solver's: both check before the fast path
        with pytest.raises(ValueError, match=msg):
            fn(f1, f2, w)


@pytest.mark.parametrize("w", [np.array([np.nan] + [1.0] * 7), np.array([np.inf] + [1.0] * 7)])
def test_non_finite_weights_are_refused(w):
    sc = make_scene(8, seed=0)
    with pytest.raises(ValueError, match="weights contain NaN or inf"):
        lirp(sc.f1, sc.f2, w)


def test_fast_path_equals_checked_path():
    """``lirp_plain`` (one core call on plain float64 rows) returns the checked path's result bit for bit,
    and declines every input the checked path has something to say about."""
    import importlib

    from poseonly.geometry import check_correspondences

    L = importlib.import_module("poseonly.solvers.lirp")
    rng = np.random.default_rng(0)
    for s in range(20):
        sc = make_scene(30, "planar" if s % 4 == 0 else "normal", "wide" if s % 2 else "pinhole", noise_px=0.5 * (s % 3), seed=s)
        scale = 10.0 ** rng.uniform(-3, 3, (30, 1))  # rows of any length: the same unit bearings
        for w in (None, rng.uniform(0.0, 7.0, 30), np.where(rng.uniform(size=30) < 0.3, 0.0, 1.0)):
            fast = L.lirp_plain(sc.f1 * scale, sc.f2, w, L.RANK_TOL)
            assert fast is not None
            b1, b2, wc = check_correspondences(sc.f1 * scale, sc.f2, w, min_positive=0)
            slow = L.lirp_checked(b1, b2, wc, L.RANK_TOL)
            assert fast == slow, s  # ValueEquality: every field, NaN equal to NaN
    sc = make_scene(30, seed=1)
    nan_row = sc.f1.copy()
    nan_row[3] = np.nan
    zero_row = sc.f1.copy()
    zero_row[3] = 0.0
    negative = np.ones(30)
    negative[2] = -1.0
    declined = [
        (sc.f1 / sc.f1[:, 2:], sc.f2, None, 1e-9),  # rows [x, y, 1]: the homogeneous-pixel check decides
        (sc.f1[:5], sc.f2[:5], None, 1e-9),
        (nan_row, sc.f2, None, 1e-9),
        (zero_row, sc.f2, None, 1e-9),
        (sc.f1, sc.f2, negative, 1e-9),
        (sc.f1, sc.f2, np.ones(29), 1e-9),
        (sc.f1[:, :2].copy(), sc.f2[:, :2].copy(), None, 1e-9),
        (sc.f1.astype(np.float32), sc.f2, None, 1e-9),
        (sc.f1, sc.f2, None, 1),  # an int rank_tol: the checked path takes it
        (sc.f1, sc.f2, None, 1.5),
    ]
    for args in declined:
        assert L.lirp_plain(*args) is None
    assert lirp(sc.f1 / sc.f1[:, 2:], sc.f2).status == "ok"  # normalized [x, y, 1] rows are bearings


def test_degenerate_identical_points():
    f = np.tile([0.1, 0.2, 1.0], (10, 1))
    r = lirp(f, f)
    assert r.status == "degenerate"
    # no pose: NaN, not the identity a typed integrator's trial got back as a plausible pose
    assert np.all(np.isnan(r.R)) and np.all(np.isnan(r.t)) and np.all(np.isnan(r.E))
    assert np.all(np.isfinite(r.candidates_R))
    assert r.notes


def test_complex_weights_are_refused():
    """Complex weights were cast to real with a ComplexWarning, the imaginary part dropped (an adversarial trial)."""
    import poseonly
    from poseonly.sim import make_scene

    sc = make_scene(40, camera="pinhole", seed=0)
    with pytest.raises(ValueError, match="weights must be real"):
        poseonly.lirp(sc.f1, sc.f2, np.ones(40) + 1j)
    with pytest.raises(ValueError, match="weights must be real"):
        poseonly.gnc_irls(sc.f1, sc.f2, weights=np.ones(40) + 0j)
