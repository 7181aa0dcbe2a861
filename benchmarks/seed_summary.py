"""Per-seed summary of a multi-seed ``poseonly bench real`` run (its ``real_bench.json``).

For every dataset and method: the median and mean rotation error (degrees; Strecha: overlapping
pairs, >= 30 matches within 1 px of the truth; a pair without a pose counts 180 deg in the median and
is left out of the mean), per seed and their average; the wrong ``ok`` poses (rotation error above
5 deg) per seed against the ``ok`` count; and the share of the pairs where the reference method
(PoseLib 1 px by default) is within 2 deg that stay ``ok``; on the datasets that are not Strecha
scenes, the pose AUC@5/10/20 of max(rotation, translation-direction error) averaged over the seeds and
the seed spread (standard deviation) of AUC@10 (with ``--strecha-auc`` on the Strecha scenes' scored
pairs too). The bench's own tables show seed 0 only. A ``real_frontends.json`` of
``benchmarks/real_frontends.py --full-json`` is summarised front-end by front-end.

    python benchmarks/seed_summary.py docs/results/real/floor_seeds5/real_bench.json
    python benchmarks/seed_summary.py OUT/real_frontends.json --strecha-auc
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from poseonly.experiments.real_bench import pose_auc

STRECHA = ("Herz-Jesus-P8", "entry-P10", "fountain-P11")
OVERLAP_GT_MATCHES = 30
WRONG_DEG = 5.0
REF_GOOD_DEG = 2.0
NO_POSE_DEG = 180.0


def _err(rec: dict) -> float:
    e = rec.get("R_err")
    return NO_POSE_DEG if e is None else float(e)


def _pose_err(rec: dict) -> float:
    """max(R err, t err); a pair without a pose is an infinite error (as the bench's AUC)."""
    r, t = rec.get("R_err"), rec.get("t_err")
    return float("inf") if r is None or t is None else max(float(r), float(t))


def summarize(bench: dict, reference: str = "poselib-1px", strecha_auc: bool = False) -> list[str]:
    """Lines of the summary of one ``real_bench.json`` (see the module docstring)."""
    out = []
    pairs = bench["pairs"]
    for ds in sorted({p["dataset"] for p in pairs}):
        P = [p for p in pairs if p["dataset"] == ds]
        ov = np.array([p["gt_matches"] >= OVERLAP_GT_MATCHES for p in P]) if ds in STRECHA else np.ones(len(P), bool)
        out.append(f"{ds} ({len(P)} pairs, {int(ov.sum())} scored)")
        for m in P[0]["methods"]:
            seeds = len(P[0]["methods"][m])
            meds, means, wrong, oks, kept, aucs = [], [], [], [], [], []
            for s in range(seeds):
                e = np.array([_err(p["methods"][m][s]) for p in P])
                ok = np.array([p["methods"][m][s]["status"] == "ok" for p in P])
                meds.append(float(np.median(e[ov])))
                means.append(float(np.mean(e[ov & (e < NO_POSE_DEG)])))
                wrong.append(int(np.count_nonzero(ok & (e > WRONG_DEG))))
                oks.append(int(ok.sum()))
                if ds not in STRECHA or strecha_auc:
                    aucs.append(pose_auc(np.array([_pose_err(p["methods"][m][s]) for p, o in zip(P, ov) if o])))
                if reference in P[0]["methods"]:
                    good = np.array([_err(p["methods"][reference][s]) < REF_GOOD_DEG for p in P])
                    kept.append(float(np.count_nonzero(ok & good) / max(int(good.sum()), 1)))
            line = (
                f"  {m:22s} median {np.mean(meds):.4f} ({' '.join(f'{x:.4f}' for x in meds)})"
                f"  mean {np.mean(means):.4f} ({' '.join(f'{x:.4f}' for x in means)})"
                f"  wrong ok {' '.join(f'{w}/{k}' for w, k in zip(wrong, oks))}"
            )
            if kept and m != reference:
                line += f"  kept {100 * np.mean(kept):.1f} %"
            if aucs:
                A = np.array(aucs)
                line += f"  AUC@5/10/20 {'/'.join(f'{x:.2f}' for x in A.mean(0))} (AUC@10 std {A[:, 1].std():.2f})"
            out.append(line)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("json", type=Path, help="real_bench.json of a `poseonly bench real --seeds S` run")
    ap.add_argument("--reference", default="poselib-1px", help="method whose <= 2 deg pairs should stay ok")
    ap.add_argument("--strecha-auc", action="store_true", help="the pose AUC on the Strecha scenes' scored pairs too")
    a = ap.parse_args(argv)
    bench = json.loads(a.json.read_text(encoding="utf-8"))
    if "front_ends" not in bench:
        print("\n".join(summarize(bench, a.reference, a.strecha_auc)))
        return 0
    for fe, res in bench["front_ends"].items():
        if "pairs" not in res:
            raise SystemExit(f"{a.json}: front-end {fe} has no pairs (run real_frontends.py with --full-json)")
        print("\n".join([f"## {fe}", *summarize(res, a.reference, a.strecha_auc)]))
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
