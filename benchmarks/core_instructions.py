"""Instruction counts of LiRP in the compiled core, per call and per routine (callgrind).

Compiles ``benchmarks/drivers/lirp_driver.cpp`` against ``src/core`` with the package's own compiler
flags (``-O3 -fno-math-errno -fno-trapping-math -ffp-contract=off``, the AVX2 clones; Eigen from the
``cmeel-eigen`` wheel, ``pip install cmeel-eigen``, or ``pip install --target DIR cmeel-eigen`` and
``PYTHONPATH=DIR``) and runs it under ``valgrind --tool=callgrind``:
instruction counts do not depend on the machine's load, unlike the times of ``poseonly bench speed``.
Prints the instructions per ``lirp()`` call and the inclusive share of its main routines.

    python benchmarks/core_instructions.py                    # n = 30, noise-free, best-only scoring
    python benchmarks/core_instructions.py --noise 0.001 --all-costs
    python benchmarks/core_instructions.py --base /tmp/base_checkout   # the same for another checkout

Needs g++ and valgrind; with ``--time`` it also times the driver (wall clock, a shared machine's
noise included).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FLAGS = ["-std=c++17", "-O3", "-fno-math-errno", "-fno-trapping-math", "-ffp-contract=off", "-DEIGEN_MPL2_ONLY", "-DEIGEN_DONT_PARALLELIZE"]
# routines reported (inclusive instructions per lirp() call), as callgrind names them
ROUTINES = {
    "null space (QR + Gram eigenvectors + Jacobi SVD)": "null_space(",
    "action matrices' eigenvalues and eigenvectors (both)": "action_eigen(",
    "identification's sign terms of the 18 candidates (loop 1)": "sign_terms(",
    "PPO costs (loop 2)": "ppo_terms(",
}


def eigen_include() -> Path:
    for p in map(Path, sys.path):
        inc = p / "cmeel.prefix" / "include" / "eigen3"
        if (inc / "Eigen" / "Dense").is_file():
            return inc
    raise SystemExit("Eigen headers not found: pip install cmeel-eigen")


def build(checkout: Path, out: Path) -> Path:
    exe = out / "lirp_driver"
    srcs = [str(ROOT / "benchmarks" / "drivers" / "lirp_driver.cpp"), str(checkout / "src" / "core" / "lirp.cpp")]
    cmd = ["g++", *FLAGS, f"-I{checkout / 'src' / 'core'}", f"-I{eigen_include()}", *srcs, "-o", str(exe)]
    subprocess.run(cmd, check=True)
    return exe


def inclusive(annotated: str, key: str) -> int:
    """Sum of the inclusive counts of the functions whose name contains ``key`` (built without debug
    information, callgrind lists each function once: ``???:name``; AVX2 and default clones both count)."""
    total = 0
    for line in annotated.splitlines():
        m = re.match(r"\s*([\d,]+)\s+(?:\([^)]*\)\s+)?\?\?\?:(.*)", line)
        if m and key in m.group(2):
            total += int(m.group(1).replace(",", ""))
    return total


def measure(exe: Path, args: argparse.Namespace, out: Path) -> dict[str, float]:
    calls = args.calls
    run = [str(exe), str(args.points), str(calls), str(args.noise), str(int(args.all_costs))]
    cg = out / f"cg.{exe.parent.name}"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={cg}", *run], check=True, capture_output=True)
    ann = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(cg)], check=True, capture_output=True, text=True).stdout
    res = {"lirp() per call": inclusive(ann, "poseonly::lirp(") / calls}
    for label, key in ROUTINES.items():
        res[label] = inclusive(ann, key) / calls
    if args.time:
        best = min(float(subprocess.run([*run[:2], str(args.time_calls), *run[3:]], check=True, capture_output=True, text=True).stdout.split()[0]) for _ in range(5))
        res["wall us per call (best of 5)"] = best
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=30)
    ap.add_argument("--noise", type=float, default=0.0, help="bearing noise, radians (0.001 ~ 1 px at f = 1000)")
    ap.add_argument("--all-costs", action="store_true", help="every candidate's PPO cost (the public poseonly.lirp)")
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--base", type=Path, help="another checkout of the repository: its core measured beside this one")
    ap.add_argument("--time", action="store_true", help="also time the driver")
    ap.add_argument("--time-calls", type=int, default=20000)
    args = ap.parse_args(argv)
    for tool in ("g++", "valgrind", "callgrind_annotate"):
        if shutil.which(tool) is None:
            raise SystemExit(f"{tool} not found")
    with tempfile.TemporaryDirectory() as tmp:
        cols = {}
        for name, checkout in (("base", args.base), ("this", ROOT)):
            if checkout is None:
                continue
            d = Path(tmp) / name
            os.makedirs(d)
            cols[name] = measure(build(checkout.resolve(), d), args, Path(tmp))
    mode = "every cost" if args.all_costs else "best only"
    print(f"LiRP, n = {args.points}, noise {args.noise:g} rad, {mode}: instructions per call (callgrind, inclusive)")
    print("| routine | " + " | ".join(cols) + " |")
    print("|---|" + "---|" * len(cols))
    for key in next(iter(cols.values())):
        vals = [cols[c][key] for c in cols]
        fmt = "{:.2f}" if key.startswith("wall") else "{:,.0f}"
        print(f"| {key} | " + " | ".join(fmt.format(v) for v in vals) + " |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
