"""Long adversarial run of the public API and the CLI (issue 14): crashes, hangs, invalid results.

Every case is drawn from its own seed (``--seed`` + case index) in one of the families below and
run in-process under a per-case alarm (``--timeout`` s = a hang). A case ends as

* ``result``  -- a result satisfying every invariant (``tests/test_properties.py::check_result``),
* ``error``   -- :class:`poseonly.InputError` (a documented ValueError) with a message,
* ``invalid`` -- a result breaking an invariant, or a RuntimeWarning reaching the caller,
* ``crash``   -- any other exception, ``hang`` -- the alarm fired.

    python benchmarks/fuzz.py --cases 10000 --out docs/results/fuzz.md

Families: adversarial arrays (shapes, dtypes incl. complex/int/float32/lists, NaN/inf, 1e-320 ..
1.7e308 magnitudes) with adversarial ``K`` (negative, mixed-sign, tiny, huge, NaN, non-triangular);
synthetic scenes (normal / planar / pure rotation, 0-80 % outliers) with every method; random
matches; duplicated and collinear points; option dicts of every type for every method; the
low-level ``gnc_irls`` / ``gnc_ransac`` / ``lirp`` with random keyword values; the CLI
(``relpose --matches`` with random arguments and match files).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

import poseonly
from poseonly import InputError
from poseonly.options import OPTIONS
from poseonly.result import STATUSES, RelativePoseResult
from poseonly.sim import default_K, make_scene

FAST = {"max_iterations": 150, "min_iterations": 20}
SPECIAL = [0.0, -0.0, 1.0, -1.0, 1e-300, 1e300, -1e300, 1e154, 1.7e308, 5e-324, np.nan, np.inf, -np.inf]
VALUES = [
    None,
    True,
    False,
    0,
    1,
    -1,
    7,
    10**6,
    2.0,
    -2.0,
    0.5,
    1e300,
    1e-300,
    np.nan,
    np.inf,
    -np.inf,
    "",
    "x",
    "median",
    "mad",
    "5pt",
    "lirp",
    "ligt",
    "msac",
    "count",
    "ms-tls",
    np.float32(2.0),
    np.int64(7),
    np.True_,
    np.int32(-1),
    np.float16(0.5),
    [1, 2],
    {"a": 1},
    6.5,
    30,
    3,
]


# the CLI arguments the fuzzer (and tests/test_properties.py) draws from: valid, invalid and missing values
CLI_WORDS = (
    "--threshold",
    "-1",
    "0",
    "nan",
    "inf",
    "2",
    "--focal",
    "500",
    "-3",
    "--pp",
    "320",
    "240",
    "--method",
    "lirp",
    "gnc-irls",
    "bogus",
    "--seed",
    "-2",
    "7",
    "--json",
    "--draw",
    "x.xyz",
    "--K",
    "missing.txt",
    "--ratio",
    "1.5",
    "--camera-model",
    "SIMPLE_RADIAL",
    "opencv_fisheye",
    "--camera-params",
    "800,320,240,-0.2",
    "800 800 320 240 0.1 0 0 0",
    "1,,2",
    "--camera2-model",
    "--camera2-params",
)


class Invalid(AssertionError):
    pass


def check_result(r, n: int) -> None:
    """The invariants of a :class:`poseonly.RelativePoseResult` (as in tests/test_properties.py)."""

    def need(c, msg):
        if not c:
            raise Invalid(msg)

    need(r.status in STATUSES, f"status {r.status!r}")
    need(r.inliers.shape == (n,) and r.inliers.dtype == bool, "inlier mask shape/dtype")
    need(r.weights.shape == (n,) and r.residuals_px.shape == (n,), "weights/residuals shape")
    need(r.num_inliers == int(r.inliers.sum()), "num_inliers != mask count")
    if r.status == "degenerate":
        need(r.R is None and r.t is None and r.E is None, "degenerate result with a pose")
    else:
        need(r.R is not None and r.t is not None, "no pose without status degenerate")
        need(np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)), "non-finite pose")
        need(np.abs(r.R.T @ r.R - np.eye(3)).max() < 1e-6 and np.linalg.det(r.R) > 0, "R not a rotation")
        need(abs(np.linalg.norm(r.t) - 1.0) < 1e-9, "t not unit")
    json.dumps(r.to_dict(), allow_nan=False)
    # the exact record reads back to an equal result (RelativePoseResult.from_dict, eighteenth session)
    back = RelativePoseResult.from_dict(json.loads(json.dumps(r.to_dict(exact=True), allow_nan=False)))
    need(back == r, "to_dict(exact=True) does not read back equal")


def _array(rng, n=None, c=None):
    n = int(rng.integers(0, 41)) if n is None else n
    c = int(rng.choice([2, 3, 3, 2, 1, 4])) if c is None else c
    a = rng.standard_normal((n, c))
    if c == 3:
        a[:, 2] = np.abs(a[:, 2]) + 0.5
    kind = rng.choice(["normal", "normal", "huge", "tiny", "special", "int", "float32", "complex", "list", "ragged", "cluster"])
    if kind == "cluster" and n:
        # every row within a small distance of one (clustered input; the trial's crash needed both views
        # clustered at ~1e-4 of the focal, which tests/test_pose_uncertainty.py covers)
        a = a[:1] + rng.uniform(-1.0, 1.0, a.shape) * 10.0 ** -float(rng.integers(2, 12))
    elif kind == "huge":
        a *= 10.0 ** rng.integers(100, 309)
    elif kind == "tiny":
        a *= 10.0 ** -rng.integers(100, 321)
    elif kind == "special" and n:
        a[rng.integers(n), rng.integers(c)] = SPECIAL[rng.integers(len(SPECIAL))]
    elif kind == "int":
        a = (a * 100).astype(np.int64)
    elif kind == "float32":
        a = a.astype(np.float32)
    elif kind == "complex":
        a = a + 1j * rng.choice([0.0, 1.0])
    elif kind == "list":
        return a.tolist()
    elif kind == "ragged" and n > 1:
        out = a.tolist()
        out[0] = out[0][:-1]
        return out
    return a


def _K(rng):
    K = default_K()
    kind = rng.choice(["none", "ok", "neg", "mixed", "zero", "tiny", "huge", "nan", "lower", "shape", "scaled"])
    if kind == "none":
        return None
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


def _opts(rng, method):
    names = list(OPTIONS[method].__dataclass_fields__) + ["bogus"]
    keys = rng.choice(names, size=int(rng.integers(0, 4)), replace=False)
    o = {str(k): VALUES[rng.integers(len(VALUES))] for k in keys}
    if method == "poseonly":
        for k, v in FAST.items():
            x = o.get(k)
            if not (isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_)) and 0 <= x <= 300):
                o[k] = v
    if method == "gnc-ransac":
        x = o.get("max_iterations")
        if not (isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_)) and x <= 10):
            o["max_iterations"] = 5
    return o


def _scene(rng):
    return make_scene(
        int(rng.integers(8, 61)),
        str(rng.choice(["normal", "planar", "rotation"])),
        camera=str(rng.choice(["wide", "pinhole"])),
        noise_px=float(rng.choice([0.0, 0.5, 2.0])),
        outlier_fraction=float(rng.choice([0.0, 0.3, 0.8])),
        seed=int(rng.integers(10**6)),
    )


# focal length of the pixel threshold for bearing / normalized inputs (required by the API)
FOCAL = 800.0


def case(rng) -> tuple[str, object]:
    """One case: ``(family, thunk)``; the thunk returns ``(result | None, n)``."""
    fam = str(rng.choice(["arrays", "scene", "random", "duplicates", "options", "lowlevel", "cli"], p=[0.25, 0.2, 0.1, 0.1, 0.15, 0.12, 0.08]))
    est = poseonly.estimate_relative_pose
    if fam == "arrays":
        n, c = int(rng.integers(0, 41)), int(rng.choice([2, 2, 2, 3, 3, 1, 4]))
        same = rng.random() < 0.8  # mostly matching shapes, so that the values are what is tested
        x1 = _array(rng, n, c)
        x2 = _array(rng, n if same else None, c if same else None)
        # half the cases with an adversarial K, the others with a valid K or none (then mostly with
        # focal_px, which bearings and normalized coordinates need), so that the values reach the estimator
        K = _K(rng) if rng.random() < 0.5 else (default_K() if rng.random() < 0.5 else None)
        kw = {"focal_px": FOCAL} if K is None and rng.random() < 0.8 else {}
        return fam, lambda: (est(x1, x2, K, **kw, **FAST), len(x1))
    if fam == "scene":
        sc, m = _scene(rng), str(rng.choice(list(poseonly.METHODS)))
        o = dict(FAST) if m == "poseonly" else ({"max_iterations": 5, "sample_size": min(30, len(sc.f1))} if m == "gnc-ransac" else {})
        pix = bool(rng.integers(2)) and np.all(sc.X[:, 2] > 0)
        if pix:
            return fam, lambda: (est(sc.u1, sc.u2, sc.K, method=m, **o), len(sc.f1))
        return fam, lambda: (est(sc.f1, sc.f2, method=m, focal_px=FOCAL, **o), len(sc.f1))
    if fam == "random":
        n = int(rng.integers(6, 120))
        if rng.integers(2):
            f1, f2 = rng.standard_normal((2, n, 3))
            return fam, lambda: (est(f1, f2, focal_px=FOCAL, **FAST), n)
        u1, u2 = rng.uniform((0, 0), (640, 480), (2, n, 2))
        return fam, lambda: (est(u1, u2, default_K(), **FAST), n)
    if fam == "duplicates":
        n, m = int(rng.integers(6, 41)), int(rng.integers(1, 6))
        if rng.integers(2):
            s = rng.uniform(-1, 1, n)
            x1, x2 = np.stack([s, 0.3 * s + 0.1], 1), np.stack([s + 0.05, 0.3 * s + 0.12], 1)
        else:
            b1, b2 = rng.standard_normal((2, m, 2)) * 0.3
            idx = rng.integers(0, m, n)
            x1, x2 = b1[idx], b2[idx]
        return fam, lambda: (est(x1, x2, focal_px=FOCAL, **FAST), n)
    if fam == "options":
        m = str(rng.choice(list(poseonly.METHODS)))
        sc = make_scene(30, seed=int(rng.integers(100)))
        o = _opts(rng, m)
        return fam, lambda: (est(sc.f1, sc.f2, method=m, **{"focal_px": FOCAL, **o}), 30)
    if fam == "lowlevel":
        fn = str(rng.choice(["gnc_irls", "gnc_ransac", "lirp"]))
        sc = _scene(rng)
        f1 = sc.f1 if rng.integers(2) else _array(rng, len(sc.f1), 3)
        names = {
            "gnc_irls": ["noise_bound", "residual", "schedule", "scale", "max_iterations", "eps0", "weights"],
            "gnc_ransac": ["seed", "sample_size", "max_iterations", "adaptive", "residual", "schedule", "scale"],
            "lirp": ["rank_tol", "weights"],
        }[fn]
        kw = {str(k): VALUES[rng.integers(len(VALUES))] for k in rng.choice(names, size=min(len(names), int(rng.integers(0, 4))), replace=False)}
        if fn == "gnc_ransac":
            kw.setdefault("theta", 2.5e-3 if rng.integers(2) else VALUES[rng.integers(len(VALUES))])
            if not (isinstance(kw.get("max_iterations"), int) and 0 < kw["max_iterations"] <= 10):
                kw["max_iterations"] = 3
        if fn == "gnc_irls" and not (isinstance(kw.get("max_iterations"), int) and 0 < kw["max_iterations"] <= 100):
            kw.pop("max_iterations", None)

        def low():
            r = getattr(poseonly, fn)(f1, sc.f2, **kw)
            R, t = np.asarray(r.R, float), np.asarray(r.t, float)
            if R.shape != (3, 3) or t.shape != (3,):
                raise Invalid(f"{fn} returned shapes {R.shape}, {t.shape}")
            return None, 0

        return fam, low
    # cli
    words = CLI_WORDS
    args = [str(w) for w in rng.choice(words, size=int(rng.integers(0, 7)))]
    n = int(rng.integers(0, 31))
    u1, u2 = _array(rng, n, 2), _array(rng, n, 2)

    def cli():
        from poseonly.cli import main

        with tempfile.TemporaryDirectory() as d:
            try:
                np.savez(Path(d) / "m.npz", u1=np.asarray(u1), u2=np.asarray(u2), K=default_K())
            except (TypeError, ValueError):
                return None, 0
            argv = ["relpose", "--matches", str(Path(d) / "m.npz"), *args, "--method", "lirp"]
            out, err = io.StringIO(), io.StringIO()
            try:
                with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                    rc = main(argv)
            except SystemExit as e:
                if e.code != 2:
                    raise Invalid(f"argparse exit code {e.code}") from None
                return None, 0
            if rc not in (0, 1, 2):  # the documented exit codes: ok, not ok, degenerate / error
                raise Invalid(f"CLI return code {rc}")
            if rc in (0, 1) and "--json" in argv:
                json.loads(out.getvalue(), parse_constant=lambda c: (_ for _ in ()).throw(Invalid(f"JSON constant {c}")))
        return None, 0

    return fam, cli


class Hang(BaseException):
    pass


def _alarm(signum, frame):
    raise Hang()


def run_case(seed: int, timeout: float) -> tuple[str, str, str]:
    rng = np.random.default_rng(seed)
    fam, thunk = case(rng)
    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            warnings.simplefilter("error", np.exceptions.ComplexWarning)
            r, n = thunk()
        if r is not None:
            check_result(r, n)
        return fam, "result", ""
    except InputError as exc:
        return (fam, "error", "") if str(exc) else (fam, "invalid", "InputError without a message")
    except (Invalid, RuntimeWarning, np.exceptions.ComplexWarning) as exc:
        return fam, "invalid", f"{type(exc).__name__}: {exc}"
    except Hang:
        return fam, "hang", f"> {timeout} s"
    except Exception as exc:  # noqa: BLE001 - counting crashes is the point
        tb = traceback.format_exception(exc)[-3:]
        return fam, "crash", "".join(tb).strip().replace("\n", " | ")[-400:]
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    counts: dict[str, Counter] = {}
    bad = []
    for i in range(a.cases):
        fam, outcome, info = run_case(a.seed + i, a.timeout)
        counts.setdefault(fam, Counter())[outcome] += 1
        if outcome in ("invalid", "crash", "hang"):
            bad.append(f"- case seed {a.seed + i} ({fam}, {outcome}): {info}")
            print(bad[-1], flush=True)
        if (i + 1) % 500 == 0:
            print(f"{i + 1} cases, {time.perf_counter() - t0:.0f} s", flush=True)
    total = Counter()
    for c in counts.values():
        total.update(c)
    rows = [f"| {fam} | {sum(c.values())} | {c['result']} | {c['error']} | {c['invalid']} | {c['crash']} | {c['hang']} |" for fam, c in sorted(counts.items())]
    rows.append(f"| **all** | {sum(total.values())} | {total['result']} | {total['error']} | {total['invalid']} | {total['crash']} | {total['hang']} |")
    cmd = "python benchmarks/fuzz.py " + " ".join(argv if argv is not None else sys.argv[1:])
    md = "\n".join(
        [
            "## Fuzzing the public API and the CLI (benchmarks/fuzz.py)",
            "",
            f"Command: `{cmd}`; {time.perf_counter() - t0:.0f} s.",
            "",
            "| family | cases | valid result | InputError | invalid result | crash | hang |",
            "|---|---|---|---|---|---|---|",
            *rows,
            "",
            *(bad[:50] or ["No crash, hang or invalid result."]),
            "",
        ]
    )
    print(md)
    if a.out is not None:
        from poseonly._fileutil import atomic_write_text

        atomic_write_text(a.out, md)
    return 1 if bad else 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
