"""Property-based tests (hypothesis) of every public entry point and the CLI (issue 14).

Whatever the input, a call either raises :class:`poseonly.InputError` (a ValueError) or returns a
result satisfying the invariants of :func:`check_result`; no other exception and no RuntimeWarning
escapes. Bounded and seeded (``derandomize=True``, few examples) so that the file runs in well under
a minute; ``benchmarks/fuzz.py`` runs the long version (>= 10,000 cases).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import poseonly
from poseonly import InputError
from poseonly.options import OPTIONS
from poseonly.result import STATUSES
from poseonly.sim import default_K, make_scene

SETTINGS = settings(derandomize=True, max_examples=12, deadline=None, database=None, suppress_health_check=list(HealthCheck))
# the default method on data without a pose would run its full 100000 iterations: cap it in tests
FAST = {"max_iterations": 150, "min_iterations": 20}


def check_result(r: poseonly.RelativePoseResult, n: int) -> None:
    """The invariants of every returned result."""
    assert r.status in STATUSES
    assert r.inliers.shape == (n,) and r.inliers.dtype == bool
    assert r.weights.shape == (n,) and r.residuals_px.shape == (n,)
    assert r.num_inliers == int(r.inliers.sum())
    if r.status == "degenerate":
        assert r.R is None and r.t is None and r.E is None
    else:
        assert r.R is not None and r.t is not None and r.E is not None
        assert np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t))
        np.testing.assert_allclose(r.R.T @ r.R, np.eye(3), atol=1e-6)
        assert np.linalg.det(r.R) > 0
        assert abs(np.linalg.norm(r.t) - 1.0) < 1e-9
    if r.R_twin is not None:
        np.testing.assert_allclose(r.R_twin.T @ r.R_twin, np.eye(3), atol=1e-6)
        assert abs(np.linalg.norm(r.t_twin) - 1.0) < 1e-9
    d = r.to_dict()
    json.loads(json.dumps(d, allow_nan=False))
    assert d["inliers"] == np.nonzero(r.inliers)[0].tolist()


def call(fn, *args, **kw):
    """``fn(*args, **kw)``, or ``None`` when it raises InputError; RuntimeWarnings are errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            return fn(*args, **kw)
        except InputError as exc:
            assert str(exc), "an InputError needs a message"
            return None


# ------------------------------------------------------------------------------------------------
# strategies

special_floats = st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300, 1e300, -1e300, 1e154, 1.7e308, np.nan, np.inf, -np.inf, 5e-324])
floats = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64), special_floats)


