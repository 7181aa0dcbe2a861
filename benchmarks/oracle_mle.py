"""How far the robust benchmark's noise floor is from what an estimator without the inlier labels can reach.

The floor of ``poseonly bench robust`` (and of ``benchmarks/synthetic_variants.py``) is Sampson least
squares on the *true* inliers, started from the true pose: it knows which matches are outliers. An
estimator that does not, even one told the true noise model, has to weigh the outliers that fall
inside the inliers' noise band (at 80 % outliers on the pinhole camera, several per scene). This
script computes, on the same scenes and seeds, the maximum-likelihood pose of the *oracle mixture*
(Gaussian inlier errors with the scene's true noise scale and inlier share, uniform outliers with the
outliers' measured density of Sampson errors near zero; all matches), from the true pose and from
the default method's pose, and prints the median rotation error of each over the floor's, with the
default's beside them, the per-scene geometric means of the ratios, and in how many scenes the two
MLEs are different maxima with the truth-started one the likelier (a search problem, not an
objective one). Where the oracle mixture's
MLE is itself well above the floor, a goal stated relative to the floor is beyond this information.

    python benchmarks/oracle_mle.py --trials 60 --outliers 0.8
    python benchmarks/oracle_mle.py --trials 60 --outliers 0.8 --cameras pinhole --kinds normal
"""

from __future__ import annotations

import argparse

import numpy as np

OUTLIER_BAND_PX = 10.0  # outliers' Sampson errors within this band estimate their density near zero
NOISE_PX = 1.0  # the robust benchmark's noise
FOCAL_PX = 800.0  # both synthetic cameras
MLE_SAME_DEG = 1e-3  # two MLEs closer than this are the same maximum
MIN_OUTLIER_DENSITY = 1e-6  # per pixel
MIN_OUTLIER_SHARE = 1e-6  # the mixture keeps an outlier component on scenes without outliers


def _oracle_mle(sc, R0: np.ndarray, t0: np.ndarray, Rt: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, float]:
    """The oracle mixture's ML rotation from (R0, t0) and its negative log-likelihood; the mixture's
    parameters measured at the truth (Rt, tt)."""
    from scipy.optimize import minimize

    from poseonly.refine._manifold import PoseChart
    from poseonly.residuals import v_sampson

    r_true = v_sampson(Rt, tt, sc.f1, sc.f2) * FOCAL_PX
    sigma = float(np.sqrt(np.mean(r_true[sc.inliers] ** 2)))
    share = min(float(np.mean(sc.inliers)), 1.0 - MIN_OUTLIER_SHARE)
    # density of an outlier's (signed) Sampson error near 0, per pixel (floored: a scene without
    # outliers, or none near the truth)
    near = np.abs(r_true[~sc.inliers]) < OUTLIER_BAND_PX
    dens = max(float(np.mean(near)) / (2.0 * OUTLIER_BAND_PX), MIN_OUTLIER_DENSITY) if near.size else MIN_OUTLIER_DENSITY
    ch = PoseChart(R0, t0)

    def nll(x: np.ndarray) -> float:
        R, t = ch.retract(x)
        r = v_sampson(R, t, sc.f1, sc.f2) * FOCAL_PX
        li = share * np.exp(-0.5 * (r / sigma) ** 2) / (np.sqrt(2.0 * np.pi) * sigma)
        return float(-np.sum(np.log(li + (1.0 - share) * dens)))

    res = minimize(nll, np.zeros(5), method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-10, "maxiter": 20000, "maxfev": 20000})
    res = minimize(nll, res.x, method="BFGS")
    return ch.retract(res.x)[0], float(res.fun)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.8])
    ap.add_argument("--cameras", nargs="+", default=["wide", "pinhole"])
    ap.add_argument("--kinds", nargs="+", default=["normal", "planar"])
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    from poseonly import estimate_relative_pose
    from poseonly.bench_robust import _twin_R, ml_floor
    from poseonly.geometry import rotation_error_deg
    from poseonly.sim import make_scene

    print(
        "| cell | floor (median deg) | default / floor | oracle MLE from the true pose / floor | oracle MLE from the default's pose / floor"
        " | per-scene geometric means (default, MLE from the truth, MLE from the default)"
        " | scenes where the two MLEs differ: the truth-started one the likelier |"
    )
    print("|---|---|---|---|---|---|---|")
    for cam in a.cameras:
        for kind in a.kinds:
            for frac in a.outliers:
                E = np.zeros((a.trials, 4))
                truth_better = differ = 0
                for s in range(a.trials):
                    sc = make_scene(300, kind, cam, NOISE_PX, frac, a.seed + s)
                    tw = _twin_R(sc) if kind == "planar" else None

                    def err(R: np.ndarray, sc=sc, tw=tw) -> float:
                        e = float(rotation_error_deg(sc.R, R))
                        return min(e, float(rotation_error_deg(tw, R))) if tw is not None else e

                    Rf = ml_floor(sc)
                    if cam == "pinhole":
                        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=a.seed + s)
                    else:
                        r = estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL_PX, seed=a.seed + s)
                    Rm, nm = _oracle_mle(sc, sc.R, sc.t, sc.R, sc.t)
                    Rd, nd = _oracle_mle(sc, r.R, r.t, sc.R, sc.t)
                    E[s] = [err(Rf), err(r.R), err(Rm), err(Rd)]
                    if rotation_error_deg(Rm, Rd) > MLE_SAME_DEG:
                        differ += 1
                        truth_better += nm < nd
                m = np.median(E, axis=0)
                g = np.exp(np.mean(np.log(np.maximum(E[:, 1:], 1e-12) / np.maximum(E[:, :1], 1e-12)), axis=0))
                print(
                    f"| {cam} {kind} {100 * frac:.0f} % | {m[0]:.4f} | {m[1] / m[0]:.3f} | {m[2] / m[0]:.3f} | {m[3] / m[0]:.3f} | {g[0]:.3f} / {g[1]:.3f} / {g[2]:.3f}"
                    f" | {differ} of {a.trials}: {truth_better} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
