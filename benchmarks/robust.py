"""Robust benchmark (issue 3): ``python benchmarks/robust.py [...]`` == ``poseonly bench robust [...]``."""

import sys

from poseonly.bench_robust import main

if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