@st.composite
def arrays(draw, n=None, cols=None):
    """Arrays of adversarial shape, dtype and values (mostly (n, 2|3) finite, sometimes not)."""
    n = draw(st.integers(0, 40)) if n is None else n
    c = draw(st.sampled_from([2, 3, 3, 2, 1, 4])) if cols is None else cols
    kind = draw(st.sampled_from(["normal", "normal", "huge", "tiny", "special", "int", "float32", "complex", "list"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    a = rng.standard_normal((n, c))
    if c == 3:
        a[:, 2] = np.abs(a[:, 2]) + 0.5
    if kind == "huge":
        a = a * 10.0 ** draw(st.integers(100, 308))
    elif kind == "tiny":
        a = a * 10.0 ** -draw(st.integers(100, 320))
    elif kind == "special" and n:
        a[draw(st.integers(0, n - 1)), draw(st.integers(0, c - 1))] = draw(floats)
    elif kind == "int":
        a = (a * 100).astype(np.int64)
    elif kind == "float32":
        a = a.astype(np.float32)
    elif kind == "complex":
        a = a + 1j * draw(st.sampled_from([0.0, 1.0]))
    elif kind == "list":
        return a.tolist()
    return a


@st.composite
def intrinsics(draw):
    base = default_K()
    kind = draw(st.sampled_from(["ok", "ok", "neg", "mixed", "zero", "tiny", "huge", "nan", "lower", "shape", "scaled"]))
    K = base.copy()
    if kind == "neg":
        K[0, 0] = K[1, 1] = -K[0, 0]
    elif kind == "mixed":
        K[1, 1] = -K[0, 0]
    elif kind == "zero":
        K[0, 0] = 0.0
    elif kind == "tiny":
        K[0, 0] = K[1, 1] = 1e-200
    elif kind == "huge":
        K[0, 0] = K[1, 1] = 1e250
    elif kind == "nan":
        K[0, 2] = np.nan
    elif kind == "lower":
        K[2, 0] = 0.5
    elif kind == "shape":
        return np.eye(2)
    elif kind == "scaled":
        K = K * 3.0
    return K


scene_kinds = st.sampled_from(["normal", "planar", "rotation"])


@st.composite
def scenes(draw):
    n = draw(st.integers(8, 60))
    sc = make_scene(
        n,
        draw(scene_kinds),
        camera=draw(st.sampled_from(["wide", "pinhole"])),
        noise_px=draw(st.sampled_from([0.0, 0.5, 2.0])),
        outlier_fraction=draw(st.sampled_from([0.0, 0.3, 0.8])),
        seed=draw(st.integers(0, 10**6)),
    )
    return sc


option_values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 10**6),
    floats,
    st.text(max_size=8),
    st.sampled_from(
        [
            np.float32(2.0),
            np.int64(7),
            np.True_,
            np.float64(np.inf),
            np.int32(-1),
            np.float16(0.5),
            "median",
            "mad",
            "5pt",
            "lirp",
            "ligt",
            "msac",
            "count",
            "ms-tls",
            1e300,
            1e-300,
            [1, 2],
            {"a": 1},
        ]
    ),
)


@st.composite
def option_dicts(draw, method):
    names = [f for f in OPTIONS[method].__dataclass_fields__]
    keys = draw(st.lists(st.sampled_from(names + ["bogus"]), max_size=3, unique=True))
    opts = {k: draw(option_values) for k in keys}
    if method == "poseonly":
        for k, v in FAST.items():
            if not (k in opts and isinstance(opts[k], (int, np.integer)) and not isinstance(opts[k], bool) and 0 <= opts[k] <= 300):
                opts[k] = v
    if method == "gnc-ransac" and "max_iterations" not in opts:
        opts["max_iterations"] = 5
    return opts


# ------------------------------------------------------------------------------------------------
# estimate_relative_pose


def _shape(a) -> tuple[int, int]:
    a = np.asarray(a)
    return (a.shape[0], a.shape[1]) if a.ndim == 2 else (0, 2)


@settings(SETTINGS, max_examples=40)
@given(data=st.data(), K=st.one_of(st.none(), st.none(), st.just(default_K()), intrinsics()))
def test_adversarial_arrays(data, K):
    """Adversarial values and dtypes; x2 mostly of x1's shape (and focal_px given without K), so that
    the values reach the estimator rather than the shape checks."""
    if data.draw(st.integers(0, 3)):  # mostly well-shaped, so that the values are what is tested
        x1 = data.draw(arrays(data.draw(st.integers(6, 40)), data.draw(st.sampled_from([2, 3]))))
    else:
        x1 = data.draw(arrays())
    n, c = _shape(x1)
    x2 = data.draw(arrays(n, c)) if data.draw(st.integers(0, 3)) else data.draw(arrays())
    r = call(poseonly.estimate_relative_pose, x1, x2, K, **({"focal_px": 800.0} if K is None else {}), **FAST)
    if r is not None:
        check_result(r, len(np.asarray(x1)))


@pytest.mark.parametrize(
    "kind",
    ["huge", "tiny", "int", "float32", "list", "pixels-int", "pixels-float32"],
)
def test_adversarial_but_valid_values_reach_the_estimator(kind):
    """Valid input at the edges of the value range gives a result with the invariants (not an error):
    bearings scaled by 1e300 or 1e-9 (only directions matter), integer and float32 arrays, nested
    lists, integer and float32 pixels with K. Bearings shorter than 1e-12 are zero-length: an error."""
    sc = make_scene(40, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=11)
    x1, x2, kw = sc.f1, sc.f2, {"focal_px": 800.0}
    if kind == "huge":
        x1, x2 = x1 * 1e300, x2 * 1e300
    elif kind == "tiny":  # (rows shorter than geometry.ZERO_BEARING, 1e-12, are an error: below)
        x1, x2 = x1 * 1e-9, x2 * 1e-9
    elif kind == "int":
        x1, x2 = np.round(x1 * 1e6).astype(np.int64), np.round(x2 * 1e6).astype(np.int64)
    elif kind == "float32":
        x1, x2 = x1.astype(np.float32), x2.astype(np.float32)
    elif kind == "list":
        x1, x2 = x1.tolist(), x2.tolist()
    elif kind == "pixels-int":
        x1, x2, kw = np.round(sc.u1).astype(np.int64), np.round(sc.u2).astype(np.int64), {}
    else:
        x1, x2, kw = sc.u1.astype(np.float32), sc.u2.astype(np.float32), {}
    r = call(poseonly.estimate_relative_pose, x1, x2, None if kw else sc.K, **kw, **FAST)
    assert r is not None
    check_result(r, 40)
    assert r.status == "ok" and poseonly.rotation_error_deg(sc.R, r.R) < 1.0, (r.status, r.message)
    if kind == "tiny":
        with pytest.raises(InputError, match="zero-length bearing"):
            poseonly.estimate_relative_pose(sc.f1 * 1e-300, sc.f2 * 1e-300, focal_px=800.0)


@SETTINGS
@given(sc=scenes(), method=st.sampled_from(list(poseonly.METHODS)), pixels=st.booleans())
def test_scenes_every_method(sc, method, pixels):
    opts = dict(FAST) if method == "poseonly" else ({"max_iterations": 5} if method == "gnc-ransac" else {})
    if method == "gnc-ransac":
        opts["sample_size"] = min(30, len(sc.f1))
    if pixels and np.all(sc.X[:, 2] > 0):
        r = call(poseonly.estimate_relative_pose, sc.u1, sc.u2, sc.K, method=method, **opts)
    else:
        r = call(poseonly.estimate_relative_pose, sc.f1, sc.f2, focal_px=800.0, method=method, **opts)
    assert r is not None
    check_result(r, len(sc.f1))
    if np.linalg.norm(sc.t) == 0:  # pure rotation: never "ok"
        assert r.status != "ok", r.message


@SETTINGS
@given(n=st.integers(6, 80), seed=st.integers(0, 10**6), bearings=st.booleans())
def test_random_matches_never_ok(n, seed, bearings):
    rng = np.random.default_rng(seed)
    if bearings:
        r = call(poseonly.estimate_relative_pose, rng.standard_normal((n, 3)), rng.standard_normal((n, 3)), focal_px=800.0, **FAST)
    else:
        u1, u2 = rng.uniform((0, 0), (640, 480), (2, n, 2))
        r = call(poseonly.estimate_relative_pose, u1, u2, default_K(), **FAST)
    assert r is not None
    check_result(r, n)
    assert r.status != "ok", r.message


@SETTINGS
@given(n=st.integers(6, 40), m=st.integers(1, 5), seed=st.integers(0, 10**6), line=st.booleans())
def test_duplicated_and_collinear_points(n, m, seed, line):
    rng = np.random.default_rng(seed)
    if line:  # all points on one image line in both views
        s = rng.uniform(-1, 1, n)
        x1 = np.stack([s, 0.3 * s + 0.1], 1)
        x2 = np.stack([s + 0.05, 0.3 * s + 0.12], 1)
    else:  # m distinct points repeated
        base1, base2 = rng.standard_normal((m, 2)) * 0.3, rng.standard_normal((m, 2)) * 0.3
        idx = rng.integers(0, m, n)
        x1, x2 = base1[idx], base2[idx]
    r = call(poseonly.estimate_relative_pose, x1, x2, focal_px=800.0, **FAST)
    assert r is not None
    check_result(r, n)
    if line or m < 3:
        assert r.status != "ok"


@SETTINGS
@given(data=st.data(), method=st.sampled_from(list(poseonly.METHODS) + ["nope", 3, None]))
def test_options_of_every_type(data, method):
    sc = make_scene(30, seed=1)
    if method not in poseonly.METHODS:
        with pytest.raises(InputError):
            poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, method=method)
        return
    opts = data.draw(option_dicts(method))
    r = call(poseonly.estimate_relative_pose, sc.f1, sc.f2, method=method, **{"focal_px": 800.0, **opts})
    if r is not None:
        check_result(r, 30)


