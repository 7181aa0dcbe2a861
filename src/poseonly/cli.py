"""Command-line interface (thin: parses, calls the library, prints).

poseonly demo [--draw out.png] [--json]
poseonly relpose IMG1 IMG2 (--K K.txt | --K1 A --K2 B | --focal F [--pp CX CY] | --camera-model M --camera-params P) [--json] [--draw out.png]
poseonly relpose --matches matches.npz [--K ...]
poseonly experiment NAME [--trials N] [--quick] [--out DIR] [...]
poseonly bench NAME [...]
poseonly colmap verify DATABASE [--pairs FILE] [--overwrite] [--jobs N [--threads] | --dask ADDRESS]
poseonly bench real DIR... [--seeds K] [--methods ...] [--out DIR] [--cache DIR] [--max-pairs N]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .argtypes import non_negative_int, positive_int, seed_int


class CLIError(Exception):
    pass


def _intrinsics(args, image_size=None):
    from .io.calibration import read_K

    given = [f for f, v in (("--K", args.K), ("--K1/--K2", args.K1 or args.K2), ("--focal", args.focal is not None)) if v]
    if len(given) > 1 or (args.pp is not None and args.focal is None):
        raise CLIError(f"give one calibration: --K, --K1/--K2 or --focal [--pp] (got {', '.join(given + (['--pp'] if args.pp is not None else []))})")
    if args.K:
        K = read_K(args.K, "--K")
        return K, K
    if args.K1 or args.K2:
        if not (args.K1 and args.K2):
            raise CLIError("give both --K1 and --K2 (or --K for a shared calibration)")
        return read_K(args.K1, "--K1"), read_K(args.K2, "--K2")
    if args.focal is not None:
        if args.pp:
            cx, cy = args.pp
        elif image_size is not None:
            cx, cy = (image_size[0] - 1) / 2.0, (image_size[1] - 1) / 2.0
        else:
            raise CLIError("--focal needs --pp CX CY when the image size is unknown")
        K = np.array([[args.focal, 0, cx], [0, args.focal, cy], [0, 0, 1.0]])
        return K, K
    return None, None


def _cameras(args):
    """``(camera1, camera2)`` of ``--camera-model / --camera-params`` (both images) and
    ``--camera2-model / --camera2-params`` (the second image's, when it differs), or None."""
    given = [args.camera_model, args.camera_params, args.camera2_model, args.camera2_params]
    if not any(v is not None for v in given):
        return None
    if (args.camera_model is None) != (args.camera_params is None) or (args.camera2_model is None) != (args.camera2_params is None):
        raise CLIError("--camera-model and --camera-params go together (and so do --camera2-model and --camera2-params)")
    if args.camera_model is None:
        raise CLIError("--camera2-model / --camera2-params give the second image's camera: give the first's with --camera-model / --camera-params")
    if args.K or args.K1 or args.K2 or args.focal is not None or args.pp is not None:
        raise CLIError("give the cameras with --K / --K1 / --K2 / --focal / --pp (pinhole) or --camera-model / --camera-params, not both")
    from .cameras import camera_from_text

    cam1 = camera_from_text(args.camera_model, args.camera_params, name="--camera-model / --camera-params")
    cam2 = cam1 if args.camera2_model is None else camera_from_text(args.camera2_model, args.camera2_params, name="--camera2-model / --camera2-params")
    return cam1, cam2


def _opencv_K(cam) -> np.ndarray:
    """A camera's pinhole ``K`` in OpenCV's pixel convention (the drawing's): COLMAP's principal point
    less :data:`poseonly.cameras.OPENCV_TO_COLMAP_PX`."""
    from .cameras import OPENCV_TO_COLMAP_PX

    K = cam.K.copy()
    K[:2, 2] -= OPENCV_TO_COLMAP_PX
    return K


def _check_draw_target(path: str | None) -> None:
    """Fail before any work when a drawing could not be written (directory, unknown format)."""
    if not path:
        return
    from .pipeline import DRAW_FORMATS

    p = Path(path)
    if p.is_dir():
        raise CLIError(f"--draw {path}: is a directory; give an image file name (e.g. matches.png)")
    if p.suffix.lower() not in DRAW_FORMATS:
        raise CLIError(f"--draw {path}: unsupported image format {p.suffix or '(none)'!r}; use one of {list(DRAW_FORMATS)}")


def _fmt_pose(R, t) -> str:
    if R is None or t is None:
        return "R = (none)\nt = (none)" if R is None else _fmt_pose(R, np.full(3, np.nan)).replace("nan", "n/a")
    rows = "\n".join("  [" + ", ".join(f"{v: .6f}" for v in r) + "]" for r in R)
    return f"R =\n{rows}\nt = [" + ", ".join(f"{v: .6f}" for v in t) + "]"


def _jsonable(v):
    """JSON-safe value (arrays -> lists, non-finite floats -> None)."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, list):
        return [_jsonable(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if np.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def cmd_demo(args: argparse.Namespace) -> int:
    from .pipeline import run_demo

    if not args.no_draw:
        _check_draw_target(args.draw)
    d = run_demo(draw=None if args.no_draw else args.draw, method=args.method, seed=args.seed)
    if args.json:
        print(json.dumps({k: _jsonable(v) for k, v in d.items()}, indent=2, allow_nan=False))
        return 0
    print(f"poseonly {__version__} demo: {d['pair']} (embedded, 960x640)")
    print(f"matches: {d['num_matches']}, inliers: {d['num_inliers']} ({100 * d['inlier_ratio']:.1f}%), status: {d['status']}")
    print("estimated pose (X2 = R X1 + t):")
    print(_fmt_pose(d["R"], d["t"]))
    print("ground truth:")
    print(_fmt_pose(d["R_gt"], d["t_gt"]))
    print(f"rotation error: {d['rotation_error_deg']:.4f} deg, translation direction error: {d['translation_error_deg']:.3f} deg")
    print(
        "deviation (1 sigma, first order, with the spread to other fits of the matches; not the calibration's errors): "
        f"rotation {d['rotation_std_deg']:.4f} deg, translation direction {d['translation_std_deg']:.3f} deg"
    )
    print(f"time: features+matching {d['time_features_s']:.2f} s, robust estimation {d['time_estimate_s'] * 1e3:.1f} ms")
    if "drawing" in d:
        print(f"match drawing: {d['drawing']} (green inliers, red outliers)")
    return 0


def cmd_relpose(args: argparse.Namespace) -> int:
    from .pipeline import draw_matches, relpose_images, relpose_matches

    _check_draw_target(args.draw)
    if args.save and (not args.save.endswith(".npz") or Path(args.save).is_dir()):
        raise CLIError(f"--save writes an .npz file; got {args.save!r}" + (" (a directory)" if Path(args.save).is_dir() else ""))
    if args.cache and Path(args.cache).exists() and not Path(args.cache).is_dir():
        raise CLIError(f"--cache {args.cache}: is a file; give a folder")
    if args.epipolar and not args.draw:
        raise CLIError("--epipolar draws into the match drawing: give --draw OUT.png as well")
    if args.draw and not (args.image1 and args.image2):
        raise CLIError("--draw needs the two images: poseonly relpose IMG1 IMG2 [--matches FILE] --draw OUT.png")
    opts = {"method": args.method, "seed": args.seed}
    if args.threshold is not None:
        opts["threshold_px"] = args.threshold
    cams = _cameras(args)
    if cams is not None:
        opts.update(camera1=cams[0], camera2=cams[1])
        if args.epipolar and not (cams[0].is_undistorted and cams[1].is_undistorted):
            raise CLIError("--epipolar draws straight epipolar lines, which a distorted camera does not have; draw without it")
    if args.matches:
        from .features import load_matches_npz

        md = load_matches_npz(args.matches)
        if cams is not None and md.K1 is not None:
            print(f"poseonly: note: {args.matches} holds K1/K2; the camera options replace them", file=sys.stderr)
        K1, K2 = (None, None) if cams is not None else _intrinsics(args)
        if K1 is None and cams is None:
            K1, K2 = md.K1, md.K2
        if K1 is None and cams is None:
            raise CLIError("no calibration: pass --K, --K1/--K2, --focal/--pp or --camera-model/--camera-params, or store K in the npz")
        pr = relpose_matches(md.u1, md.u2, K1, K2, scores=md.scores, noise_scales=md.noise_scales, **opts)
        imgs = (args.image1, args.image2) if args.image1 and args.image2 else None  # only for --draw
    else:
        if not (args.image1 and args.image2):
            raise CLIError("give two images (IMG1 IMG2) or --matches FILE")
        from .features import read_image

        im = read_image(args.image1)
        read_image(args.image2)
        K1, K2 = (None, None) if cams is not None else _intrinsics(args, (im.shape[1], im.shape[0]))
        if K1 is None and cams is None:
            raise CLIError("no calibration: pass --K K.txt, --K1/--K2, --focal F [--pp CX CY], or --camera-model M --camera-params P")
        pr = relpose_images(args.image1, args.image2, K1, K2, ratio=args.ratio, cache_dir=args.cache, **opts)
        imgs = (args.image1, args.image2)
    r = pr.result
    if args.draw and imgs:
        from .features import fundamental_from_pose

        # epipolar lines are straight for pinhole cameras only (--epipolar was refused for distorted ones)
        Ka, Kb = (_opencv_K(cams[0]), _opencv_K(cams[1])) if cams is not None else (K1, K2)
        straight = cams is None or (cams[0].is_undistorted and cams[1].is_undistorted)
        F = None
        if straight and Ka is not None and Kb is not None and r.R is not None and r.t is not None:
            F = fundamental_from_pose(Ka, Kb, r.R, r.t)
        draw_matches(imgs[0], imgs[1], pr.u1, pr.u2, r.inliers, args.draw, F=F, epipolar=args.epipolar if F is not None else 0, title=f"status: {r.status}")
    # --matches rows a camera model could not lift were left out: inliers are reported as the file's rows
    rows = pr.kept if args.matches else None
    if args.save:
        _save_result(args.save, r, rows, len(pr.u1) + pr.dropped)
    if args.json:
        d = r.to_dict()
        if rows is not None:  # the file's rows, so num_points counts them (RelativePoseResult.from_dict reads it)
            d["inliers"] = rows[np.asarray(r.inliers, bool)].tolist()
            d["num_points"] = int(len(pr.u1) + pr.dropped)
        d.update(num_matches=int(len(pr.u1)), num_dropped=pr.dropped, time_features_s=pr.time_features_s, time_estimate_s=pr.time_estimate_s)
        print(json.dumps(d, indent=2, allow_nan=False))
    else:
        print(_fmt_pose(r.R, r.t))
        print(f"inliers: {r.num_inliers} / {len(pr.u1)} matches ({100 * r.inlier_ratio:.1f}%)")
        if pr.dropped:
            print(f"left out: {pr.dropped} matches with a keypoint the camera model cannot undistort")
        if r.rotation_covariance is not None:
            std_t = r.diagnostics.get("translation_std_deg", float("nan"))
            what = (
                "the matches' noise and the rotation-only fit's distance from the pose's R"
                if r.status == "pure_rotation"
                else "the matches' noise and an equally good planar twin's distance"
                if "twin_spread_deg" in r.diagnostics
                else "the matches' noise alone"
            )
            print(f"deviation from {what} (1 sigma, first order): rotation {r.diagnostics['rotation_std_deg']:.3g} deg, translation direction {std_t:.3g} deg")
        print(f"status: {r.status}: {r.message}")
        print(f"time: features+matching {pr.time_features_s:.2f} s, estimation {pr.time_estimate_s * 1e3:.1f} ms")
    return exit_code(r.status)


# exit codes of `poseonly relpose` (documented in the README): a pose to trust, a result whose status
# says it is not one (planar_ambiguous, ambiguous, uncertain, pure_rotation, too_few_inliers), no pose (degenerate) or an error
EXIT_OK, EXIT_NOT_OK, EXIT_ERROR = 0, 1, 2


def exit_code(status: str) -> int:
    """0 for status ``ok``, 1 for a result that is not ``ok``, 2 for ``degenerate`` (as for errors)."""
    return EXIT_OK if status == "ok" else (EXIT_ERROR if status == "degenerate" else EXIT_NOT_OK)


def _save_result(path: str, r, rows: np.ndarray | None = None, n_rows: int = 0) -> None:
    """``r`` to an npz; with ``rows`` (the given matches' rows ``r`` was estimated on, of ``n_rows``) the
    ``inliers`` mask covers all the given rows (False for those left out)."""
    import io

    from ._fileutil import atomic_write_bytes

    if not path.endswith(".npz"):
        raise CLIError(f"--save writes an .npz file; got {path!r}")
    nan3 = np.full(3, np.nan)
    buf = io.BytesIO()
    np.savez(
        buf,
        R=r.R if r.R is not None else np.full((3, 3), np.nan),
        t=r.t if r.t is not None else nan3,
        E=r.E if r.E is not None else np.full((3, 3), np.nan),
        inliers=np.asarray(r.inliers, bool) if rows is None else np.isin(np.arange(n_rows), rows[np.asarray(r.inliers, bool)]),
        status=np.array(r.status),
        threshold_px=np.array(r.threshold_px),
    )
    atomic_write_bytes(path, buf.getvalue())


def cmd_experiment(args: argparse.Namespace) -> int:
    from . import experiments
    from ._fileutil import new_results_dir

    mod = experiments.load(args.name)
    if getattr(args, "out", "") is None:
        args.out = str(new_results_dir(args.name))
        print(f"writing results to {args.out}", file=sys.stderr)
    experiments.set_command_line(_command_line(args))
    try:
        return int(mod.run(args) or 0)
    finally:
        experiments.clear_command_line()


def _command_line(args: argparse.Namespace) -> str:
    """The command line that started this run (``main``'s ``argv``, or the process's)."""
    import shlex

    return "poseonly " + shlex.join(getattr(args, "argv", None) or sys.argv[1:])


def cmd_colmap_verify(args: argparse.Namespace) -> int:
    from .colmap_verify import run_cli

    return run_cli(args)


BENCHES = {"speed": "poseonly.bench_speed", "robust": "poseonly.bench_robust"}  # modules with main(argv)
# --- issue 12: `poseonly bench real DIR...` (real-data benchmark; logic in experiments/real_bench.py)
BENCHES["real"] = "poseonly.experiments.real_bench"
# --- end issue 12


def cmd_bench(args: argparse.Namespace) -> int:
    import importlib

    return int(importlib.import_module(BENCHES[args.name]).main(args.rest) or 0)


# the methods of estimate_relative_pose (poseonly.options.OPTIONS; listed here to keep the CLI's import light)
METHOD_CHOICES = ("poseonly", "gnc-ransac", "gnc-irls", "lirp")
METHOD_HELP = "poseonly: the default (5-point MSAC search, local optimisation, ML refinement); gnc-ransac, gnc-irls, lirp: the paper's Algorithms 3, 2 and 1 (default poseonly)"


# one line per experiment for ``poseonly experiment --help`` (the modules' docstrings say more)
# experiments on real images: no Monte Carlo trials
REAL_DATA_EXPERIMENTS = ("strecha",)
EXPERIMENT_HELP = {
    "table2": "the paper's Table 2: LiRP's rotation error and d_min, n = 30",
    "noise": "Section 7.1: rotation error against image noise, normal and planar scenes",
    "residuals": "Section 7.1.2: GNC-IRLS with each residual under 0-50 %% outliers",
    "gnc-ransac": "Section 7.1.3: GNC-RANSAC against the state of the art under 0-80 %% outliers",
    "chirality": "Appendix B: robust N-point and RANSAC + 5pt with and without the chirality filter",
    "strecha": "real Strecha pairs: every method's relative rotations against the ground truth (Table 3)",
}


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser. ``argv``: the arguments it will parse (``None``: every experiment's
    options are added); with them, only the experiment they name is imported for its options (every
    command imported every experiment module: ``colmap verify``'s start-up ran through table2.py)."""
    p = argparse.ArgumentParser(prog="poseonly", description="Robust two-view relative pose founded on pose-only imaging geometry")
    p.add_argument("--version", action="version", version=f"poseonly {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True)

    d = sub.add_parser("demo", help="run the whole pipeline on the embedded real image pair")
    d.add_argument("--draw", default="poseonly_demo_matches.png", help="where to write the match drawing")
    d.add_argument("--no-draw", action="store_true", help="do not write the match drawing")
    d.add_argument("--json", action="store_true", help="print the result as strict JSON")
    d.add_argument("--method", default="poseonly", choices=METHOD_CHOICES, help=METHOD_HELP)
    d.add_argument("--seed", type=seed_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
    d.set_defaults(func=cmd_demo)

    r = sub.add_parser("relpose", help="relative pose of two images (or of a matches file)")
    r.add_argument("image1", nargs="?", help="first image (SIFT features are matched unless --matches is given)")
    r.add_argument("image2", nargs="?", help="second image")
    r.add_argument("--matches", help="npz with u1, u2 (and optionally K or K1, K2)")
    r.add_argument("--K", help="text file with the shared 3x3 calibration matrix")
    r.add_argument("--K1", help="text file with the 3x3 calibration matrix of the first image")
    r.add_argument("--K2", help="text file with the 3x3 calibration matrix of the second image")
    r.add_argument("--focal", type=float, help="focal length in pixels (a pinhole K with --pp or the image centre)")
    r.add_argument("--pp", type=float, nargs=2, metavar=("CX", "CY"), help="principal point in pixels (with --focal; default: the image centre)")
    r.add_argument(
        "--camera-model",
        help="instead of a K: the camera model of the images, a COLMAP name (any perspective model, e.g. PINHOLE, OPENCV, OPENCV_FISHEYE, FOV, EUCM; poseonly.cameras.MODELS)",
    )
    r.add_argument(
        "--camera-params",
        help="the camera model's parameters in COLMAP's order and pixel convention (as in its cameras.txt), separated by commas or spaces "
        "(e.g. f,cx,cy,k for SIMPLE_RADIAL; write --camera-params=... when the first value is negative); with --matches, the matches' pixels "
        "must be in that convention too",
    )
    r.add_argument("--camera2-model", help="the second image's camera model, when it differs from the first's")
    r.add_argument("--camera2-params", help="the second image's camera parameters (with --camera2-model)")
    r.add_argument("--method", default="poseonly", choices=METHOD_CHOICES, help=METHOD_HELP)
    r.add_argument("--threshold", type=float, default=None, help="inlier threshold in pixels (default: the method's; 1 px for the default method)")
    r.add_argument("--ratio", type=float, default=0.8, help="Lowe ratio")
    r.add_argument("--cache", help="feature cache directory")
    r.add_argument("--seed", type=seed_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
    r.add_argument("--json", action="store_true", help="print the result as strict JSON (R, t, E, inlier indices, status, threshold, timings)")
    r.add_argument("--save", metavar="OUT.npz", help="write R, t, E, the inlier mask and the status to an .npz (atomically)")
    r.add_argument("--draw", metavar="OUT.png", help="write a drawing of the matches (inliers green, outliers red, a legend with the counts); needs IMG1 IMG2, also with --matches")
    r.add_argument("--epipolar", type=non_negative_int, default=0, metavar="N", help="with --draw: also draw the epipolar lines of N random inliers in both images (default 0)")
    r.set_defaults(func=cmd_relpose)

    c = sub.add_parser("colmap", help="COLMAP database tools")
    csub = c.add_subparsers(dest="colmap_cmd", required=True)
    cv = csub.add_parser("verify", help="two-view verification of a COLMAP database's matches with poseonly")
    from .colmap_verify import add_arguments as colmap_verify_arguments

    colmap_verify_arguments(cv)
    cv.set_defaults(func=cmd_colmap_verify)

    b = sub.add_parser("bench", help="benchmarks: speed, robust (synthetic) or real (real image pairs against the anchors)")
    b.add_argument(
        "name", metavar="NAME", choices=sorted(BENCHES), help="speed: timing against PoseLib and OpenCV; robust: synthetic accuracy; real: real image pairs against the anchors"
    )
    b.add_argument("rest", nargs=argparse.REMAINDER, metavar="OPTIONS", help="options of the benchmark (see poseonly bench NAME --help)")
    b.set_defaults(func=cmd_bench)

    e = sub.add_parser("experiment", help="reproduce one of the paper's experiments")
    esub = e.add_subparsers(dest="name", required=True)
    from . import experiments

    for name in experiments.EXPERIMENTS:
        ep = esub.add_parser(name, help=EXPERIMENT_HELP.get(name))
        if name not in REAL_DATA_EXPERIMENTS:  # (a researcher's trial: strecha took --trials and ignored it)
            ep.add_argument("--trials", type=positive_int, default=None, help="Monte Carlo trials (default: the paper's)")
        ep.add_argument("--quick", action="store_true", help="a few trials (smoke test)" if name not in REAL_DATA_EXPERIMENTS else "a few pairs (smoke test)")
        ep.add_argument("--out", default=None, help=f"output folder for tables and figures (default: a new folder poseonly-{name}-<date>-<time> under the working directory)")
        ep.add_argument("--seed", type=seed_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
        ep.set_defaults(func=cmd_experiment)
        if argv is not None and not ("experiment" in argv and name in argv):
            continue  # another command, or another experiment: its module's options are not needed
        try:
            experiments.load(name).add_arguments(ep)
        except ImportError:
            pass

    # --- sfm hook (issue 15): `poseonly sfm` and `poseonly experiment global`; logic in poseonly.sfm.cli ---
    from .sfm.cli import add_parsers as add_sfm_parsers

    add_sfm_parsers(sub, esub)
    # --- end sfm hook ---
    return p


class Terminated(KeyboardInterrupt):
    """SIGTERM during a command: unwinds as Ctrl-C does (writers remove their temporary files, worker
    pools shut down), then the command exits with 128 + SIGTERM."""


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated


class _ClosedPipeGuard:
    """``sys.stdout`` while a command runs: once the reader of a pipe has gone (``poseonly sfm ... | head
    -1``), the rest of the output is dropped instead of raising ``BrokenPipeError``, which aborted the run
    before it wrote its files (a user's trial: exit 2, nothing written). The stream's descriptor is then
    pointed at ``os.devnull`` so that the interpreter's last flush does not fail either."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self.broken = False

    def _closed(self) -> None:
        self.broken = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):  # no descriptor (a test's captured stream)
            pass

    def write(self, text: str) -> int:
        if not self.broken:
            try:
                n = self._stream.write(text)
                return len(text) if n is None else int(n)  # (a host stream's write may return None)
            except BrokenPipeError:
                self._closed()
        return len(text)

    def flush(self) -> None:
        if not self.broken:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._closed()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def main(argv: list[str] | None = None) -> int:
    """The command line (``poseonly ...``): the command's exit code; stdout guarded by
    :class:`_ClosedPipeGuard` from the help text on, and flushed through it at the end (a block-buffered
    pipe's last flush failed after the guard was gone: a review)."""
    stdout = sys.stdout
    guard = None if stdout is None else _ClosedPipeGuard(stdout)
    if guard is not None:
        sys.stdout = guard
    try:
        return _main(argv)
    finally:
        if guard is not None:
            guard.flush()
            sys.stdout = stdout


def _main(argv: list[str] | None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    try:
        args = build_parser(words).parse_args(words)
    except KeyboardInterrupt:  # Ctrl-C during start-up: no traceback (a user's trial)
        print("poseonly: interrupted", file=sys.stderr)
        return 130
    args.argv = list(argv) if argv is not None else sys.argv[1:]
    rc = 1
    # (only the main thread may set handlers; pycolmap's import keeps this one: poseonly._pycolmap)
    installed = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _on_sigterm) if installed else None
    try:
        rc = int(args.func(args) or 0)
        return rc
    except (CLIError, ValueError, ImportError, OSError) as exc:
        print(f"poseonly: error: {exc}", file=sys.stderr)
        rc = 2
        return rc
    except Terminated:
        print("poseonly: terminated", file=sys.stderr)
        rc = 128 + signal.SIGTERM
        return rc
    except KeyboardInterrupt:
        print("poseonly: interrupted", file=sys.stderr)
        rc = 130
        return rc
    finally:
        if installed:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
        if rc != 0:
            from ._fileutil import remove_empty_results_dirs

            remove_empty_results_dirs()  # a run that failed before writing leaves no empty results folder


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
