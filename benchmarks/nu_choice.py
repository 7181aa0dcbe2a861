"""The ML stage's chosen degrees of freedom on synthetic scale-mixture errors.

Usage::

    python benchmarks/nu_choice.py --nu 1 --scales 0.05 0.1 0.2 --scenes 15

Scenes of ``tests/test_ml_student.py`` (pinhole, 300 matches, 30 % uniform outliers): every match has
its own pixel noise scale, ``scale^2 nu / chi2_nu``, so the Sampson errors are Student-t with ``nu``
degrees of freedom. Prints the nu that ``poseonly._core.ml_refine`` chooses per scene, from the true
pose, with the outlier range T = 3 px.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from poseonly import _core  # noqa: E402
from test_ml_student import T_PX, _bearings, _heavy_scene  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--nu", type=float, default=1.0)
    ap.add_argument("--scales", type=float, nargs="+", default=[0.05, 0.1, 0.2])
    ap.add_argument("--scenes", type=int, default=15)
    a = ap.parse_args()
    for scale in a.scales:
        chosen = []
        for seed in range(a.scenes):
            sc, u1, u2 = _heavy_scene(seed, nu=a.nu, scale_px=scale)
            m = _core.ml_refine(sc.R, sc.t, _bearings(u1, sc.K), _bearings(u2, sc.K), T_PX / sc.K[0, 0], rounds=50, pose_tol=1e-10)
            chosen.append(m["nu"])
        print(f"true nu {a.nu:g}, scale {scale:g} px: chosen {chosen}")


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