valid_px = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False, allow_infinity=False)


@SETTINGS
@given(thr=st.one_of(valid_px, valid_px, floats), focal=st.one_of(valid_px, valid_px, st.none(), floats))
def test_threshold_and_focal_extremes(thr, focal):
    """Thresholds and focal lengths from 1e-6 to 1e6 px (valid as long as their angle is within
    options.MIN_ANGLE..MAX_ANGLE) and adversarial ones (0, negative, NaN, inf): a result or an
    InputError."""
    sc = make_scene(30, seed=2)
    r = call(poseonly.estimate_relative_pose, sc.f1, sc.f2, threshold_px=thr, focal_px=focal, **FAST)
    if r is not None:
        check_result(r, 30)
        assert np.isfinite(thr) and thr > 0


def test_threshold_and_focal_extremes_that_are_valid():
    """The valid corners of the range return results (the hypothesis test above may draw few)."""
    from poseonly.options import MAX_ANGLE, MIN_ANGLE

    sc = make_scene(30, seed=2)
    for thr, focal in ((1e-6, 1e-6), (1e6, 1e6), (1e-3, 1e6), (1e3, 1e3 / (0.99 * MAX_ANGLE)), (1.0, 1.0 / (1.01 * MIN_ANGLE)), (0.01, 800.0)):
        r = call(poseonly.estimate_relative_pose, sc.f1, sc.f2, threshold_px=thr, focal_px=focal, **FAST)
        assert r is not None, (thr, focal)
        check_result(r, 30)
    for thr, focal in ((1.0, 1.0 / (0.99 * MIN_ANGLE)), (1e3, 1e3 / (1.01 * MAX_ANGLE))):
        assert call(poseonly.estimate_relative_pose, sc.f1, sc.f2, threshold_px=thr, focal_px=focal, **FAST) is None, (thr, focal)


