"""``poseonly colmap verify``: two-view verification of a COLMAP database's matches with poseonly.

For every matched image pair (or those of ``--pairs``) the keypoints are lifted to bearings through
the image's COLMAP camera (:mod:`poseonly.cameras`; once per image), the pair is estimated with
:func:`poseonly.estimate_relative_poses` (seed from the pair id, so reruns and schedules agree) and
a ``two_view_geometries`` row is written:

=====================  ======================  =====================================================
our status             COLMAP configuration    row content
=====================  ======================  =====================================================
``ok``                 ``CALIBRATED``          inliers, E, F (pinhole cameras only), cam2_from_cam1
``uncertain``          ``CALIBRATED``          the same (``DEGENERATE`` without inliers with
                                               ``--drop-uncertain`` / ``keep_uncertain=False``)
``planar_ambiguous``   ``PLANAR_OR_PANORAMIC`` same + H (DLT on the inlier keypoints)
``pure_rotation``      ``PANORAMIC``           inliers, H, cam2_from_cam1 with ``t = 0``
``ambiguous``          ``MULTIPLE``            no inliers (two poses explain the matches: which
                                               matches are right is not known)
``too_few_inliers``,   ``DEGENERATE``          no inliers (also: fewer than :data:`MIN_MATCHES`
``degenerate``                                 matches with valid keypoints)
invalid input          ``UNDEFINED``           no inliers
=====================  ======================  =====================================================

The default method runs at most :data:`poseonly.options.MANY_PAIRS_MAX_ITERATIONS` (10000) samples a
pair, COLMAP's two-view cap, as in ``poseonly sfm``'s pairwise stage (most pairs of an exhaustively
matched database do not overlap, and their searches run to the cap); ``max_iterations=...``
(``--max-iterations``) overrides it.

Rows are written in transactions of ``write_every`` pairs, so a killed run leaves every pair either
complete or absent. A rerun skips pairs that already have a geometry, of any configuration (it
resumes; COLMAP's own matcher writes ``UNDEFINED`` rows for the pairs it rejects); ``overwrite=True``
replaces the selected pairs' geometries (e.g. those of COLMAP's own verifier) batch by batch, so an
interrupted run leaves each pair with its old row or its new one, never none (it deleted them all first
until a reliability trial; a rerun with ``overwrite`` starts over). A camera poseonly
cannot lift to bearings is refused before anything is written (:class:`poseonly.geometry.InputError`),
a database another process has locked, or that cannot be written, too
(:class:`poseonly.io.colmap_db.DatabaseUnavailableError`, an ``OSError``; a lock taken mid-run ends the
run with it, the batches written before kept).

``poseonly colmap verify`` exits 0 when every selected pair was verified or kept, :data:`EXIT_SOME_INVALID`
(1) when the run finished but some pairs had invalid input and were written ``UNDEFINED`` (it exited 0
until a user's review: a script could not tell), and 2 on an error that stopped it.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import sys
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._fileutil import atomic_open
from .api import DEFAULT_METHOD, METHODS
from .argtypes import jobs_int, positive_float, positive_int, seed_int
from .batch import AUTO_THREADS_MAX_PAIRS, Backend, Pair, PairResult, estimate_relative_poses
from .geometry import InputError, pair_focal
from .io.colmap_db import ColmapDatabase, GeometryRow, refuse_guessed_focal
from .io.colmap_geometry import ERROR_CONFIG, STATUS_CONFIG, two_view_fields
from .options import MANY_PAIRS_MAX_ITERATIONS
from .quantization import check_coordinate_step, image_grid_step, pair_grid_step

__all__ = ["MIN_MATCHES", "STATUS_CONFIG", "VerifySummary", "add_arguments", "run_cli", "verify_database"]

MIN_MATCHES = 6  # fewer valid matches cannot determine a pose: DEGENERATE without estimating
WRITE_EVERY = 256  # pairs per write transaction
# the columns of the per-pair report (``report=`` / ``--report``): status is poseonly's, or "invalid input" /
# "too few matches" for the pairs decided without estimating; the deviations are 1 sigma, first order
REPORT_COLUMNS = ("pair_id", "image1", "image2", "matches", "config", "status", "inliers", "rotation_std_deg", "translation_std_deg", "threshold_px", "message")
EXIT_SOME_INVALID = 1  # `poseonly colmap verify`: the run finished, and some pairs had invalid input (UNDEFINED rows)


@dataclass
class VerifySummary:
    """Counts of a run: ``selected`` pairs, ``skipped`` (already verified), ``written`` rows,
    ``configs`` (rows per configuration), ``statuses`` (estimated pairs per poseonly status: ``ok`` and
    ``uncertain`` are both ``CALIBRATED``), ``errors`` (pair id -> message), ``unmatched`` (pairs of the
    pairs file without matches in the database: nothing to verify), ``time_s``."""

    selected: int = 0
    skipped: int = 0
    unmatched: int = 0
    written: int = 0
    configs: Counter = field(default_factory=Counter)
    statuses: Counter = field(default_factory=Counter)
    errors: dict[int, str] = field(default_factory=dict)
    time_s: float = 0.0


class _Source:
    """Builds the batch's pairs from the database (bearings cached per image) and keeps, for each
    pair in flight, what is needed to turn its result into a row."""

    def __init__(
        self,
        db: ColmapDatabase,
        todo: list[tuple[int, int, int]],
        errors: dict[int, str],
        statuses: Counter,
        noise_scales: bool = True,
        keep_uncertain: bool = True,
        coordinate_step: float | None = None,
    ) -> None:
        self.db, self.todo, self.errors, self.statuses = db, todo, errors, statuses
        self.noise_scales, self.keep_uncertain, self.coordinate_step = noise_scales, keep_uncertain, coordinate_step
        self.pending: dict[int, tuple[int, int, np.ndarray]] = {}
        self.direct: list[GeometryRow] = []  # rows decided without estimating
        self.records: list[list[Any]] = []  # the report's lines of the rows not yet written (REPORT_COLUMNS)
        self._bear: dict[int, np.ndarray] = {}
        self._step: dict[int, float] = {}  # each image's keypoint grid (poseonly.quantization)

    def bearings(self, image_id: int) -> np.ndarray:
        b = self._bear.get(image_id)
        if b is None:
            kp = self.db.keypoints(image_id)
            finite = np.isfinite(kp).all(axis=1)
            b = np.full((len(kp), 3), np.nan)
            # a keypoint stored as NaN / inf is an unusable keypoint of its pairs, not an error of the run
            # (one such keypoint stopped a whole verify; a reliability trial)
            b[finite] = self.db.cameras[image_id].unproject(kp[finite], invalid="nan")
            if len(self._bear) > 512:
                self._bear.pop(next(iter(self._bear)))
            self._bear[image_id] = b
            self._step[image_id] = image_grid_step(kp)  # (a float per image: kept for the whole run)
        return b

    def _names(self, i1: int, i2: int) -> str:
        """The pair's images by name (by id where the images table lacks one), for its error message."""
        a, b = (repr(self.db.image_names[i]) if i in self.db.image_names else f"id {i}" for i in (i1, i2))
        return f"images {a}, {b}"

    def _refuse(self, pid: int, i1: int, i2: int, msg: str) -> None:
        """The pair's input is invalid: an ``UNDEFINED`` row without estimating, and its message."""
        self.direct.append(GeometryRow.empty(i1, i2, ERROR_CONFIG))
        self.errors[pid] = msg
        self.records.append(self._record(pid, i1, i2, 0, ERROR_CONFIG, "invalid input", None, msg))

    def _record(self, pid: int, i1: int, i2: int, n: int, config: str, status: str, r: Any, message: str) -> list[Any]:
        """One line of the report (:data:`REPORT_COLUMNS`); ``r`` the pair's result or None."""
        names = [self.db.image_names.get(i, "") for i in (i1, i2)]
        if r is None:
            return [pid, *names, n, config, status, 0, "", "", "", message]
        return [
            pid,
            *names,
            n,
            config,
            r.status,
            r.num_inliers,
            f"{r.rotation_std_deg:.6g}",
            f"{r.diagnostics.get('translation_std_deg', float('nan')):.6g}",
            f"{r.threshold_px:.6g}",
            r.message,
        ]

    def __iter__(self) -> Iterator[Pair]:
        for pid, i1, i2 in self.todo:
            missing = [i for i in (i1, i2) if i not in self.db.cameras and i not in self.db.unsupported]
            if missing:  # matches of an image id the images table does not have
                self._refuse(pid, i1, i2, f"{self._names(i1, i2)}: image id {missing[0]} has matches but is not in the database's images table")
                continue
            if i1 in self.db.unsupported or i2 in self.db.unsupported:
                self._refuse(pid, i1, i2, self.db.unsupported.get(i1) or self.db.unsupported[i2])
                continue
            try:
                m = self.db.matches(i1, i2)
                b1, b2 = self.bearings(i1), self.bearings(i2)
            except (RuntimeError, ValueError) as exc:  # pycolmap on a malformed blob ("Check failed: matrix.size() ..."): this pair's
                what = f"images {self.db.image_names.get(i1, i1)!r}, {self.db.image_names.get(i2, i2)!r}"
                self._refuse(pid, i1, i2, f"pycolmap cannot read the keypoints or matches of {what}: {(str(exc).strip().splitlines() or [type(exc).__name__])[-1]}")
                continue
            if len(m) and (m[:, 0].max() >= len(b1) or m[:, 1].max() >= len(b2) or m.min() < 0):
                empty = [i for i, b in ((i1, b1), (i2, b2)) if len(b) == 0]
                self._refuse(
                    pid,
                    i1,
                    i2,
                    f"{self._names(i1, i2)}: image {self.db.image_names.get(empty[0], empty[0])!r} has matches but no keypoints in the database"
                    if empty  # a user's trial: "matches index keypoints that do not exist" for an image without keypoints
                    else f"{self._names(i1, i2)}: matches index keypoints that do not exist",
                )
                continue
            valid = np.isfinite(b1[m[:, 0], 0]) & np.isfinite(b2[m[:, 1], 0])
            m = m[valid]
            if len(m) < MIN_MATCHES:
                self.direct.append(GeometryRow.empty(i1, i2, "DEGENERATE"))
                self.records.append(self._record(pid, i1, i2, len(m), "DEGENERATE", "too few matches", None, f"{len(m)} valid matches, fewer than {MIN_MATCHES}"))
                continue
            self.pending[pid] = (i1, i2, m)
            c1, c2 = self.db.cameras[i1], self.db.cameras[i2]
            # the keypoints' rounding (e.g. SuperPoint's pixel centres), which the bearings no longer show
            step = pair_grid_step(self._step[i1], self._step[i2]) if self.coordinate_step is None else self.coordinate_step
            opts: dict[str, Any] = {"focal_px": pair_focal(c1.focal_px, c2.focal_px), "coordinate_step_px": step}
            s1, s2 = (self.db.keypoint_scales(i1), self.db.keypoint_scales(i2)) if self.noise_scales else (None, None)
            if s1 is not None and s2 is not None:
                opts["noise_scales"] = np.sqrt(s1[m[:, 0]] * s2[m[:, 1]])  # the keypoints' scales weight the ML refinement
            yield Pair(b1[m[:, 0]], b2[m[:, 1]], key=pid, options=opts)

    def row(self, pr: PairResult) -> GeometryRow:
        pid = pr.key
        assert isinstance(pid, int)  # the keys of _Source's pairs are pair ids
        i1, i2, m = self.pending.pop(pid)
        r = pr.result
        if r is None:
            self.errors[pid] = f"{self._names(i1, i2)}: {pr.error}"
            self.records.append(self._record(pid, i1, i2, len(m), ERROR_CONFIG, "invalid input", None, self.errors[pid]))
            return GeometryRow.empty(i1, i2, ERROR_CONFIG)
        c1, c2 = self.db.cameras[i1], self.db.cameras[i2]
        pinhole = c1.is_undistorted and c2.is_undistorted  # a distorted camera has no F
        with_h = (r.status != "uncertain" or self.keep_uncertain) and STATUS_CONFIG.get(r.status, ERROR_CONFIG) in ("PLANAR_OR_PANORAMIC", "PANORAMIC")  # keypoints read only for H
        kp1, kp2 = (self.db.keypoints(i1), self.db.keypoints(i2)) if with_h else (None, None)
        f = two_view_fields(r, m, c1.K if pinhole else None, c2.K if pinhole else None, keypoints1=kp1, keypoints2=kp2, keep_uncertain=self.keep_uncertain)
        self.statuses[r.status] += 1
        self.records.append(self._record(pid, i1, i2, len(m), f.config, r.status, r, r.message))
        return GeometryRow(i1, i2, f)


