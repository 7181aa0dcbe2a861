"""Probe of pysuperansac on two fountain-P11 pairs (docs/RESULTS_real.md, SupeRANSAC caveat).

Runs ``pysuperansac.estimateEssentialMatrix`` four times per configuration on the cached SIFT
matches of the real benchmark (PROSAC order by ratio) and prints (inliers, iterations) per call.

    PYTHONPATH=src python benchmarks/superansac_probe.py [CACHE]   # CACHE: the --cache of `bench real`
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from poseonly.experiments import real_bench as rb

SCENE = Path("/work/shared/data/strecha/fountain-P11")
PAIRS = ("2-7", "1-8")


def main(cache: Path) -> None:
    import pysuperansac as sr

    pairs = {p.pid: p for p in rb.load_strecha(SCENE)}
    variants = {
        "authors": {},
        "min_iterations=5000": {"min_iterations": 5000},
        "confidence=0.99": {"confidence": 0.99},
        "uniform sampler": {"sampler": sr.SamplerType.Uniform},
        "GC-RANSAC LO": {"local_optimization": sr.LocalOptimizationType.GCRANSAC},
        "IRLS final": {"final_optimization": sr.LocalOptimizationType.IteratedLSQ},
        "library defaults": None,
    }
    for pid in PAIRS:
        p = pairs[pid]
        u1, u2, r = rb.pair_matches(p, cache)
        order = np.argsort(r, kind="stable")
        corr = np.ascontiguousarray(np.hstack([u1[order], u2[order]]))
        size = [2 * p.K1[0, 2] + 1, 2 * p.K1[1, 2] + 1, 2 * p.K2[0, 2] + 1, 2 * p.K2[1, 2] + 1]
        for label, kw in variants.items():
            out = []
            for _ in range(4):
                cfg = sr.RANSACSettings()
                if kw is not None:
                    cfg.inlier_threshold = rb.SUPERANSAC_THRESHOLD_PX
                    cfg.confidence = rb.SUPERANSAC_CONFIDENCE
                    cfg.max_iterations = rb.SUPERANSAC_MAX_ITERATIONS
                    cfg.sampler = sr.SamplerType.PROSAC
                    cfg.scoring = sr.ScoringType.MAGSAC
                    cfg.local_optimization = sr.LocalOptimizationType.NestedRANSAC
                    cfg.final_optimization = sr.LocalOptimizationType.LSQ
                    for k, v in kw.items():
                        setattr(cfg, k, v)
                _, inl, _, it = sr.estimateEssentialMatrix(corr, p.K1, p.K2, size, [], config=cfg)
                out.append((len(inl), it))
            print(f"fountain-P11 {pid} ({len(u1)} matches): {label}: (inliers, iterations) = {out}", flush=True)


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp/realbench_cache"))