def test_numpy_scalars_and_messages():
    sc = make_scene(30, seed=3)
    r = poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, threshold_px=np.float32(2.0), min_inliers=np.int64(10), refine=np.True_, seed=np.int64(4), **FAST)
    check_result(r, 30)
    with pytest.raises(InputError, match="must be of type bool") as e:
        poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, refine=1)
    assert "got int" in str(e.value)
    with pytest.raises(InputError, match="invalid value inf"):
        poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, threshold_px=np.inf)


# ------------------------------------------------------------------------------------------------
# low-level functions

low_values = st.one_of(option_values, st.integers(-3, 60))


@SETTINGS
@given(data=st.data(), fn=st.sampled_from(["gnc_irls", "gnc_ransac", "lirp"]))
def test_low_level_functions(data, fn):
    sc = make_scene(data.draw(st.integers(6, 40)), data.draw(scene_kinds), seed=data.draw(st.integers(0, 99)))
    f1, f2 = (sc.f1, sc.f2) if data.draw(st.booleans()) else (data.draw(arrays(len(sc.f1), 3)), sc.f2)
    names = {
        "gnc_irls": ["noise_bound", "residual", "schedule", "scale", "max_iterations", "eps0", "weights"],
        "gnc_ransac": ["seed", "sample_size", "max_iterations", "adaptive", "residual", "schedule", "scale"],
        "lirp": ["rank_tol", "weights"],
    }[fn]
    kw = {k: data.draw(low_values) for k in data.draw(st.lists(st.sampled_from(names), max_size=3, unique=True))}
    if fn == "gnc_ransac":
        kw["theta"] = data.draw(st.one_of(st.just(2.5e-3), low_values))
        if not (isinstance(kw.get("max_iterations"), int) and 0 < kw["max_iterations"] <= 10):
            kw["max_iterations"] = 3
    if fn == "gnc_irls" and not (isinstance(kw.get("max_iterations"), int) and 0 < kw["max_iterations"] <= 100):
        kw.pop("max_iterations", None)
    r = call(getattr(poseonly, fn), f1, f2, **kw)
    if r is None:
        return
    R, t = np.asarray(r.R), np.asarray(r.t)
    assert R.shape == (3, 3) and t.shape == (3,)


