"""Options of :func:`poseonly.estimate_relative_pose`: one frozen dataclass per method, checked.

:func:`parse_options` turns the keyword options of a call into the method's dataclass. Every value
is checked by the field's :class:`Spec` (its kind, bounds and choices); unknown names, wrong types and
out-of-range values raise :class:`poseonly.InputError` naming the option, what it must be and what
was given. Accepted types: Python and numpy scalars alike (``np.float32(2.0)``, ``np.int64(7)``,
``np.True_``); ``bool`` is never taken for a number. ``None`` for an option means its default. Real
values must be finite (``threshold_px=inf`` is rejected) unless the spec allows ``inf`` (``max_rotation_std_deg``). The same specs check the keyword arguments of
the low-level functions (:func:`check_value`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .geometry import InputError

__all__ = [
    "OPTIONS",
    "CommonOptions",
    "GncIrlsOptions",
    "GncRansacOptions",
    "LirpOptions",
    "MANY_PAIRS_MAX_ITERATIONS",
    "PoseonlyOptions",
    "Spec",
    "check_angle",
    "check_camera_threshold",
    "check_value",
    "parse_options",
]

# the range an angular threshold (radians) must lie in: below 1e-12 rad no double-precision residual
# of unit bearings is meaningful, above 1 rad (57 deg) nearly every match is an inlier of any pose
MIN_ANGLE = 1e-12
MAX_ANGLE = 1.0
# the default method's sample cap (``max_iterations``) where many pairs of one image set are estimated:
# the pairwise stage of ``poseonly sfm`` and ``poseonly colmap verify``. COLMAP's two-view verification
# caps at 10000, where the two-view API keeps PoseLib's 100000. In an image set most pairs do not
# overlap and their searches run to the cap (with match scores no stopping rule ends a search without
# a model); a pair whose model is not found in 10000 draws has under ~13 % inliers, and the view
# graph's other pairs carry its views. Measured in docs/SFM.md, "The sample cap"
# (`python benchmarks/sample_cap.py $S/Herz-Jesus-P8 $S/entry-P10 $S/fountain-P11 [--no-scores]`)
MANY_PAIRS_MAX_ITERATIONS = 10000


@dataclass(frozen=True)
class Spec:
    """How one option is checked.

    ``kind``: ``"real"`` (finite int/float, numpy scalars too), ``"int"`` (integral, not bool),
    ``"bool"``, ``"str"`` (one of ``choices``), ``"name"`` (a registered solver or residual name,
    ``doc`` says which registry), ``"seed"`` (int >= 0 or ``numpy.random.Generator``)
    or ``"scale"`` (one of ``choices`` or a positive finite real). ``lo``/``hi`` bound a number
    (``lo_open``/``hi_open``: strict).
    """

    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""
    inf: bool = False  # "real": +inf is allowed too (a bound that never binds)

    def describe(self) -> str:
        """What a valid value is, e.g. ``"a finite real > 0"``."""
        if self.kind == "bool":
            return "True or False"
        if self.kind == "seed":
            return "an integer in [0, 2**64) or a numpy.random.Generator"
        if self.kind == "name":
            return f"a {self.doc} name"
        if self.kind == "str":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        base = {"real": "a finite real number", "int": "an integer", "scale": "a positive finite real number"}[self.kind]
        if self.kind == "real" and self.inf:
            base = "a real number (inf allowed)"
        if self.kind == "scale":
            return base + " or one of " + ", ".join(repr(c) for c in self.choices)
        bounds = []
        if self.lo is not None:
            bounds.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            bounds.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        elif self.kind == "int":
            bounds.append(f"<= {CORE_INT_MAX}")
        return base + (" " + " and ".join(bounds) if bounds else "")


def _type_name(v: Any) -> str:
    t = type(v)
    return t.__name__ if t.__module__ == "builtins" else f"{t.__module__}.{t.__name__}"


def _is_bool(v: Any) -> bool:
    return isinstance(v, (bool, np.bool_))


# the core's counts (samples, iterations, points) are C ints: a larger option raised TypeError /
# std::bad_cast from the bindings (an adversarial trial)
CORE_INT_MAX = 2**31 - 1


def _in_bounds(x: float, s: Spec) -> bool:
    if s.kind == "int" and abs(x) > CORE_INT_MAX:
        return False
    if s.lo is not None and (x <= s.lo if s.lo_open else x < s.lo):
        return False
    return not (s.hi is not None and (x >= s.hi if s.hi_open else x > s.hi))


def check_value(name: str, v: Any, s: Spec) -> Any:
    """Checked and converted value of option ``name`` (plain Python types out); raises
    :class:`InputError` saying what the option must be and what was given."""

    def bad_type() -> InputError:
        return InputError(f"option {name!r} must be of type {_TYPE_WORD[s.kind]} ({s.describe()}), got {_type_name(v)} {v!r}")

    def bad_value() -> InputError:
        return InputError(f"option {name!r} has an invalid value {v!r}: it must be {s.describe()}")

    if isinstance(v, np.ndarray) and v.ndim == 0 and v.dtype.kind in "biuf":  # np.array(2.0) as np.float64(2.0) (a trial)
        v = v[()]

    if s.kind == "bool":
        if not _is_bool(v):
            raise bad_type()
        return bool(v)
    if s.kind == "seed":
        if isinstance(v, np.random.Generator):
            return v
        given = v
        if isinstance(v, (float, np.floating)) and math.isfinite(v) and v == round(v):  # 7.0 (a JSON config), as the batch takes it
            v = int(v)
        if _is_bool(v) or not isinstance(v, numbers.Integral):
            raise bad_type()
        if not 0 <= int(v) < SEED_LIMIT:  # the core's seeds are 64-bit: a larger one would alias a smaller
            raise InputError(f"option {name!r} has an invalid value {given!r}: it must be {s.describe()}")
        return int(v)
    if s.kind == "name":
        if not isinstance(v, str):
            raise bad_type()
        return _check_name(name, v, s.doc)
    if s.kind in ("str", "scale") and isinstance(v, str):
        if v not in s.choices:
            raise bad_value()
        return v
    if s.kind == "str":
        raise bad_type()
    if _is_bool(v) or not isinstance(v, numbers.Real):
        raise bad_type()
    if s.kind == "int":
        if not isinstance(v, numbers.Integral):
            raise bad_type()
        x: float = int(v)
    else:
        x = float(v)
        if not (math.isfinite(x) or (s.inf and x == math.inf)) or (s.kind == "scale" and not x > 0):
            raise bad_value()
    if not _in_bounds(x, s):
        raise bad_value()
    return x


SEED_LIMIT = 2**64
_TYPE_WORD = {"bool": "bool", "seed": "int", "name": "str", "str": "str", "int": "int", "real": "int/float", "scale": "str/float"}


def _check_name(name: str, v: str, registry: str) -> str:
    """A solver or residual name known to its registry (solvers may be registered by users)."""
    from .estimator import get_estimator
    from .residuals import get_residual

    try:
        get_estimator(v) if registry == "solver" else get_residual(v)
    except ValueError as exc:
        raise InputError(f"option {name!r}: {exc}") from None
    return v


def _opt(default: Any, kind: str, doc: str = "", **kw: Any) -> Any:
    return field(default=default, metadata={"spec": Spec(kind, doc=doc, **kw)})


SCHEDULES = ("ms-tls", "gnc-tls")
# status "uncertain" above this rotation standard deviation (first order, degrees, the least constrained
# axis): were the deviation exact and one axis dominant, an ok rotation would be within 5 deg (the line
# beyond which docs/RESULTS_real.md counts a pose as wrong) at three of them. Chosen between 1 and 5/3 on
# the shared temple pairs, i.e. in sample: at 1 deg two right temple poses (0.7 and 2.4 deg off, PoseLib
# 1.3-1.4) also lost ok. First order is optimistic: on temple the error is 1.22x the deviation at the
# median, with noise above the threshold several times it (docs/RESULTS_real.md, "Pose uncertainty");
# every ok pose of the Strecha and KITTI pairs is at most 0.21 deg, the temple ok poses 5-20 deg off were
# at 1.55-2.04 deg (the one at 1.55, 5.1 deg off, stays ok)
MAX_ROTATION_STD_DEG = 5.0 / 3.0


@dataclass(frozen=True)
class CommonOptions:
    """Options every method takes (see :func:`poseonly.estimate_relative_pose`)."""

    threshold_px: float = _opt(2.0, "real", "inlier threshold in pixels", lo=0.0, lo_open=True)
    focal_px: float | None = _opt(None, "real", "focal for the pixel <-> angle conversion", lo=0.0, lo_open=True)
    seed: int | np.random.Generator = _opt(0, "seed", "random seed")  # noqa: RUF009
    refine: bool = _opt(True, "bool", "LiGTopt on the inliers")
    min_inliers: int = _opt(15, "int", "inliers needed for status ok", lo=6)
    max_rotation_std_deg: float = _opt(
        MAX_ROTATION_STD_DEG,
        "real",
        "the largest first-order standard deviation of the rotation (degrees, its least constrained axis) of an ok pose; above it, "
        "or where it cannot be estimated, the status is uncertain (inf: never)",
        lo=0.0,
        lo_open=True,
        inf=True,
    )
    max_translation_std_deg: float = _opt(
        float("inf"),
        "real",
        "the largest standard deviation of the translation direction (degrees, diagnostics translation_std_deg) of an ok pose; above"
        " it, or where it cannot be estimated, the status is uncertain (inf, the default: the status reads the rotation alone; a"
        " pipeline that needs the direction, e.g. translation averaging, can set a bound)",
        lo=0.0,
        lo_open=True,
        inf=True,
    )

    def check(self) -> None:
        """Check every field against its :class:`Spec` (raises :class:`InputError`)."""
        for f in fields(self):
            v = getattr(self, f.name)
            if v is not None:
                check_value(f.name, v, f.metadata["spec"])

    def as_kwargs(self) -> dict[str, Any]:
        """The fields set to other than their defaults, as keyword options:
        ``estimate_relative_pose(x1, x2, K, **PoseonlyOptions(threshold_px=2.0).as_kwargs())``. The typed
        way to build options (a type checker checks the field names and value types; the call checks
        the values, as for any keyword option). The class fixes the method: the paper's methods take
        ``method=`` with their own class (:data:`OPTIONS`)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is not f.default and not (type(v) is type(f.default) and v == f.default):
                out[f.name] = v
        return out


