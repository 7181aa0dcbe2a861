"""Per-pair differences of one method between two ``poseonly bench real`` runs on the same matches.

For every pair and seed present in both JSON files: whether the rotation error is the same (within
``--tol`` degrees), the largest change, and the status flips (listed); per dataset, among the changed
pair-seeds, how many got better and worse and the geometric mean of new / old rotation error. Use it to
show that a change of the code leaves the real benchmark's results as they were, or where it moves them.

    python benchmarks/compare_runs.py NEW/real_bench.json OLD/real_bench.json --method poseonly
    python benchmarks/compare_runs.py NEW/real_bench.json OLD/real_bench.json --method poseonly --old-method poseonly-floor500
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

SAME_TOL_DEG = 1e-9  # rotation errors this close count as the same result (rounding of the solvers)


def _runs(path: str, method: str) -> dict[tuple[str, str, int], dict[str, Any]]:
    with open(path) as fh:
        data = json.load(fh)
    out = {}
    for p in data["pairs"]:
        for s, r in enumerate(p["methods"].get(method, [])):
            out[(p["dataset"], p["id"], s)] = r
    return out


def compare(new: dict, old: dict, tol: float) -> dict[str, Any]:
    """``new`` / ``old``: ``{(dataset, pair, seed): result}``; returns counts, the largest change and
    the status flips."""
    keys = sorted(set(new) & set(old))
    same, worst, flips = 0, 0.0, []
    for k in keys:
        a, b = new[k]["R_err"], old[k]["R_err"]
        d = abs(a - b) if math.isfinite(a) and math.isfinite(b) else (0.0 if a == b else math.inf)
        same += d <= tol
        worst = max(worst, d)
        if new[k]["status"] != old[k]["status"]:
            flips.append((k, old[k]["status"], new[k]["status"], b, a))
    return {"compared": len(keys), "same": same, "max_change_deg": worst, "flips": flips}


def paired_by_dataset(new: dict, old: dict, tol: float) -> dict[str, tuple[int, int, int, float]]:
    """Per dataset: (pair-seeds with finite errors, better, worse, geometric mean of new / old over the
    changed ones; nan when none changed)."""
    out: dict[str, tuple[int, int, int, float]] = {}
    for ds in sorted({k[0] for k in set(new) & set(old)}):
        pairs = [(new[k]["R_err"], old[k]["R_err"]) for k in sorted(set(new) & set(old)) if k[0] == ds]
        pairs = [(a, b) for a, b in pairs if math.isfinite(a) and math.isfinite(b)]
        changed = [(a, b) for a, b in pairs if abs(a - b) > tol and a > 0.0 and b > 0.0]
        better = sum(a < b for a, b in changed)
        gm = math.exp(sum(math.log(a / b) for a, b in changed) / len(changed)) if changed else math.nan
        out[ds] = (len(pairs), better, len(changed) - better, gm)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("new")
    ap.add_argument("old")
    ap.add_argument("--method", default="poseonly")
    ap.add_argument("--old-method", default=None, help="the method's name in OLD (default: --method)")
    ap.add_argument("--tol", type=float, default=SAME_TOL_DEG, help="degrees of rotation error counted as no change")
    a = ap.parse_args(argv)
    c = compare(_runs(a.new, a.method), _runs(a.old, a.old_method or a.method), a.tol)
    print(f"{c['compared']} pair-seeds compared: {c['same']} the same (within {a.tol:g} deg), {c['compared'] - c['same']} changed, largest change {c['max_change_deg']:.3g} deg")
    print(f"status flips: {len(c['flips'])}")
    for (ds, pid, s), so, sn, eo, en in c["flips"]:
        print(f"  {ds} {pid} seed {s}: {so} ({eo:.3f} deg) -> {sn} ({en:.3f} deg)")
    print("changed pair-seeds per dataset: better / worse, geometric mean of new / old rotation error")
    for ds, (n, better, worse, gm) in paired_by_dataset(_runs(a.new, a.method), _runs(a.old, a.old_method or a.method), a.tol).items():
        print(f"  {ds}: {better} / {worse} of {n}, {gm:.3f}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
