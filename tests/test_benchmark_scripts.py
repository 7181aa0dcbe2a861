"""Smoke test of every script in benchmarks/: it compiles, and those with a command line answer
``--help`` (imports resolve, the parser builds). The benchmarks themselves are slow and stay out of CI;
tests/test_bench.py runs the quick versions of `poseonly bench`."""

from __future__ import annotations

import py_compile
import subprocess
import sys
from pathlib import Path

import numpy as np
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
    # its output starts with the command and the code that printed it (a docs audit: figures no output
    # tied to a commit)
    assert r.stdout.startswith(f"# python {script}") and "# poseonly " in r.stdout.splitlines()[1]


def test_provenance_names_the_command_and_the_code():
    from poseonly.experiments.report import code_version, provenance

    lines = provenance().splitlines()
    assert len(lines) == 2 and lines[0].startswith("# python ") and f"code {code_version()}," in lines[1] and "UTC" in lines[1]


def test_hard_cases_benchmark_runs(capsys):
    """benchmarks/hard_cases.py end to end on one scene of one case (PoseLib is its anchor)."""
    pytest.importorskip("poselib")
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import hard_cases
    finally:
        sys.path.pop(0)
    assert hard_cases.main(["--seeds", "1", "--cases", "second_motion", "--option", "challengers=2"]) == 0
    out = capsys.readouterr().out
    assert "second_motion" in out and "PoseLib 1 px median" in out and "ratio" in out


def test_ml_collapse_survey_runs(capsys):
    """benchmarks/ml_collapse_survey.py end to end on two scenes of one cell."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import ml_collapse_survey
    finally:
        sys.path.pop(0)
    assert ml_collapse_survey.main(["--scenes", "2", "--cells", "1"]) == 0
    out = capsys.readouterr().out
    assert "wide normal 80%: collapsed" in out and "of 2" in out


def test_compare_runs_counts_changes_and_flips(tmp_path: Path, capsys):
    """benchmarks/compare_runs.py on two hand-made runs: one pair unchanged, one moved with a status flip,
    one only in the new run (not compared)."""
    import json

    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import compare_runs
    finally:
        sys.path.pop(0)

    def run(path: Path, rows: list[tuple[str, float, str]]) -> str:
        pairs = [{"dataset": "d", "id": pid, "methods": {"poseonly": [{"R_err": e, "status": s}]}} for pid, e, s in rows]
        path.write_text(json.dumps({"pairs": pairs}))
        return str(path)

    new = run(tmp_path / "new.json", [("a", 0.5, "ok"), ("b", 7.0, "ambiguous"), ("c", 1.0, "ok")])
    old = run(tmp_path / "old.json", [("a", 0.5, "ok"), ("b", 0.25, "ok")])
    assert compare_runs.main([new, old]) == 0
    out = capsys.readouterr().out
    assert "2 pair-seeds compared: 1 the same" in out and "1 changed, largest change 6.75 deg" in out
    assert "status flips: 1" in out and "d b seed 0: ok (0.250 deg) -> ambiguous (7.000 deg)" in out


def test_oracle_mle_runs(capsys):
    """benchmarks/oracle_mle.py end to end on one scene of one cell: the oracle mixture's MLE from the
    true pose stays near the floor on a scene without outliers."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import oracle_mle
    finally:
        sys.path.pop(0)
    assert oracle_mle.main(["--trials", "1", "--outliers", "0.0", "--cameras", "wide", "--kinds", "normal"]) == 0
    row = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| wide normal 0 %")]
    assert len(row) == 1
    cells = [c.strip() for c in row[0].strip("|").split("|")]
    assert 0.5 < float(cells[3]) < 2.0  # oracle MLE from the truth over the floor


def test_pair_probe_counts_the_truth_and_the_poses():
    """benchmarks/pair_probe.py's probe on a synthetic pinhole scene: the truth row counts the matches
    on the true geometry, every pose row counts its own and the shared ones (never more than the truth's)."""
    from poseonly import sim

    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import pair_probe
    finally:
        sys.path.pop(0)
    sc = sim.make_scene(200, camera="pinhole", noise_px=0.3, outlier_fraction=0.3, seed=3)
    rows = pair_probe.probe(sc.u1, sc.u2, sc.K, sc.K, sc.R, sc.t, None, None, seeds=2)
    truth = rows[0]
    assert truth["method"] == "truth" and truth["within"] == truth["gt_within"] >= int(0.6 * sc.inliers.sum())
    ours = [r for r in rows if r["method"] == "poseonly"]
    assert [r["seed"] for r in ours] == [0, 1]
    for r in rows[1:]:
        assert r["R_err"] < 1.0 and 0 < r["gt_within"] <= min(r["within"], truth["within"])
    assert all(r["status"] == "ok" for r in ours)


