"""Time and accuracy on hard real pairs: >= 500 matches with < 15 % inliers (issue 12's last time goal).

The shared data hold no Strecha pair in that regime (entry-P10's hardest have 16.5-18 % of their
matches on the ground truth), so this benchmark makes some from the real ones: each overlapping pair
whose matches are at most ``--max-gt-share`` on the truth (default 30 %) gets wrong matches added
until its truth share is ``--target`` (default 8 %, the middle of the issue's 5-8 %) and it has at
least 500 matches. An added match re-pairs a keypoint of the pair's own first image with a keypoint of
its second image (both drawn from the pair's matches, so the added matches lie where features do),
and takes the ratio score and noise scale of one of the pair's own off-truth matches (so that PROSAC
ranks them as it ranks real wrong matches); re-pairings within 3 px of the true geometry are drawn
again. Each augmented pair is solved by the default (scores and scales, as ``poseonly bench real``
calls it) and PoseLib at 1 px, alternating in one process, for ``--seeds`` seeds; printed: per pair
the median time of each and their ratio, the rotation errors and statuses, and the median ratio over
all pairs.

    python benchmarks/hard_pair_time.py /work/shared/data/strecha/entry-P10 /work/shared/data/strecha/fountain-P11 \\
        /work/shared/data/strecha/Herz-Jesus-P8 --cache /tmp/realbench_cache --out docs/results/hard_pair_time.md
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

MIN_MATCHES = 500  # the regime: at least this many matches ...
OFF_TRUTH_PX = 3.0  # an added (wrong) match must be at least this far (Sampson, px) from the truth
AUG_SEED = 1234  # the augmentation's own generator (the estimators' seeds are 0..seeds-1)


def augment(
    u1: np.ndarray, u2: np.ndarray, ratio: np.ndarray, scales: np.ndarray, on_truth: np.ndarray, off_err: np.ndarray, target: float, rng: np.random.Generator, sampson
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pair's matches plus wrong ones: ``(u1, u2, ratio, scales)`` with ``on_truth.sum() / n <= target``
    and ``n >= MIN_MATCHES``. ``sampson(a, b)`` is the Sampson error (px) of matches under the truth."""
    k = int(on_truth.sum())
    n_total = max(MIN_MATCHES, int(np.ceil(k / target)))
    add = n_total - len(u1)
    if add <= 0:
        return u1, u2, ratio, scales
    off = np.flatnonzero(off_err >= OFF_TRUTH_PX)
    pool = off if len(off) else np.arange(len(u1))
    a_list, b_list, got = [], [], 0
    while got < add:
        i = rng.integers(0, len(u1), 4 * add)
        j = rng.integers(0, len(u2), 4 * add)
        ok = (i != j) & (sampson(u1[i], u2[j]) >= OFF_TRUTH_PX)
        a_list.append(u1[i[ok]])
        b_list.append(u2[j[ok]])
        got += int(ok.sum())
    A, B = np.concatenate(a_list)[:add], np.concatenate(b_list)[:add]
    src = rng.choice(pool, add)
    order = rng.permutation(len(u1) + add)  # the estimators must not see the added matches last
    cat = lambda x, y: np.concatenate([x, y])[order]  # noqa: E731
    return cat(u1, A), cat(u2, B), cat(ratio, ratio[src]), cat(scales, scales[src])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", help="Strecha scene or realpairs folders (poseonly bench real's format)")
    ap.add_argument("--cache", default="/tmp/realbench_cache", help="poseonly bench real's SIFT match cache")
    ap.add_argument("--target", type=float, default=0.08, help="the truth's share of the augmented matches")
    ap.add_argument("--max-gt-share", type=float, default=0.3, help="pairs whose truth share is at most this are augmented")
    ap.add_argument("--min-gt", type=int, default=30, help="pairs with at least this many matches on the truth (overlapping)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--method", default="poseonly", help="a poseonly bench real method name (e.g. poseonly-consistency)")
    ap.add_argument("--out", type=Path, help="also write the table (markdown) here")
    args = ap.parse_args(argv)

    from poseonly.anchors import poselib_relpose
    from poseonly.experiments.real_bench import GT_PX, _errors, load_datasets, pair_match_data
    from poseonly.experiments.real_bench import METHODS as RB_METHODS
    from poseonly.features import sampson_error_px

    ours = RB_METHODS[args.method]
    rows, ratios = [], []
    rng = np.random.default_rng(AUG_SEED)
    for name, pairs in load_datasets(args.dirs).items():
        for p in pairs:
            u1, u2, r, sc = pair_match_data(p, Path(args.cache))
            if len(u1) == 0:
                continue
            err = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
            on = err < GT_PX
            if on.sum() < args.min_gt or on.sum() / len(u1) > args.max_gt_share:
                continue
            a1, a2, ar, asc = augment(u1, u2, r, sc, on, err, args.target, rng, lambda a, b, p=p: sampson_error_px(a, b, p.K1, p.K2, p.R, p.t))
            share = float((sampson_error_px(a1, a2, p.K1, p.K2, p.R, p.t) < GT_PX).mean())
            t_ours, t_pl, e_ours, e_pl, st = [], [], [], [], []
            for s in range(args.seeds):
                t0 = time.perf_counter()
                o = ours(a1, a2, p.K1, p.K2, 1.0 - ar, s, asc)
                t_ours.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                R, t, _, _ = poselib_relpose(a1, a2, p.K1, p.K2, threshold_px=1.0, seed=s)
                t_pl.append(time.perf_counter() - t0)
                e_ours.append(_errors(p, o)[0])
                e_pl.append(float(np.degrees(np.arccos(np.clip((np.trace(p.R.T @ R) - 1) / 2, -1, 1)))) if R is not None else float("inf"))
                st.append(str(o.status))
            ratio = float(np.median(t_ours) / np.median(t_pl))
            ratios.append(ratio)
            ok_errs = [e for e, x in zip(e_ours, st) if x == "ok"]
            worst_ok = max(ok_errs) if ok_errs else float("nan")
            times = (1e3 * np.median(t_ours), 1e3 * np.median(t_pl), ratio)
            rows.append((name, p.pid, len(a1), 100 * share, *times, np.median(e_ours), np.median(e_pl), worst_ok, ",".join(sorted(set(st)))))
            print(f"{name} {p.pid}: {len(a1)} matches, {100 * share:.1f} % on the truth: {rows[-1][4]:.0f} / {rows[-1][5]:.0f} ms = {ratio:.2f}x", flush=True)
    head = (
        f"Hard pairs: real overlapping pairs (truth share <= {args.max_gt_share:.0%}, >= {args.min_gt} matches on it) with wrong matches added "
        f"to a {args.target:.0%} truth share and >= {MIN_MATCHES} matches "
        f"(`python benchmarks/hard_pair_time.py {' '.join(args.dirs)} --target {args.target} --seeds {args.seeds} --method {args.method}`); "
        f"medians over {args.seeds} seeds; R errors in degrees.\n"
    )
    lines = [
        head,
        f"| dataset | pair | matches | on truth | {args.method} ms | PoseLib 1 px ms | ratio | {args.method} R | PoseLib R | worst `ok` R | statuses |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {c} | {d:.1f} % | {e:.0f} | {f:.0f} | {g:.2f} | {h:.3f} | {i:.3f} | {w:.3f} | {j} |" for a, b, c, d, e, f, g, h, i, w, j in rows]
    oks = [r[9] for r in rows if np.isfinite(r[9])]
    if oks:
        lines.append(f"\nLargest rotation error of an `ok` pose: {max(oks):.3f} deg.")
    lines.append(
        f"\nMedian time ratio over {len(ratios)} pairs: {np.median(ratios):.2f} (quartiles {np.percentile(ratios, 25):.2f}-{np.percentile(ratios, 75):.2f})."
        if ratios
        else "\nNo pair qualified."
    )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