# ------------------------------------------------------------------------------------------------
# the CLI


def _cli_words() -> list[str]:
    """The CLI arguments of benchmarks/fuzz.py (one list for the fuzzer and this test)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    try:
        from fuzz import CLI_WORDS
    finally:
        sys.path.pop(0)
    return list(CLI_WORDS)


cli_args = st.lists(st.sampled_from(_cli_words()), max_size=6)


@SETTINGS
@given(args=cli_args, data=st.data())
def test_cli_relpose_matches(args, data, tmp_path_factory, capsys):
    from poseonly.cli import main

    d = tmp_path_factory.mktemp("cli")
    n = data.draw(st.integers(0, 30))
    u1 = data.draw(arrays(n, 2))
    u2 = data.draw(arrays(n, 2))
    try:
        np.savez(d / "m.npz", u1=np.asarray(u1), u2=np.asarray(u2), K=default_K())
    except (TypeError, ValueError):
        return
    argv = ["relpose", "--matches", str(d / "m.npz"), *args]
    if "--method" not in args or "lirp" not in args:
        argv += ["--method", "lirp"]  # the fast method: the CLI is under test here, not the estimator
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            rc = main(argv)
    except SystemExit as e:  # argparse usage errors
        assert e.code == 2
        return
    assert rc in (0, 1, 2)
    out = capsys.readouterr().out
    if rc in (0, 1) and "--json" in argv:
        json.loads(out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))


@pytest.mark.parametrize("method", ["lirp", "poseonly"])
def test_cli_relpose_matches_json_is_strict(method, tmp_path, capsys):
    """The success path the hypothesis test above rarely reaches: a matches file of a real pose, the
    JSON printed parses without NaN / Infinity constants and carries the pose."""
    from poseonly.cli import main

    sc = make_scene(60, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=5)
    np.savez(tmp_path / "m.npz", u1=sc.u1, u2=sc.u2, K=sc.K)
    rc = main(["relpose", "--matches", str(tmp_path / "m.npz"), "--json", "--method", method])
    d = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert rc == (0 if d["status"] == "ok" else 1)
    assert np.asarray(d["R"]).shape == (3, 3) and len(d["t"]) == 3


@SETTINGS
@given(trials=st.sampled_from(["-1", "0", "x", "1.5"]))
def test_cli_experiment_bad_trials(trials):
    from poseonly.cli import main

    with pytest.raises(SystemExit) as e:
        main(["experiment", "table2", "--trials", trials])
    assert e.value.code == 2


@SETTINGS
@given(method=st.sampled_from(list(poseonly.METHODS)), data=st.data())
def test_option_messages_do_not_contradict_themselves(method, data):
    """An error names the option, what it must be and what was given; the given type never equals
    the one required (the old ``refine=np.True_``: "must be of type bool, got bool")."""
    from poseonly.options import parse_options

    name = data.draw(st.sampled_from(list(OPTIONS[method].__dataclass_fields__)))
    value = data.draw(option_values)
    try:
        parse_options(method, {name: value})
    except InputError as exc:
        msg = str(exc)
        assert repr(name) in msg
        if "must be of type " in msg and ", got " in msg:
            required = msg.split("must be of type ")[1].split(" ")[0]
            given_type = msg.split(", got ")[1].split(" ")[0]
            assert given_type not in required.split("/"), msg
