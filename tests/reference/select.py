"""numpy reference of the default method's pose-only choice (the core's ``select_by_support`` in
``src/core/analysis.cpp``; tests compare)."""

from __future__ import annotations

import numpy as np

from poseonly.analysis import support
from poseonly.geometry import essential_from_pose, rotation_error_deg
from poseonly.identify import identify_poses
from poseonly.residuals import v_sampson
from poseonly.solvers.lirp import lirp_batch
from poseonly.twin import homography_twin

from .status import plausible_twin, polish

SAME_BASIN_DEG = 1.0


def select_by_support(R, t, f1, f2, tau):
    """Best of ``(R, t)`` (re-identified on its Sampson inliers), its homography twin and the LiRP
    candidates of its consensus set, by cheirality-consistent support."""
    sel = np.nonzero(v_sampson(R, t, f1, f2) < tau)[0]
    if len(sel) < 6:
        return R, t
    Ri, ti, _, _ = identify_poses(essential_from_pose(R, t)[None], f1[sel], f2[sel])
    R, t = Ri[0], ti[0]
    inl = support(R[None], t[None], f1, f2, tau)[0]
    o = lirp_batch(f1[sel][None], f2[sel][None])
    cR = [R[None], o["cand_R"][0]]
    ct = [t[None], o["cand_t"][0]]
    tw = homography_twin(R, t, f1[sel], f2[sel])
    if tw is not None and plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = polish(tw[0], tw[1], f1, f2, tau)
        cR.append(Rt[None])
        ct.append(tt[None])
    cRa, cta = np.concatenate(cR), np.concatenate(ct)
    # candidates within 1 deg of the re-identified pose (max of the rotation and translation angles)
    # are estimates of the same pose, not alternatives
    far = np.maximum(rotation_error_deg(R[None], cRa), np.degrees(np.arccos(np.clip(cta @ t / np.linalg.norm(cta, axis=1), -1, 1)))) >= SAME_BASIN_DEG
    far[0] = True
    cRa, cta = cRa[far], cta[far]
    sup = support(cRa, cta, f1, f2, tau).sum(axis=1)
    k = int(np.argmax(sup))
    return (cRa[k], cta[k]) if sup[k] > inl.sum() else (R, t)