def verify_database(
    path: str | Path,
    *,
    pairs_file: str | Path | None = None,
    overwrite: bool = False,
    n_jobs: int = 1,
    backend: Backend = "auto",
    client: Any = None,
    chunk_size: int | None = None,
    write_every: int = WRITE_EVERY,
    progress: bool | None = None,
    noise_scales: bool = True,
    camera: Any = None,
    trust_guessed_focal: bool = False,
    keep_uncertain: bool = True,
    coordinate_step: float | None = None,
    report: str | Path | None = None,
    **options: Any,
) -> VerifySummary:
    """Verify the matched pairs of the COLMAP database ``path`` and write their two-view geometries
    (module docstring). ``options``: those of :func:`poseonly.estimate_relative_pose`
    (``threshold_px``, ``method``, ``seed`` ...; the default method's ``max_iterations`` defaults to
    :data:`poseonly.options.MANY_PAIRS_MAX_ITERATIONS`); ``noise_scales``: pass each match's
    ``sqrt(s1 s2)`` of its keypoints' scales (when the database stores keypoint shapes); ``camera``:
    one camera for every image instead of the database's (anything :func:`poseonly.cameras.as_camera`
    accepts, in COLMAP's pixel convention as the database's keypoints; e.g. a calibration where the
    database holds COLMAP's guess); ``trust_guessed_focal``: estimate pairs whose camera's focal
    length COLMAP guessed (no prior focal length) with that guess; without it (and without ``camera``)
    such a database is refused before any pair is estimated (:class:`InputError` naming the cameras),
    since a calibrated pose from a guessed focal length can be degrees off and be written
    ``CALIBRATED``; ``keep_uncertain``: write pairs of status ``uncertain`` (the inliers single out the
    epipolar geometry, the pose is poorly determined) ``CALIBRATED`` with their inliers (default: COLMAP's
    bundle adjustment re-estimates every pose) or, with ``False``, ``DEGENERATE`` without inliers, as
    ``too_few_inliers``; ``coordinate_step``: the grid (pixels) every keypoint was rounded to, whose
    rounding noise is the estimates' noise floor (None: detected per image from its keypoints,
    :func:`poseonly.quantization.image_grid_step`; 0: none); ``report``: a CSV file of one line per pair
    written in this run (:data:`REPORT_COLUMNS`: poseonly's status, inliers, the pose's deviations, the
    message), published when the run ends (atomically: an interrupted run leaves none; a user's trial:
    ``CALIBRATED`` holds ``ok`` and ``uncertain`` poses, and the rows alone could not be audited); ``n_jobs``,
    ``backend`` (``"auto"``: threads for fewer than :data:`poseonly.batch.AUTO_THREADS_MAX_PAIRS` pairs to
    verify, else processes; ``"processes"`` or ``"threads"``) and ``client`` as :func:`poseonly.estimate_relative_poses`
    takes them (the database is read and written in this thread only). Close your own ``pycolmap.Database``
    handles on ``path`` first and reopen them after: one held across the run fails with "disk I/O error"
    on every later call (a user's trial; the file stays intact). Returns a :class:`VerifySummary`."""
    t0 = time.perf_counter()
    coordinate_step = check_coordinate_step(coordinate_step)
    if not isinstance(keep_uncertain, (bool, np.bool_)):
        raise InputError(f"keep_uncertain must be True or False, got {keep_uncertain!r}")
    if isinstance(write_every, (bool, np.bool_)) or not isinstance(write_every, (int, np.integer)) or write_every < 1:
        raise InputError(f"write_every must be a positive int, got {write_every!r}")
    if options.get("method", DEFAULT_METHOD) == "poseonly" and options.get("max_iterations") is None:
        options["max_iterations"] = MANY_PAIRS_MAX_ITERATIONS
    summary = VerifySummary()
    cam = None
    if camera is not None:
        from .cameras import as_camera
        from .options import check_camera_threshold

        cam = as_camera(camera)
        check_camera_threshold(cam, options.get("method", DEFAULT_METHOD), options.get("threshold_px"))
    with ColmapDatabase(path, writable=True) as db:
        if cam is not None:  # every image's camera replaced (checked before any pair is estimated)
            db.cameras = dict.fromkeys(db.image_names, cam)
            db.unsupported.clear()
        pairs = db.matched_pairs()
        if pairs_file is not None:
            pf = Path(pairs_file)
            if not pf.is_file():
                raise InputError(f"pairs file not found: {pairs_file}")
            try:
                lines = pf.read_text(encoding="utf-8").splitlines()
            except UnicodeDecodeError as exc:
                raise InputError(f"pairs file {pf} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
            wanted = db.pair_ids_from_names(lines, str(pf))
            summary.unmatched = len(wanted - {p[0] for p in pairs})
            pairs = [p for p in pairs if p[0] in wanted]
        summary.selected = len(pairs)
        # every existing row is kept without overwrite, UNDEFINED ones included: COLMAP's own matcher writes
        # UNDEFINED for the pairs it rejects, and a rerun must not mix the two verifiers' results (a review)
        todo = pairs if overwrite else [p for p in pairs if not db.has_geometry(p[1], p[2])]
        bad = sorted({msg for _, i1, i2 in todo for i in (i1, i2) if (msg := db.unsupported.get(i)) is not None})
        if bad:  # before any row is deleted or written: each of these pairs would be written UNDEFINED
            raise InputError(
                f"{path}: the cameras of {sum(1 for _, i1, i2 in todo if i1 in db.unsupported or i2 in db.unsupported)} selected pairs"
                f" cannot be lifted to bearings ({'; '.join(bad[:3])}{'; ...' if len(bad) > 3 else ''}): give a supported camera"
                " (--camera-model / --camera-params; camera= in Python), or leave those pairs out (--pairs)"
            )
        if cam is None and not trust_guessed_focal:  # before any row is deleted or written
            refuse_guessed_focal(
                path,
                (db.guessed[i] for _, i1, i2 in todo for i in (i1, i2) if i in db.guessed),
                "Give the calibration (--camera-model / --camera-params; camera= in Python), or use the guess (--trust-guessed-focal; trust_guessed_focal=True).",
            )
        summary.skipped = len(pairs) - len(todo)
        if backend == "auto":  # the pairs stream from the database (no len): decided on the pairs to verify
            backend = "threads" if len(todo) < AUTO_THREADS_MAX_PAIRS else "processes"
        src = _Source(db, todo, summary.errors, summary.statuses, noise_scales, bool(keep_uncertain), coordinate_step)
        buf: list[GeometryRow] = []
        with contextlib.ExitStack() as stack:
            writer = None
            if report is not None:
                writer = csv.writer(stack.enter_context(atomic_open(report, newline="")))
                writer.writerow(REPORT_COLUMNS)

            def flush() -> None:
                rows = buf + src.direct
                if rows:
                    summary.written += db.write_geometries(rows)
                    summary.configs.update(r.geometry.config for r in rows)
                if writer is not None:  # after the rows: a line for every row written
                    writer.writerows(src.records)
                buf.clear()
                src.direct.clear()
                src.records.clear()

            for pr in estimate_relative_poses(src, n_jobs=n_jobs, backend=backend, client=client, chunk_size=chunk_size, progress=progress, **options):
                buf.append(src.row(pr))
                if len(buf) + len(src.direct) >= write_every:
                    flush()
            flush()
    summary.time_s = time.perf_counter() - t0
    return summary


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``poseonly colmap verify``."""
    p.add_argument("database", help="COLMAP database file (database.db) with cameras, keypoints and matches")
    p.add_argument("--pairs", help="only these pairs: a text file of 'IMAGE_NAME1 IMAGE_NAME2' lines")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the selected pairs' existing two-view geometries (default: keep them and verify only the others, which also resumes an interrupted run)",
    )
    p.add_argument(
        "--threshold-px",
        "--threshold",
        dest="threshold",
        metavar="PX",
        type=positive_float,
        default=None,
        help="inlier threshold in pixels (default: the method's, 1 px for the default method)",
    )
    p.add_argument("--method", default=DEFAULT_METHOD, choices=METHODS, help=f"estimation method (default {DEFAULT_METHOD})")
    p.add_argument("--seed", type=seed_int, default=0, help="base seed; each pair's seed derives from it and the pair id")
    p.add_argument(
        "--max-iterations",
        type=positive_int,
        default=None,
        help=f"the search's sample cap per pair (default for the default method: {MANY_PAIRS_MAX_ITERATIONS}, COLMAP's two-view cap; the method's own otherwise)",
    )
    p.add_argument("--jobs", type=jobs_int, default=1, help="local workers (-1: all cores; default 1): processes, or threads with --threads")
    p.add_argument(
        "--threads",
        action="store_true",
        help=f"the local workers are threads (the core releases the GIL), not processes (default: threads below {AUTO_THREADS_MAX_PAIRS} pairs to verify, processes above)",
    )
    p.add_argument("--dask", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS instead of local processes")
    p.add_argument("--chunk", type=positive_int, default=None, help="pairs per task (default 16 local, 256 on Dask)")
    p.add_argument("--write-every", type=positive_int, default=WRITE_EVERY, help=f"pairs per database transaction (default {WRITE_EVERY})")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (there is one only where stderr is a terminal)")
    p.add_argument(
        "--report",
        metavar="FILE.csv",
        help="write one CSV line per pair verified in this run: poseonly's status (ok and uncertain are both CALIBRATED), inliers,"
        " the pose's deviations, the message (written when the run ends)",
    )
    p.add_argument("--no-noise-scales", action="store_true", help="do not pass the keypoints' scales to the estimator as noise scales")
    p.add_argument("--camera-model", help="one camera for every image instead of the database's: a COLMAP model name (with --camera-params)")
    p.add_argument("--camera-params", help="its parameters in COLMAP's order and pixel convention, separated by commas or spaces")
    p.add_argument(
        "--trust-guessed-focal",
        action="store_true",
        help="estimate with the focal length COLMAP guessed for cameras imported without calibration or EXIF focal length (refused"
        " otherwise: the poses can be degrees off and would be written CALIBRATED)",
    )
    p.add_argument(
        "--coordinate-step",
        type=float,
        metavar="PX",
        help="the grid (px) the keypoints were rounded to, whose rounding noise is the noise floor (default: detected per image, e.g. 1 for SuperPoint's pixel centres; 0: none)",
    )
    p.add_argument(
        "--drop-uncertain",
        action="store_true",
        help="write pairs whose status is 'uncertain' (poorly determined pose) DEGENERATE without inliers instead of CALIBRATED",
    )


def _verify_from_args(args: argparse.Namespace, camera: Any) -> VerifySummary:
    return verify_database(
        args.database,
        pairs_file=args.pairs,
        overwrite=args.overwrite,
        n_jobs=args.jobs,
        backend="threads" if args.threads else "auto",
        client=args.dask,
        chunk_size=args.chunk,
        write_every=args.write_every,
        progress=False if args.no_progress else None,  # a bar where stderr is a terminal
        noise_scales=not args.no_noise_scales,
        camera=camera,
        trust_guessed_focal=args.trust_guessed_focal,
        keep_uncertain=not args.drop_uncertain,
        coordinate_step=args.coordinate_step,
        report=args.report,
        method=args.method,
        seed=args.seed,
        **({} if args.threshold is None else {"threshold_px": args.threshold}),
        **({} if args.max_iterations is None else {"max_iterations": args.max_iterations}),
    )


def run_cli(args: argparse.Namespace) -> int:
    """Run ``poseonly colmap verify`` from parsed arguments; prints a summary, returns the exit code."""
    camera = None
    if args.camera_model is not None or args.camera_params is not None:
        if args.camera_model is None or args.camera_params is None:
            raise InputError("--camera-model and --camera-params go together")
        from .cameras import camera_from_text

        camera = camera_from_text(args.camera_model, args.camera_params, name="--camera-model / --camera-params")
    try:
        s = _verify_from_args(args, camera)
    except KeyboardInterrupt:  # (a user's trial: "interrupted" alone did not say what the database holds)
        print(
            "poseonly colmap verify: interrupted; the batches written before are in the database, and a rerun verifies the rest"
            " (after an interrupted --overwrite run, rerun with --overwrite)",
            file=sys.stderr,
        )
        raise
    print(f"{s.selected} pairs selected, {s.skipped} already verified (kept), {s.written} written in {s.time_s:.1f} s")
    if not s.selected and args.pairs is None:
        print("  the database has no matched pairs: match its images first (COLMAP's matchers, e.g. pycolmap.match_exhaustive)")
    if s.unmatched:
        print(f"  {s.unmatched} pairs of {args.pairs} have no matches in the database: nothing to verify there")
    if s.skipped and not s.written:
        print("  every selected pair already had a two-view geometry: pass --overwrite to replace them with poseonly's")
    for cfg, k in sorted(s.configs.items()):
        print(f"  {cfg}: {k}")
    if s.statuses:
        print("  poseonly statuses: " + ", ".join(f"{st} {k}" for st, k in sorted(s.statuses.items())))
    if args.report is not None and s.written:
        print(f"  per-pair report: {args.report}")
    if s.errors:
        print(f"  {len(s.errors)} pairs with invalid input (UNDEFINED), e.g. {next(iter(s.errors.values()))} (pair id {next(iter(s.errors))})")
        print("  exit status 1: those pairs' rows say UNDEFINED; a rerun keeps them, so after fixing the input rerun with --overwrite")
    if camera is not None and s.written:  # a user's trial: COLMAP's mapper then started from the guessed focal
        print(
            "  note: --camera-model / --camera-params calibrated the estimation only; the database's cameras table is unchanged,"
            " and COLMAP's mappers read their calibration from it (update it too, e.g. pycolmap.Database.update_camera)"
        )
    return EXIT_SOME_INVALID if s.errors else 0
