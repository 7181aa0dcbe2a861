"""Per-pair rotation-error ratio of two methods of a ``poseonly bench real`` JSON.

Usage::

    python benchmarks/pair_ratio.py docs/results/real/student_seeds5/real_bench.json poseonly poseonly-gauss
    python benchmarks/pair_ratio.py RUN_A/real_bench.json poseonly poseonly --b-json RUN_B/real_bench.json

Prints, per dataset and pooled, the geometric mean of ``R_err(A) / R_err(B)`` over the pairs and
seeds where both methods are within ``WITHIN_DEG`` of the truth (Strecha: the overlapping pairs only),
with one standard error of the mean log ratio, and the fraction of pairs where A is closer. With
``--b-json`` method B is read from a second run on the same pairs (two versions of one method). Medians
of a few dozen pairs move by several per cent with one pair; the per-pair ratio uses every pair.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from poseonly.experiments.real_bench import _subsets

WITHIN_DEG = 5.0
FLOOR_DEG = 1e-6  # errors are floored here before the log


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("json")
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--b-json", default=None, help="read method B from this run instead")
    a = ap.parse_args()
    with open(a.json, encoding="utf-8") as f:
        d = json.load(f)
    recs = d["pairs"] if "pairs" in d else d["records"]
    if a.b_json:
        with open(a.b_json, encoding="utf-8") as f:
            other = {(r["dataset"], r["id"]): r for r in json.load(f)["pairs"]}
        recs = [dict(r, methods={**r["methods"], "__b__": other[(r["dataset"], r["id"])]["methods"][a.b]}) for r in recs if (r["dataset"], r["id"]) in other]
        a.b = "__b__"
    by: dict[str, list[float]] = {}
    subset = {ds: next(iter(_subsets(kind).values())) for ds, kind in d["config"]["datasets"].items()}  # Strecha: overlapping
    for r in recs:
        if not subset[r["dataset"]](r):
            continue
        for x, y in zip(r["methods"][a.a], r["methods"][a.b], strict=True):
            ex, ey = x["R_err"], y["R_err"]
            if ex is None or ey is None or ex > WITHIN_DEG or ey > WITHIN_DEG:
                continue
            by.setdefault(r["dataset"], []).append(math.log(max(ex, FLOOR_DEG) / max(ey, FLOOR_DEG)))
    pooled: list[float] = []
    for name, v in by.items():
        pooled += v
        _row(name, np.array(v))
    _row("pooled", np.array(pooled))


def _row(name: str, v: np.ndarray) -> None:
    se = v.std() / math.sqrt(len(v))
    print(f"{name:20s} n={len(v):4d}  geo-mean ratio {math.exp(v.mean()):.3f} +- {se:.3f}  A closer {np.mean(v < 0):.2f}")


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
