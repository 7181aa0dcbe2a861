"""Speed benchmark (issue 6): ``python benchmarks/speed.py [...]`` == ``poseonly bench speed [...]``.

The code lives in :mod:`poseonly.bench_speed` so the installed command can run it.
"""

import sys

from poseonly.bench_speed import main

if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
