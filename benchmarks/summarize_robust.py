"""Summarise the robust benchmark's JSON outputs into the table and goal ratios of docs/RESULTS.md.

Usage::

    python benchmarks/summarize_robust.py [docs/results/robust_wide/robust.json docs/results/robust_pinhole/robust.json]

Prints (1) the markdown table of RESULTS.md section 2 - median rotation error in degrees (planar:
against the nearer of the truth and the homography twin) and median time per call in ms - and
(2) the goals of issue 3: the default's median over the noise floor at 80 % outliers, its time over
PoseLib's default there, and at <= 50 % outliers its time over OpenCV USAC_MAGSAC's with the three
methods' medians.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT = [REPO / "docs/results/robust_wide/robust.json", REPO / "docs/results/robust_pinhole/robust.json"]
COLUMNS = [
    "poseonly (default)",
    "GNC-RANSAC (paper)",
    "GNC-IRLS (pixel bound)",
    "OpenCV USAC_MAGSAC",
    "PoseLib (default)",
    "OpenCV USAC_MAGSAC (3 px)",
    "PoseLib (default, 3 px)",
    "noise floor (ML on true inliers)",
]
FLOOR = COLUMNS[-1]


def _index(path: Path) -> tuple[str, dict]:
    d = json.loads(Path(path).read_text())
    rows = {(r["scene"], r["outliers"], r["method"]): r for r in d["rows"]}
    return d["rows"][0]["camera"], rows


def _err(r: dict, scene: str) -> float:
    return r["median_twin"] if scene == "planar" else r["median"]


def main(argv: list[str] | None = None) -> int:
    paths = [Path(p) for p in (argv if argv else DEFAULT)]
    tables = [_index(p) for p in paths]
    print("| camera, scene | outliers | default | GNC-RANSAC (paper) | GNC-IRLS | MAGSAC | PoseLib default | MAGSAC 3 px | PoseLib 3 px | noise floor |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for cam, idx in tables:
        for scene in ("normal", "planar"):
            for o in (0.0, 0.5, 0.8):
                cells = []
                for m in COLUMNS:
                    r = idx.get((scene, o, m))
                    if r is None:  # an older run without this method
                        cells.append("-")
                        continue
                    v = r["median"] if m == FLOOR else _err(r, scene)
                    cells.append(f"{v:.3g}" if m == FLOOR else f"{v:.3g} ({r['time_ms']:.0f})")
                print(f"| {cam}, {scene} | {o * 100:.0f} % | " + " | ".join(cells) + " |")
    print()
    for cam, idx in tables:
        for scene in ("normal", "planar"):
            fl = idx[(scene, 0.8, FLOOR)]["median"]
            a, p = idx[(scene, 0.8, COLUMNS[0])], idx[(scene, 0.8, "PoseLib (default)")]
            p3 = idx.get((scene, 0.8, "PoseLib (default, 3 px)"))
            print(
                f"{cam} {scene}, 80 % outliers: default / floor {a['median'] / fl:.2f} (vs truth), {_err(a, scene) / fl:.2f} "
                f"(nearer of truth and twin); PoseLib default / floor {_err(p, scene) / fl:.2f}"
                + (f", PoseLib 3 px / floor {_err(p3, scene) / fl:.2f}" if p3 else "")
                + f"; default time / PoseLib time {a['time_ms'] / p['time_ms']:.2f}"
            )
            for o in (0.0, 0.2, 0.4, 0.5):
                a, m, p = idx[(scene, o, COLUMNS[0])], idx[(scene, o, "OpenCV USAC_MAGSAC")], idx[(scene, o, "PoseLib (default)")]
                p3 = idx.get((scene, o, "PoseLib (default, 3 px)"))
                print(
                    f"    {o * 100:.0f} %: default time / MAGSAC time {a['time_ms'] / m['time_ms']:.2f} ({a['time_ms']:.1f} / "
                    f"{m['time_ms']:.1f} ms); median default {_err(a, scene):.3g}, PoseLib {_err(p, scene):.3g}, MAGSAC {_err(m, scene):.3g}"
                    + (f", PoseLib 3 px {_err(p3, scene):.3g}" if p3 else "")
                )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main(sys.argv[1:]))
