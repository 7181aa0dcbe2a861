"""The speed benchmark's thread row alone (8 pairs on 2 threads against serial, 21 alternating repeats),
run ``--runs`` times in one process: how far this machine's 2-thread scaling drifts from minute to
minute, for the whole method and for the GIL-free core search alone.

    OMP_NUM_THREADS=1 python benchmarks/threads_row.py --runs 3
"""

from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=21)
    a = ap.parse_args(argv)
    from poseonly.bench_speed import threads_row
    from poseonly.experiments._common import code_version, single_thread

    single_thread()
    print(f"code {code_version()}")
    for k in range(a.runs):
        r = threads_row(repeats=a.repeats)
        q, qs = r["speedup_quartiles"], r["search_speedup_quartiles"]
        print(
            f"run {k + 1}: whole method {r['speedup']:.2f}x (quartiles {q[0]:.2f}-{q[1]:.2f}), "
            f"core search alone {r['search_speedup']:.2f}x (quartiles {qs[0]:.2f}-{qs[1]:.2f}), identical results {r['identical_results']}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
