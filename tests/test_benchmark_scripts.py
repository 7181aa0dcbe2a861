"""Smoke test of every script in benchmarks/: it compiles, and those with a command line answer
``--help`` (imports resolve, the parser builds). The benchmarks themselves are slow and stay out of CI;
tests/test_bench.py runs the quick versions of `poseonly bench`."""

from __future__ import annotations

import py_compile
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = sorted((Path(__file__).resolve().parents[1] / "benchmarks").glob("*.py"))


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_benchmark_script_compiles_and_answers_help(script: Path, tmp_path: Path):
    py_compile.compile(str(script), cfile=str(tmp_path / "x.pyc"), doraise=True)
    if "argparse" not in script.read_text(encoding="utf-8"):
        return
    r = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "usage" in r.stdout.lower()
