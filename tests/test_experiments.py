"""Experiments end-to-end (``--quick``) and the OpenGV-default RANSAC + 5pt baseline."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from poseonly.cli import main
from poseonly.geometry import normalize, rotation_error_deg
from poseonly.residuals import v_E
from poseonly.sim import make_scene

pytest.importorskip("matplotlib")

EXPERIMENTS = ["table2", "noise", "residuals", "gnc-ransac", "chirality"]


@pytest.mark.parametrize("name", EXPERIMENTS)
def test_experiment_quick_end_to_end(name, tmp_path, capsys):
    assert main(["experiment", name, "--quick", "--out", str(tmp_path)]) == 0
    for ext in ("md", "json", "png"):
        f = tmp_path / f"{name}.{ext}"
        assert f.is_file() and f.stat().st_size > 0, f
    data = json.loads((tmp_path / f"{name}.json").read_text())
    assert data["trials"] >= 1
    md = (tmp_path / f"{name}.md").read_text()
    assert "|" in md
    assert md.splitlines()[0] in capsys.readouterr().out  # the table is printed too


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_opengv_ransac_5pt_exact_with_outliers(seed):
    from poseonly.experiments.opengv_ransac import opengv_ransac_5pt

    sc = make_scene(100, "normal", "wide", 0.0, 0.3, seed=seed)
    r = opengv_ransac_5pt(sc.f1, sc.f2, np.random.default_rng(seed), max_iterations=1000)
    assert rotation_error_deg(sc.R, r.R) < 1e-6
    assert np.degrees(np.arccos(np.clip(r.t @ sc.t, -1, 1))) < 1e-6
    assert np.array_equal(r.inliers, sc.inliers)
    assert r.num_inliers == 70
    # adaptive stop: w = 0.7, sample size 8 -> k = log(0.01) / log(1 - 0.7^8) ~ 78 samples
    assert r.num_iterations <= 100


def test_opengv_ransac_5pt_iteration_cap_and_input():
    from poseonly.experiments.opengv_ransac import OPENGV_THRESHOLD, opengv_ransac_5pt

    assert OPENGV_THRESHOLD == pytest.approx(7.8125e-7, rel=1e-4)
    sc = make_scene(60, "normal", "wide", 1.0, 0.8, seed=3)
    r = opengv_ransac_5pt(sc.f1, sc.f2, 0, max_iterations=50)
    assert r.num_iterations <= 51  # OpenGV stops once iterations > max_iterations
    with pytest.raises(ValueError):
        opengv_ransac_5pt(sc.f1[:7], sc.f2[:7], 0)


def test_no_chirality_generator_keeps_points_behind_the_cameras():
    from poseonly.experiments.chirality import make_scene_no_chirality

    sc = make_scene_no_chirality(200, 0.0, 0.0, seed=4)
    X2 = sc.X @ sc.R.T + sc.baseline * sc.t
    behind = (sc.X[:, 2] <= 0) | (X2[:, 2] <= 0)
    assert 0.2 < behind.mean() < 0.9
    assert np.max(v_E(sc.R, sc.t, sc.f1, sc.f2)) < 1e-12  # still exact two-view geometry
    assert np.allclose(sc.f1, normalize(sc.X))


def test_planar_twin_is_another_exact_pose_or_none():
    """Wide-angle planar scenes rarely have an exact twin (its reconstruction usually puts points
    behind a camera, which the PPO residual sees); when one exists it is a distinct exact pose."""
    from poseonly.experiments.gnc_ransac import planar_twin
    from poseonly.solvers.lirp import lirp

    found = 0
    for seed in range(30):
        sc = make_scene(300, "planar", "wide", 0.0, 0.0, seed=seed)
        tw = planar_twin(sc)
        if tw is None:
            continue
        found += 1
        assert rotation_error_deg(sc.R, tw) > 0.5
        b1, b2 = normalize(sc.X), normalize(sc.X @ sc.R.T + sc.baseline * sc.t)
        o = lirp(b1, b2)
        k = int(np.argmin(rotation_error_deg(tw, o.candidates_R)))
        assert np.max(v_E(o.candidates_R[k], o.candidates_t[k], b1, b2)) < 1e-8
    assert found >= 1
    assert planar_twin(make_scene(300, "planar", "wide", 0.0, 0.0, seed=0)) is None


def test_robust_npt_keeps_the_last_estimate_when_a_later_solve_fails():
    from poseonly.experiments.chirality import robust_npt, solver_errors_types

    assert all(isinstance(e, type) and issubclass(e, BaseException) for e in solver_errors_types())
    sc = make_scene(40, "normal", "wide", 1.0, 0.2, seed=5)  # outliers: the weights change after the first solve
    calls = []

    def fake_npt(f1, f2, w):
        calls.append(1)
        if len(calls) > 1:
            raise ValueError("solver failed")
        from poseonly.geometry import essential_from_pose

        return sc.R, sc.t, {"E": essential_from_pose(sc.R, sc.t)}

    R, t, w, it = robust_npt(sc.f1, sc.f2, fake_npt)
    assert np.allclose(R, sc.R) and len(calls) == 2
    with pytest.raises(ValueError):
        robust_npt(sc.f1, sc.f2, lambda *a: (_ for _ in ()).throw(ValueError("first solve fails")))


def test_chirality_compute_counts_failed_methods(monkeypatch):
    from poseonly.experiments import chirality

    def boom(sc, s):
        raise ValueError("no solution")

    monkeypatch.setattr(chirality, "_methods", lambda c: ({"boom": boom}, {}))
    res = chirality.compute(1, n=20, outliers=(0.0,))
    assert res["results"]["chirality"]["boom"]["fail"] == [1]


def test_atomic_writers_give_files_the_default_mode(tmp_path):
    """Outputs written through a temp file get the mode a plain open() gives (not mkstemp's 0600)."""
    import os

    from poseonly._fileutil import atomic_savez
    from poseonly.experiments._common import atomic_write_text

    ref = tmp_path / "plain.txt"
    ref.write_text("x")
    a = atomic_write_text(tmp_path / "a.md", "x")
    atomic_savez(tmp_path / "b.npz", v=np.ones(2))
    for p in (a, tmp_path / "b.npz"):
        assert os.stat(p).st_mode & 0o777 == os.stat(ref).st_mode & 0o777
    assert sorted(q.name for q in tmp_path.iterdir()) == ["a.md", "b.npz", "plain.txt"]  # no temp files left


def test_experiment_without_out_writes_a_new_folder_under_the_working_directory(tmp_path, monkeypatch):
    """Issue 13: without ``--out`` an experiment never writes into ``docs/results`` of the working
    directory; it creates a new folder ``poseonly-NAME-<date>-<time>`` there (a second run, another)."""
    from poseonly._fileutil import new_results_dir

    monkeypatch.chdir(tmp_path)
    (tmp_path / "docs" / "results").mkdir(parents=True)
    assert main(["experiment", "chirality", "--quick"]) == 0
    made = sorted(p for p in tmp_path.iterdir() if p.name.startswith("poseonly-chirality-"))
    assert len(made) == 1 and (made[0] / "chirality.md").is_file()
    assert not any((tmp_path / "docs" / "results").iterdir())
    a, b = new_results_dir("x"), new_results_dir("x")
    assert a != b and a.parent == b.parent == tmp_path and not any(a.iterdir())


def test_code_version_only_for_poseonly_checkouts(tmp_path, monkeypatch):
    """A package installed inside a user's own git repository must not report the user's commit as its
    code version (a packaging trial): ``code_version`` is None unless the package is ``src/poseonly`` of
    the checkout."""
    import shutil
    import subprocess

    from poseonly.experiments import report

    if shutil.which("git") is None:
        pytest.skip("git not installed")
    repo = tmp_path / "user_repo"
    pkg = repo / ".venv" / "site-packages" / "poseonly"
    (pkg / "experiments").mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    subprocess.run(["git", "-C", str(repo), "-c", "user.email=a@b", "-c", "user.name=a", "commit", "-q", "--allow-empty", "-m", "x"], check=True)
    monkeypatch.setattr(report, "__file__", str(pkg / "experiments" / "report.py"))
    assert report.code_version() is None
    monkeypatch.undo()
    if (Path(report.__file__).resolve().parents[3] / ".git").exists():  # this checkout (not a wheel)
        assert report.code_version() is not None


def test_table2_columns_of_a_method_without_d_min_say_so():
    """A researcher's trial: the N-point column printed "(err, nan)" under a d_min header in every row."""
    from poseonly.experiments.table2 import to_markdown

    def cell(err, d):
        return {"mean_err": err, "mean_d_min": d, "mean_err_oracle": err}

    res = {"methods": ["LiRP (m)", "Npt (m)"], "rows": [{"scene": "normal", "noise_px": 0.1, "LiRP (m)": cell(0.0128, 0.236), "Npt (m)": cell(0.0117, None)}]}
    md = to_markdown(res)
    assert "Npt (m): mean err (deg) (no d_min)" in md and "| 0.0117 |" in md and "(0.0128, 0.236)" in md and "nan" not in md