@dataclass(frozen=True)
class PoseonlyOptions(CommonOptions):
    """The default method's options (:mod:`poseonly.robust.default`). Defaults decided on real image
    pairs (docs/RESULTS_real.md): a 1 px threshold, at least 500 samples at confidence 0.9999 where the
    best model has little parallax (a search that does not stop on the first plausible consensus of a
    weakly constrained pose) and 100 where it has 3 degrees or more, Sampson-LM local optimisation, four
    challengers (the best models of other basins optimised at the end of the search), the ML final
    refinement on inliers cross-fitted over five folds; a search that has not converged after 3000
    samples continues in the neighbour-consistency order (``consistency="fallback"``), and one that PROSAC's
    rule ended early is followed by a search of the matches outside its model's band (``prosac_remainder``)."""

    threshold_px: float = _opt(1.0, "real", "inlier threshold in pixels", lo=0.0, lo_open=True)
    max_iterations: int = _opt(100000, "int", lo=1)
    min_iterations: int = _opt(500, "int", "the sample floor while the best model's inliers have little parallax (see floor_parallax_deg)", lo=0)
    floor_parallax_deg: float = _opt(
        3.0,
        "real",
        "a best model whose inliers' median parallax (angle between R f1 and f2) is at least this many degrees lowers the sample floor"
        " to min(min_iterations, min_iterations_parallax): the longer search pays only for weakly constrained poses (measured:"
        " docs/history/RESULTS_real_sessions.md, fourteenth session); 0: the floor is always min_iterations",
        lo=0.0,
        hi=180.0,
    )
    min_iterations_parallax: int = _opt(100, "int", "the sample floor for a best model with parallax (see floor_parallax_deg)", lo=0)
    confidence: float = _opt(0.9999, "real", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    min_hits: int = _opt(1, "int", "adaptive stopping waits for this many all-inlier samples at `confidence`", lo=1, hi=64)
    stop_at_min_inliers: bool = _opt(
        True,
        "bool",
        "the stopping rule assumes at least min_inliers inliers: a pose with less support is too_few_inliers whatever the search"
        " finds, so the search ends once a model with min_inliers inliers would have been drawn at `confidence` (without"
        " replacement; with scores only PROSAC's uniform draws, after its pool holds every match, count). It shortens searches"
        " on small match sets without such a model (pairs that do not overlap) when no scores are given; with such a model the"
        " rule is the classical one as soon as one is found",
    )
    consistency: str = _opt(
        "fallback",
        "str",
        "the sampling order by neighbour consistency (poseonly.robust.consistency: how many of a match's consistency_k nearest"
        " matches in view 1 are among its nearest in view 2; the caller's scores break ties): 'always' (the search samples in"
        " that order), 'fallback' (a search that has not converged after consistency_after samples in the order of `scores`"
        " continues in the consistency order and keeps the better of the two models), 'off'; used with at least"
        " consistency_min_matches * consistency_k matches (docs/RESULTS_real.md, 'Hard pairs')",
        choices=("off", "fallback", "always"),
    )
    consistency_k: int = _opt(10, "int", "neighbours per view of the consistency order", lo=1, hi=64)
    consistency_after: int = _opt(3000, "int", "consistency='fallback': the samples of the first search (the fallback is off where min_iterations exceeds it)", lo=1)
    consistency_min_draws: int = _opt(
        3000,
        "int",
        "in the consistency order PROSAC's stopping rule may end the search only after this many samples (the classical rule"
        " is not affected): the order puts consistent regions first, and the rule trusts the order",
        lo=0,
    )
    consistency_rule: str = _opt(
        "prosac",
        "str",
        "the stopping rule of the search in the consistency order (consistency='always', and the second stage of 'fallback'),"
        " as progressive_rule. 'expected' ends 8 of the 16 hard pairs at 0.1x PoseLib's time, but a compact moving object"
        " tops the consistency order, and on sparse second-motion scenes it doubles the confident wrong poses"
        " (docs/RESULTS_real.md, 'Hard pairs'), so the default stays 'prosac'",
        choices=("prosac", "expected"),
    )
    consistency_remainder: bool = _opt(
        False,
        "bool",
        "a search in the consistency order that its progressive rule ends (before its budget and before the classical rule on its"
        " inlier share would have; with chiral_scoring) is followed by one more in the consistency order of the"
        " matches outside its model's band, for as many samples (at least consistency_min_draws); the remainder's model replaces"
        " the result if it costs less on all the matches, and is the uniqueness test's rival if it is close: a compact second"
        " motion tops the consistency order, and the rule that trusts the order would otherwise end on it. With"
        " consistency_rule='expected' it halves that rule's confident wrong poses on sparse second-motion scenes (9 -> 5 of 20,"
        " the default's 4), not enough to make the pair the default (docs/RESULTS_real.md, 'Hard pairs')",
    )
    prosac_remainder: bool = _opt(
        True,
        "bool",
        "with `scores`: a search that PROSAC's rule ends (before the classical rule on its inlier share would have) is followed"
        " by one more in the score order of the matches outside its model's band, for as many samples; its model replaces the"
        " result if it costs less on all the matches, and is the uniqueness test's rival if it is close: scores that rank a"
        " repeated structure first ended PROSAC on its geometry (the wrong pose `ok` in 12 of 24 runs of"
        " tests/test_hard_cases.py's misleading scores, 0 with it), while the real benchmark's results (SIFT full size and 1024 px,"
        " ORB) and the hard pairs' are the same with it (docs/RESULTS_real.md, 'PROSAC's remainder')",
    )
    consistency_min_matches: int = _opt(
        20,
        "int",
        "the consistency order needs at least this many matches per neighbour (n >= consistency_min_matches * consistency_k):"
        " a neighbourhood must be a small part of the matches to be local",
        lo=1,
    )
    progressive_stop: bool = _opt(
        True,
        "bool",
        "with `scores`: the search also ends by PROSAC's stopping rule (a non-random top-n set of the score order whose draws reach"
        " the count at its inlier ratio, bounded for sampling without replacement; Chum and Matas 2005), not only by the count at"
        " the inlier ratio of all matches: 0.7-0.94x the time on real pairs, the same accuracy (docs/history/RESULTS_real_sessions.md,"
        " thirteenth session); False: the classical rule alone",
    )
    progressive_rule: str = _opt(
        "prosac",
        "str",
        "with `scores` and progressive_stop: 'prosac' (Chum and Matas' rule over the top-n sets) or 'expected' (stop where the"
        " expected number of all-inlier draws of the best model's inliers, summed over the sampler's actual schedule, reaches"
        " the classical rule's -ln(1 - confidence); src/core/ransac.h expected_needed). 'expected' ends hard searches much earlier but"
        " sees fewer rival models: on the real pairs it let two confident wrong poses through (docs/history/RESULTS_real_sessions.md,"
        " fifteenth session), so the default stays 'prosac'",
        choices=("prosac", "expected"),
    )
    solver: str = _opt("5pt", "str", "minimal solver", choices=("5pt", "lirp"))
    max_lo: int = _opt(8, "int", lo=0)
    challengers: int = _opt(
        4,
        "int",
        "the search keeps the best models of this many other basins (1 deg apart) and locally optimises them at its end; one that beats its result replaces it",
        lo=0,
        hi=64,
    )
    scoring: str = _opt(
        "msac-multi",
        "str",
        "the search's score: 'msac-multi' sums MSAC's truncated quadratic at tau, tau/2 and tau/4 "
        "(a coarse marginalisation over the noise scale); 'msac' at tau alone; 'count': RANSAC's inlier count",
        choices=("msac", "msac-multi", "count"),
    )
    chiral_scoring: bool = _opt(True, "bool", "the search scores a match whose point a hypothesis puts behind either camera as an outlier")
    keypoint_once: bool = _opt(
        True,
        "bool",
        "with chiral_scoring: of the matches that share a keypoint (an identical point in one image), "
        "only the correspondence that fits a hypothesis best scores and is its inlier (src/core/conflicts.h)",
    )
    lo_residual: str = _opt("sampson-chiral", "name", "residual")
    lo_mu0: float = _opt(1e3, "real", lo=0.0, lo_open=True)
    lo_iterations: int = _opt(10, "int", lo=1)
    lo_max_points: int = _opt(
        1000,
        "int",
        "each LO step of the search (and the rival's) runs on an evenly strided subset of at most this many of the points within its window"
        " (0: all); its model is then rescored on every match. 1000 left every status and summary figure of the real benchmark unchanged"
        " (docs/history/RESULTS_real_sessions.md, seventh session) and takes 8-25 % off pairs of 1000-4300 matches",
        lo=0,
    )
    adaptive_threshold: bool = _opt(True, "bool")
    noise_factor: float = _opt(2.5, "real", lo=0.0, lo_open=True)
    lo: str = _opt(
        "sampson",
        "str",
        "the search's local optimisation (src/core/estimators.h): Sampson LM with Cauchy's loss at the threshold ('sampson'), "
        "MSAC's truncated loss ('sampson-truncated'), msac-multi's truncated losses ('sampson-multi'), Cauchy's then one of "
        "those ('sampson-cauchy-truncated', 'sampson-cauchy-multi'; 'sampson-cauchy-auto': msac-multi's only where the "
        "matches within the threshold have a median error below 0.3 thresholds), or TLS IRLS on LiRP ('lirp'). A two-stage "
        "LO's two poses are scored by the search's scoring and the better kept, so its second stage (its loss fixed by "
        "the choice, whatever the scoring) never makes the search's result worse by that scoring",
        choices=("lirp", "sampson", "sampson-truncated", "sampson-multi", "sampson-cauchy-multi", "sampson-cauchy-truncated", "sampson-cauchy-auto"),
    )
    final: str = _opt(
        "ml",
        "str",
        "the final stage: the ML refinement; 'ligt' LO at a noise-matched threshold + angular LiGTopt (the earlier "
        "default); 'cauchy' PoseLib's: Sampson LM with a Cauchy loss at the threshold on the inliers (a study: worse on the real pairs)",
        choices=("ml", "ligt", "cauchy"),
    )
    ml_range: float = _opt(3.0, "real", lo=1.0, hi=100.0, lo_open=True)
    ml_start: str = _opt(
        "search",
        "str",
        "where the ML stage's EM starts: the chosen pose ('search'; a collapsed EM restarts as 'band'), its least-squares"
        " refit on the matches within 3 robust noise scales of it, at most the mixture's range ('band'), or both, the"
        " fixed point of the larger full-range mixture likelihood kept ('both'); the last two are studies (docs/RESULTS_real.md)",
        choices=("search", "band", "both"),
    )
    ml_tails: str = _opt(
        "student",
        "str",
        "the ML stage's inlier errors: Student-t with its degrees of freedom estimated (heavy-tailed real matches), or 'gauss' (MLESAC)",
        choices=("student", "gauss"),
    )
    ml_folds: int = _opt(
        5,
        "int",
        "the ML stage's inliers cross-fitted: a match the ML pose calls an inlier is removed when the ML pose of the other folds"
        " (i % ml_folds) puts it beyond the mixture's decision threshold, and the final pose is EM on every other match (0 or 1: the"
        " ML pose decides its own inliers; docs/history/RESULTS_real_sessions.md, twelfth and thirteenth sessions)",
        lo=0,
        hi=16,
    )
    max_leverage: float = _opt(
        0.5,
        "real",
        "the leverage test after the ML stage: inliers whose leverage in the least-squares fit of the inliers exceeds this"
        " (the fit absorbs more than this share of their own residual) are tested against the fit of the others, with its"
        " prediction uncertainty, and the ML pose is refitted without those it rejects (1: no test;"
        " poseonly.robust.default.leverage_test)",
        lo=0.0,
        hi=1.0,
        lo_open=True,
    )
    research_noise: float = _opt(
        0.0,
        "real",
        "repeat the search at 3 sigma when the ML noise scale sigma exceeds this fraction of the threshold (0: never; 0.5 is the studied value)",
        lo=0.0,
    )
    rival_distance: float = _opt(
        5.0,
        "real",
        "uniqueness test: the search keeps its best model this many degrees from the result and the other basins it optimised"
        " (at most `rivals`), refines them, and the status is 'ambiguous' when one of them, still this far in rotation, explains"
        " as many matches of its own as the result (0: no test)",
        lo=0.0,
        hi=180.0,
    )
    rivals: int = _opt(
        8,
        "int",
        "uniqueness test: the pose is compared with at most this many of the models the search kept rival_distance or more"
        " away, one per basin, best first (its best rival and the other basins it optimised; 1: the best rival alone)",
        lo=1,
        hi=64,
    )


@dataclass(frozen=True)
class GncRansacOptions(CommonOptions):
    """The paper's GNC-RANSAC (Alg. 3)."""

    max_iterations: int = _opt(50, "int", lo=1)
    sample_size: int = _opt(30, "int", lo=6)
    adaptive: bool = _opt(False, "bool")
    confidence: float = _opt(0.99, "real", lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    residual: str = _opt("ligt", "name", "residual")
    schedule: str = _opt("ms-tls", "str", choices=SCHEDULES)
    scale: str | float = _opt("median", "scale", choices=("median", "mad"))


@dataclass(frozen=True)
class GncIrlsOptions(CommonOptions):
    """GNC-IRLS (Alg. 2) on all points. ``scale=None``: noise bound from the pixel threshold."""

    residual: str = _opt("ligt", "name", "residual")
    schedule: str = _opt("ms-tls", "str", choices=SCHEDULES)
    scale: str | float | None = _opt(None, "scale", choices=("median", "mad"))
    max_iterations: int = _opt(100, "int", lo=1)


@dataclass(frozen=True)
class LirpOptions(CommonOptions):
    """LiRP (Alg. 1) on all points: only the common options."""


OPTIONS: dict[str, type[CommonOptions]] = {
    "poseonly": PoseonlyOptions,
    "gnc-ransac": GncRansacOptions,
    "gnc-irls": GncIrlsOptions,
    "lirp": LirpOptions,
}


def check_angle(name: str, tau: float, how: str = "") -> float:
    """An angular threshold (radians) within ``[MIN_ANGLE, MAX_ANGLE]``; ``how`` says how it was
    derived (for the message)."""
    if not (math.isfinite(tau) and MIN_ANGLE <= tau <= MAX_ANGLE):
        raise InputError(
            f"{name} = {tau:.17g} rad{how} must lie in [{MIN_ANGLE:g}, {MAX_ANGLE:g}] rad"
            f" ({'below' if tau < MIN_ANGLE else 'above'} it: a smaller angle is below double precision, a larger one makes every match an inlier)"
        )
    return float(tau)


def check_camera_threshold(camera: Any, method: str, threshold_px: float | None, name: str = "camera") -> None:
    """That ``threshold_px`` (``None``: ``method``'s default) over ``camera``'s mean focal length is an
    angle :func:`check_angle` accepts: a camera given once for many pairs is checked before any pair
    is estimated (each pair would fail alike)."""
    from .cameras import as_camera

    thr = float(parse_options(method, {}).threshold_px) if threshold_px is None else float(threshold_px)
    f = as_camera(camera, name).focal_px
    check_angle(f"{name}: the angular threshold threshold_px / focal", thr / f, f" (threshold {thr:g} px, focal {f:g} px)")


# other libraries' names for options that poseonly has under another name (OpenCV's findEssentialMat,
# PoseLib's RansacOptions, pycolmap's RANSACOptions): an unknown option says which one it means (a
# migrating user's trial got the list of all 45)
FOREIGN_OPTION_NAMES = {
    "prob": "confidence",
    "success_prob": "confidence",
    "threshold": "threshold_px",
    "max_epipolar_error": "threshold_px",
    "max_error": "threshold_px",
    "maxIters": "max_iterations",
    "max_num_trials": "max_iterations",
    "min_num_trials": "min_iterations",
    "random_seed": "seed",
}


def _unknown_option_hint(k: str, names: list[str]) -> str:
    """`` (did you mean ...?)`` for an unknown option ``k``: another library's name for it, or a close spelling."""
    import difflib

    if k in FOREIGN_OPTION_NAMES and FOREIGN_OPTION_NAMES[k] in names:
        return f" (poseonly's name for it: {FOREIGN_OPTION_NAMES[k]!r})"
    close = difflib.get_close_matches(k, names, n=3, cutoff=0.7)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def parse_options(method: Any, options: dict[str, Any]) -> CommonOptions:
    """The checked options dataclass of ``method`` from keyword ``options`` (``None`` = default)."""
    if not isinstance(method, str):
        raise InputError(f"method must be a string, one of {list(OPTIONS)}; got {_type_name(method)} {method!r}")
    if method not in OPTIONS:
        raise InputError(f"unknown method {method!r}; choose one of {list(OPTIONS)}")
    cls = OPTIONS[method]
    specs = {f.name: f.metadata["spec"] for f in fields(cls)}
    kw: dict[str, Any] = {}
    for k, v in options.items():
        if k not in specs:
            raise InputError(f"unknown option {k!r} for method {method!r}{_unknown_option_hint(str(k), sorted(specs))}; valid options: {sorted(specs)}")
        if v is not None:
            kw[k] = check_value(k, v, specs[k])
    return cls(**kw)
