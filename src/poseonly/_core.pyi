"""Type stubs of the compiled core poseonly._core (src/core/*.cpp)."""

from typing import Any

import numpy as np
from numpy.typing import NDArray

RESIDUAL_KINDS: tuple[str, ...]
LIRP_CANDIDATES: int
SOURCE_HASH: str  # SHA-256 of the src/core sources it was built from (CMakeLists.txt; poseonly._build)

def residual_matrix(kind: int, R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64]) -> NDArray[np.float64]: ...
def pixel_bearings(a: NDArray[np.float64], K: NDArray[np.float64], zero: float) -> tuple[NDArray[np.float64], int, int, int] | None: ...
def undistort_brown(
    xd: NDArray[np.float64], yd: NDArray[np.float64], k: NDArray[np.float64], tol: float, max_iter: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]: ...
def undistort_fisheye(rd: NDArray[np.float64], k: NDArray[np.float64], tol: float, max_iter: int) -> tuple[NDArray[np.float64], NDArray[np.uint8]]: ...
def undistort_prism(
    xd: NDArray[np.float64], yd: NDArray[np.float64], kind: int, k: NDArray[np.float64], tol: float, max_iter: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]: ...
def unit_rows(a: NDArray[np.float64], zero: float) -> tuple[NDArray[np.float64], int, int]: ...
def epipolar_singular_values(f1: NDArray[np.float64], f2: NDArray[np.float64]) -> NDArray[np.float64]: ...

_F64 = NDArray[np.float64]

_LirpTuple = tuple[_F64, _F64, _F64, NDArray[np.bool_], _F64, _F64, int, float, float, int, _F64, _F64, _F64]

def lirp_one(f1: _F64, f2: _F64, w: _F64 | None = None, all_costs: bool = True, rank_tol: float = 1e-9) -> _LirpTuple: ...
def lirp_bearings(f1: _F64, f2: _F64, w: _F64 | None, rank_tol: float, zero: float, min_points: int) -> _LirpTuple | None: ...
def lirp_batch(f1: NDArray[np.float64], f2: NDArray[np.float64], w: NDArray[np.float64] | None = None, all_costs: bool = True) -> dict[str, Any]: ...
def identify(E: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], w: NDArray[np.float64] | None = None, with_cost: bool = True) -> dict[str, Any]: ...
def gnc_irls_batch(
    f1: NDArray[np.float64], f2: NDArray[np.float64], w0: NDArray[np.float64] | None = None, options: dict[str, Any] = ..., check_signals: bool = False
) -> dict[str, Any]: ...

class CancelFlag:
    def __init__(self) -> None: ...
    def set(self) -> None: ...
    def is_set(self) -> bool: ...

class SearchCancelled(Exception): ...

def ransac_relpose(
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    threshold: float,
    seed: int,
    solver: int = 0,
    scoring: int = 1,
    max_iterations: int = 100000,
    min_iterations: int = 50,
    confidence: float = 0.999,
    max_lo: int = 8,
    lo_mu0: float = 1e3,
    lo_iterations: int = 10,
    lo_residual: int = 1,
    order: NDArray[np.int64] | None = None,
    lo: int = 0,
    rival_distance: float = 0.0,
    chiral: bool = False,
    min_hits: int = 1,
    challengers: int = 0,
    challenger_distance: float = 1.0,
    lo_max_points: int = 0,
    keypoint_once: bool = False,
    progressive_stop: bool = False,
    floor_parallax: float = 0.0,
    min_iterations_parallax: int = 0,
    progressive_expected: bool = False,
    progressive_min_draws: int = 0,
    prosac_trials: int = 0,
    min_inlier_ratio: float = 0.0,
    check_signals: bool = False,
    cancel: CancelFlag | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]: ...
def search_cost(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    threshold: float,
    scoring: int = 1,
    keypoint_once: bool = True,
) -> tuple[float, NDArray[np.int64]]: ...
def keypoint_groups(f1: NDArray[np.float64], f2: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]: ...
def relpose_lo(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    threshold: float,
    lo_mu0: float = 1e3,
    lo_iterations: int = 10,
    lo_residual: int = 1,
    lo: int = 0,
    lo_max_points: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def ml_refine(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    range: float,
    rounds: int = 6,
    lm_iterations: int = 10,
    pose_tol: float = 0.0,
    student: bool = True,
    scales: NDArray[np.float64] | None = None,
    band_start: bool = False,
    nu: float | None = None,
    alpha: float | None = None,
    pose_only: bool = False,
    sigma_init: float | None = None,
    g_init: float | None = None,
    noise_floor: float = 0.0,
) -> dict[str, Any]: ...
def ml_cross_fit(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    range: float,
    decision: float,
    folds: int = 5,
    min_agree: int = 15,
    student: bool = True,
    scales: NDArray[np.float64] | None = None,
    nu: float | None = None,
    alpha: float | None = None,
    sigma_init: float | None = None,
    g_init: float | None = None,
    *,
    fold_rounds: int,
    fold_lm_iterations: int,
    fold_pose_tol: float,
    final_rounds: int,
    final_lm_iterations: int,
    final_pose_tol: float,
    noise_floor: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], int, bool, NDArray[np.uint8]]: ...
