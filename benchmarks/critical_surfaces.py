"""Statuses on critical surfaces: two poses fit every match exactly (``poseonly.sim_hard.critical_surface``).

Two views of points on a ruled quadric through both centres cannot tell the true pose from the second
one (8-20 deg away), so an ``ok`` pose is a coin flip the status vouches for. Prints, per noise level,
the default's statuses over ``--scenes`` scenes and ``--seeds`` seeds, the ``ok`` poses more than 2 deg
from the truth, and the runs where the search's own result was a rival of the pose returned
(``diagnostics["rival_search_own"]``). docs/RELIABILITY.md, "Critical surfaces".

    python benchmarks/critical_surfaces.py --scenes 30 --seeds 3
"""

from __future__ import annotations

import argparse
import collections
import json

WRONG_DEG = 2.0  # an ok pose further than this from the truth counts as wrong


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=30, help="scenes per noise level (default 30)")
    ap.add_argument("--seeds", type=int, default=3, help="estimator seeds per scene (default 3)")
    ap.add_argument("--noise", type=float, nargs="+", default=[0.1, 0.5], help="pixel noise levels (default 0.1 0.5)")
    ap.add_argument("--points", type=int, default=200, help="matches per scene (default 200)")
    ap.add_argument("--options", type=json.loads, default={}, help='the method\'s options as JSON (default {}: the default method), e.g. \'{"lo": "sampson-cauchy-auto"}\'')
    a = ap.parse_args(argv)
    from poseonly import estimate_relative_pose, rotation_error_deg
    from poseonly.sim_hard import critical_surface

    for noise in a.noise:
        st: collections.Counter[str] = collections.Counter()
        wrong = own = 0
        for scene in range(a.scenes):
            c = critical_surface(a.points, noise_px=noise, seed=scene)
            for seed in range(a.seeds):
                r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=seed, **a.options)
                st[r.status] += 1
                wrong += r.status == "ok" and rotation_error_deg(r.R, c.R) > WRONG_DEG
                own += bool(r.diagnostics.get("rival_search_own"))
        n = a.scenes * a.seeds
        print(f"noise {noise:g} px: {dict(sorted(st.items()))} of {n}; ok more than {WRONG_DEG:g} deg off: {wrong}; the search's result a rival: {own}", flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
