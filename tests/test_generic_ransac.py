"""The core's robust loop over estimators written in Python (poseonly.robust.generic; issue 11: one
estimator protocol the loops are generic over, with a Python face; a researcher's trial found the
loop reachable only from C++)."""

import numpy as np
import pytest

from poseonly import _core
from poseonly.geometry import InputError
from poseonly.robust.generic import RansacEstimator, ransac


class Line:
    """``a x + b y + c = 0`` with ``a^2 + b^2 = 1`` from 2 points, total least squares as refine: the
    core's LineEstimator (src/core/estimators.h) in numpy."""

    sample_size = 2

    def __init__(self, xy):
        self.xy = np.asarray(xy, float)
        self.num_data = len(self.xy)
        self.calls = 0

    def generate(self, sample):
        self.calls += 1
        p, q = self.xy[sample]
        d = q - p
        nrm = np.hypot(*d)
        if not nrm > 0:
            return []
        a, b = -d[1] / nrm, d[0] / nrm
        return [(a, b, -(a * p[0] + b * p[1]))]

    def residuals(self, m):
        return np.abs(self.xy @ np.array(m[:2]) + m[2])

    def refine(self, m, inliers):
        if len(inliers) < 2:
            return None
        P = self.xy[inliers]
        mu = P.mean(axis=0)
        w, V = np.linalg.eigh((P - mu).T @ (P - mu))
        a, b = V[:, 0]
        return (a, b, -(a * mu[0] + b * mu[1]))

    def distance(self, p, q):
        c = min(1.0, abs(p[0] * q[0] + p[1] * q[1]))
        return float(np.degrees(np.arccos(c)) + abs(abs(p[2]) - abs(q[2])))


def _line_data(seed=0, n=200, outliers=0.5):
    rng = np.random.default_rng(seed)
    t = rng.uniform(-10, 10, n)
    xy = np.column_stack([t, 0.5 * t + 1.0]) + rng.normal(0, 0.05, (n, 2))
    out = rng.random(n) < outliers
    xy[out] = rng.uniform(-10, 10, (out.sum(), 2))
    return xy, ~out


def test_a_python_line_estimator_equals_the_core_line_estimator():
    """The same loop, sampler and scoring: the Python line and the core's LineEstimator end on the
    same line with the same inliers, seed for seed."""
    assert isinstance(Line(np.zeros((3, 2))), RansacEstimator)
    for seed in range(5):
        xy, truth = _line_data(seed)
        r = ransac(Line(xy), 0.2, seed=seed, max_iterations=1000)
        (a, b, c), st = _core.ransac_line(np.ascontiguousarray(xy), 0.2, seed, max_iterations=1000)
        sign = np.sign(r.model[0] * a + r.model[1] * b)
        assert np.allclose(np.array(r.model) * sign, [a, b, c], atol=1e-9)
        assert r.num_iterations == st["iterations"] and r.stats["num_lo"] == st["num_lo"]
        assert r.inliers.sum() >= 0.9 * truth.sum() and (r.inliers & ~truth).sum() <= 3
        assert r.residuals is not None and np.array_equal(r.inliers, r.residuals <= 0.2)


def test_determinism_scorings_prosac_and_challengers():
    xy, truth = _line_data(3)
    a = ransac(Line(xy), 0.2, seed=7)
    b = ransac(Line(xy), 0.2, seed=7)
    assert a.model == b.model and np.array_equal(a.inliers, b.inliers)
    for scoring in ("msac", "multi-msac", "count"):
        r = ransac(Line(xy), 0.2, seed=1, scoring=scoring)
        assert r.inliers.sum() >= 0.9 * truth.sum()
    order = np.argsort(~truth, kind="stable")  # the true points first: PROSAC ends early
    est = Line(xy)
    r = ransac(est, 0.2, seed=1, order=order)
    assert r.inliers.sum() >= 0.9 * truth.sum() and r.num_iterations < 100
    r = ransac(Line(xy), 0.2, seed=1, challengers=4, challenger_distance=2.0)
    assert r.inliers.sum() >= 0.9 * truth.sum()