def gnc_ransac(
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    theta: float,
    seed: int,
    sample_size: int = 30,
    max_iterations: int = 50,
    adaptive: bool = False,
    confidence: float = 0.99,
    gnc: dict[str, Any] = ...,
    check_signals: bool = False,
    cancel: CancelFlag | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], dict[str, Any]]: ...
def ransac_python(
    estimator: Any,
    sample_size: int,
    num_data: int,
    has_refine: bool,
    has_distance: bool,
    threshold: float,
    seed: int,
    max_iterations: int,
    min_iterations: int,
    confidence: float,
    max_lo: int,
    scoring: int,
    challengers: int,
    challenger_distance: float,
    order: NDArray[np.int64] | None,
) -> tuple[Any, dict[str, Any]]: ...
def ransac_line(
    xy: NDArray[np.float64],
    threshold: float,
    seed: int,
    max_iterations: int = 1000,
    confidence: float = 0.999,
    max_lo: int = 8,
    scoring: int = 0,
    challengers: int = 0,
    challenger_distance: float = 1.0,
    min_inlier_ratio: float = 0.0,
) -> tuple[tuple[float, float, float], dict[str, Any]]: ...
def fivept(f1: NDArray[np.float64], f2: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def fivept_batch(f1: NDArray[np.float64], f2: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]: ...
def fivept_essentials(f1: NDArray[np.float64], f2: NDArray[np.float64]) -> NDArray[np.float64]: ...
def _fivept_essentials_path(f1: NDArray[np.float64], f2: NDArray[np.float64], path: int) -> tuple[NDArray[np.float64], int]: ...
def refine_sampson(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    w: NDArray[np.float64] | None = None,
    loss: str = "linear",
    loss_scale: float | None = None,
    max_iterations: int = 50,
    tol: float = 1e-12,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]: ...
def refine_ligt(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    w: NDArray[np.float64] | None = None,
    normalization: str = "none",
    loss: str = "linear",
    loss_scale: float | None = None,
    max_iterations: int = 50,
    tol: float = 1e-12,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]: ...
def pose_covariance(
    R: NDArray[np.float64],
    t: NDArray[np.float64] | None,
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    w: NDArray[np.float64] | None = None,
    threshold: float = 0.0,
    noise_floor: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, int, bool]: ...
def leverage_veto(
    R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], inliers: NDArray[np.bool_], decision: float, max_leverage: float
) -> tuple[NDArray[np.float64], NDArray[np.uint8], NDArray[np.uint8], bool, NDArray[np.float64], NDArray[np.float64]]: ...
def _refine_residuals(
    kind: int, R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], x: NDArray[np.float64], w: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def _refine_normal_equations(
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    x: NDArray[np.float64],
    w: NDArray[np.float64] | None = None,
    blocks: bool = True,
    loss: str = "linear",
    loss_scale: float = 1.0,
    weights_outside: bool = False,
    residual_weights: NDArray[np.float64] | None = None,
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]: ...
def robust_rotation(
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    chord: float,
    seed: int,
    max_iterations: int = 10000,
    confidence: float = 0.999,
    max_score_points: int = 0,
    min_inlier_ratio: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.uint8], int]: ...
def chance_count(R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], perm: NDArray[np.int64], tau: float) -> int: ...
def rotation_chance_count(R: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], perm: NDArray[np.int64], chord2: float) -> int: ...
def homography_twin(
    R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], float] | None: ...
def homography_twin_dlt(
    R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], max_transfer: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None: ...
def log_binom_sf(k: int, n: int, p: float) -> float: ...
def compare_support(
    R_a: NDArray[np.float64],
    t_a: NDArray[np.float64],
    R_b: NDArray[np.float64],
    t_b: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    thr: float,
    far_neutral: bool = False,
) -> tuple[int, int, int, int]: ...
def analyse_twin(
    R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], mask: NDArray[np.bool_], tau: float
) -> tuple[float, tuple[NDArray[np.float64], NDArray[np.float64], tuple[int, int, int, int]] | None] | None: ...
def median_rotation_angle(R: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], mask: NDArray[np.bool_]) -> float: ...
def parallax_ratio(
    R: NDArray[np.float64],
    f1: NDArray[np.float64],
    f2: NDArray[np.float64],
    v_pose: NDArray[np.float64],
    tau: float,
    band: float,
    sel_chord2: float,
    min_matches: int,
    irls_rounds: int,
    cauchy_c: float,
    chi2_median: float,
    min_parallax: float,
    noise_floor: float = 0.0,
) -> tuple[float, float, NDArray[np.float64] | None]: ...
def decompose_homography(H: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None: ...
def select_by_support(
    R: NDArray[np.float64], t: NDArray[np.float64], f1: NDArray[np.float64], f2: NDArray[np.float64], tau: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def nearest_neighbours(f: NDArray[np.float64], k: int) -> NDArray[np.int64]: ...
def neighbour_consistency(f1: NDArray[np.float64], f2: NDArray[np.float64], k: int) -> NDArray[np.int64]: ...
def distinct_matches(f1: NDArray[np.float64], f2: NDArray[np.float64], tol: float) -> NDArray[np.int64] | None: ...
def locally_supported(f1: NDArray[np.float64], extra: NDArray[np.bool_], explained: NDArray[np.bool_], k_max: int, min_count: int) -> NDArray[np.uint8]: ...