def test_hard_pair_augmentation():
    """benchmarks/hard_pair_time.py's augment: at least 500 matches, the truth's share at most the
    target, every added match off the truth, the pair's own matches kept."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import hard_pair_time
    finally:
        sys.path.pop(0)
    rng = np.random.default_rng(0)
    n = 200
    u1 = rng.uniform(0, 640, (n, 2))
    u2 = u1 + np.where(np.arange(n)[:, None] < 60, 5.0, rng.uniform(-200, 200, (n, 2)))  # the first 60 on the "truth"

    def sampson(a, b):  # a stand-in truth: a pure 5 px shift
        return np.linalg.norm(b - a - 5.0, axis=1)

    err = sampson(u1, u2)
    on = err < 1.0
    a1, a2, r, s = hard_pair_time.augment(u1, u2, rng.random(n), np.ones(n), on, err, 0.08, np.random.default_rng(1), sampson)
    assert len(a1) == len(a2) == len(r) == len(s) >= max(hard_pair_time.MIN_MATCHES, int(np.ceil(60 / 0.08)))
    assert np.count_nonzero(sampson(a1, a2) < 1.0) == 60
    kept = {tuple(x) for x in np.hstack([a1, a2]).round(9)}
    assert all(tuple(x) in kept for x in np.hstack([u1, u2]).round(9))


def test_sfm_scale_runs(tmp_path: Path):
    """benchmarks/sfm_scale.py end to end on a 60-view graph, every stage (each in its own subprocess)."""
    import json

    out = tmp_path / "scale.json"
    script = SCRIPTS[0].parent / "sfm_scale.py"
    cmd = [sys.executable, str(script), "--views", "60", "80", "--stages", "rotation_averaging", "ligt", "ligt_averaged", "pipeline", "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr[-2000:]
    rows = json.loads(out.read_text())["rows"]
    assert [(x["stage"], x["views"]) for x in rows] == [(st, n) for n in (60, 80) for st in ("rotation_averaging", "ligt", "ligt_averaged", "pipeline")]
    for x in rows:
        if x["stage"] == "rotation_averaging":
            assert x["outliers_found"] == x["outliers_true"] and x["rot_mean_deg_rotalign"] < 1.0
        elif x["stage"] == "pipeline":
            assert x["views_posed"] == x["views"] and x["pos_mean_frac"] < 0.01 and x["points_valid"] > 0
        else:
            assert x["normalization"] == "noise" and x["pos_mean_frac"] < 0.01


def test_warped_statuses_runs(capsys):
    """benchmarks/warped_statuses.py end to end on the embedded demo image, one seed: every pure rotation
    and the shift `pure_rotation`, the sideways plane `ok` with its true rotation."""
    pytest.importorskip("cv2")
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import warped_statuses
    finally:
        sys.path.pop(0)
    assert warped_statuses.main(["--seeds", "1"]) == 0
    out = capsys.readouterr().out
    assert "ok (a made-up translation) 0 of 5" in out, out
    line = next(x for x in out.splitlines() if "t = 0.2 d sideways" in x)
    assert "{'ok': 1}" in line and float(line.split("error ")[1].split()[0]) < 0.05


def test_shoulder_study_runs(capsys):
    """benchmarks/shoulder_study.py's synthetic table on one seed a cell."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import shoulder_study
    finally:
        sys.path.pop(0)
    assert shoulder_study.main(["--synthetic", "--seeds", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n| ") == 10 and "band test" in out


def test_vo_frames_runs(capsys):
    """benchmarks/vo_frames.py on two consecutive KITTI pairs of the shared data (skipped without it)."""
    kitti = Path(__file__).resolve().parents[2] / "shared" / "data" / "realpairs" / "kitti_seq1"
    if not (kitti / "pairs.json").is_file():
        pytest.skip("../shared/data/realpairs/kitti_seq1 is not here")
    pytest.importorskip("cv2")
    pytest.importorskip("poselib")
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import vo_frames
    finally:
        sys.path.pop(0)
    assert vo_frames.main([str(kitti), "--features", "orb", "--pairs", "2"]) == 0
    out = capsys.readouterr().out
    assert "2 consecutive pairs" in out and "poseonly-video" in out and "statuses" in out


def test_critical_surfaces_runs(capsys):
    """benchmarks/critical_surfaces.py end to end on two scenes, one seed."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import critical_surfaces
    finally:
        sys.path.pop(0)
    assert critical_surfaces.main(["--scenes", "2", "--seeds", "1", "--noise", "0.5", "--options", '{"lo": "sampson-cauchy-auto"}']) == 0
    out = capsys.readouterr().out
    assert "noise 0.5 px:" in out and "of 2;" in out


def test_seed_summary_of_a_front_end_run(tmp_path: Path, capsys):
    """benchmarks/seed_summary.py on a hand-made ``real_frontends.json``: one block per front-end, the
    Strecha scenes' AUC on their scored pairs with ``--strecha-auc`` only; a run without the pairs is
    refused by name."""
    import json

    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import seed_summary
    finally:
        sys.path.pop(0)

    def rec(e: float, s: str = "ok") -> dict:
        return {"R_err": e, "t_err": e, "status": s}

    pairs = [
        {"dataset": "entry-P10", "id": "0-1", "gt_matches": 100, "methods": {"poseonly": [rec(1.0), rec(3.0)], "poselib-1px": [rec(1.0), rec(1.0)]}},
        {"dataset": "entry-P10", "id": "0-9", "gt_matches": 5, "methods": {"poseonly": [rec(90.0), rec(90.0)], "poselib-1px": [rec(90.0), rec(90.0)]}},
    ]
    path = tmp_path / "real_frontends.json"
    path.write_text(json.dumps({"front_ends": {"fe-a": {"pairs": pairs}, "fe-b": {"pairs": pairs}}}))
    assert seed_summary.main([str(path), "--strecha-auc"]) == 0
    out = capsys.readouterr().out
    assert "## fe-a" in out and "## fe-b" in out and "entry-P10 (2 pairs, 1 scored)" in out
    # the scored pair only: 1 and 3 deg on the two seeds, AUC@10 95 and 85 (the recall curve rises
    # linearly from 0 at 0 deg: pose_auc), so 90 with std 5; the 90 deg pair would add a zero
    assert "median 2.0000 (1.0000 3.0000)" in out and "/90.00/" in out and "(AUC@10 std 5.00)" in out, out
    assert seed_summary.main([str(path)]) == 0
    assert "AUC" not in capsys.readouterr().out.split("poseonly")[1].split("\n")[0]
    path.write_text(json.dumps({"front_ends": {"fe-a": {"summary": {}}}}))
    with pytest.raises(SystemExit, match="fe-a has no pairs"):
        seed_summary.main([str(path)])


def test_lirp_public_path_benchmark_runs(capsys):
    """benchmarks/lirp_public_path.py on one scene, one round of two calls."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import lirp_public_path
    finally:
        sys.path.pop(0)
    assert lirp_public_path.main(["--points", "30", "--scenes", "1", "--rounds", "1", "--calls", "2"]) == 0
    out = capsys.readouterr().out
    assert "public / core" in out and "checked" in out


def test_parallax_statuses_runs(capsys):
    """benchmarks/parallax_statuses.py end to end on two scenes of one cell per depth field."""
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import parallax_statuses
    finally:
        sys.path.pop(0)
    assert parallax_statuses.main(["--seeds", "2", "--matches", "40", "--outliers", "0.3"]) == 0
    out = capsys.readouterr().out
    assert "random depths,  40 matches, 30% outliers" in out and "smooth depths" in out


def test_short_baseline_kitti_runs(capsys):
    """benchmarks/short_baseline_kitti.py end to end on one KITTI pair at one scale."""
    pytest.importorskip("cv2")
    pytest.importorskip("poselib")
    kitti = SCRIPTS[0].parents[2] / "shared" / "data" / "realpairs" / "kitti_seq1"
    if not (kitti / "pairs.txt").is_file():
        pytest.skip("../shared/data/realpairs/kitti_seq1 is not here")
    sys.path.insert(0, str(SCRIPTS[0].parent))
    try:
        import short_baseline_kitti
    finally:
        sys.path.pop(0)
    assert short_baseline_kitti.main([str(kitti), "--pairs", "1", "--scales", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "s = 0.1:" in out and "PoseLib 1 px t err median" in out