class Homography:
    """A plane's homography from 4 points (DLT in numpy), transfer error in pixels, no refine."""

    sample_size = 4

    def __init__(self, x1, x2):
        self.x1, self.x2 = np.asarray(x1, float), np.asarray(x2, float)
        self.num_data = len(x1)

    def generate(self, sample):
        rows = []
        for (x, y), (u, v) in zip(self.x1[sample], self.x2[sample]):
            rows.append([-x, -y, -1, 0, 0, 0, u * x, u * y, u])
            rows.append([0, 0, 0, -x, -y, -1, v * x, v * y, v])
        H = np.linalg.svd(np.array(rows))[2][-1].reshape(3, 3)
        return [H] if abs(H[2, 2]) > 1e-12 else []

    def residuals(self, H):
        p = np.column_stack([self.x1, np.ones(len(self.x1))]) @ H.T
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.linalg.norm(p[:, :2] / p[:, 2:] - self.x2, axis=1)


def test_a_homography_estimator():
    rng = np.random.default_rng(2)
    H = np.array([[1.1, 0.05, 10.0], [-0.03, 0.95, -5.0], [1e-4, 2e-4, 1.0]])
    x1 = rng.uniform(0, 640, (150, 2))
    p = np.column_stack([x1, np.ones(150)]) @ H.T
    x2 = p[:, :2] / p[:, 2:] + rng.normal(0, 0.3, (150, 2))
    bad = rng.random(150) < 0.4
    x2[bad] = rng.uniform(0, 640, (bad.sum(), 2))
    r = ransac(Homography(x1, x2), 1.5, seed=0, max_iterations=5000)
    assert (r.inliers == ~bad).mean() > 0.97
    assert np.median(r.residuals[~bad]) < 0.8  # a minimal (unrefined) fit maps the true matches within the noise


def test_bad_estimators_are_named():
    xy, _ = _line_data(0, n=20)

    class NoResiduals:
        sample_size, num_data = 2, 20

        def generate(self, s):
            return [1]

    with pytest.raises(InputError, match="no method residuals"):
        ransac(NoResiduals(), 0.1)

    class WrongShape(Line):
        def residuals(self, m):
            return np.zeros(3)

    with pytest.raises(InputError, match=r"shape \(20,\)"):
        ransac(WrongShape(xy), 0.1)

    class Signed(Line):
        def residuals(self, m):
            return self.xy @ np.array(m[:2]) + m[2]

    with pytest.raises(InputError, match="non-negative"):
        ransac(Signed(xy), 0.1)

    class OneModel(Line):
        def generate(self, s):
            return (1.0, 0.0, 0.0)[0]  # a number, not a sequence of models

    with pytest.raises(InputError, match="sequence of models"):
        ransac(OneModel(xy), 0.1)

    class Boom(Line):
        def generate(self, s):
            raise RuntimeError("solver failed")

    with pytest.raises(RuntimeError, match="solver failed"):  # the estimator's own error, unchanged
        ransac(Boom(xy), 0.1)
    with pytest.raises(InputError, match="distance"):
        ransac(type("NoDistance", (), {"sample_size": 2, "num_data": 20, "generate": Line.generate, "residuals": Line.residuals, "xy": xy})(), 0.1, challengers=2)
    for kw, msg in (({"threshold": 0}, "threshold"), ({"threshold": 0.1, "scoring": "lmeds"}, "scoring"), ({"threshold": 0.1, "order": np.arange(19)}, "permutation")):
        with pytest.raises(InputError, match=msg):
            ransac(Line(xy), **kw)
    r = ransac(type("Never", (Line,), {"generate": lambda self, s: []})(xy), 0.1, max_iterations=20)
    assert r.model is None and not r.inliers.any() and r.num_iterations == 20
