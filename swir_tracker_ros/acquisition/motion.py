# SPDX-License-Identifier: Apache-2.0
"""Per-track motion model, validation gate and motion cost (paper 004 eq. 2; model per notes seed-004 1.3);
partial detections (occluder, image border) measured and gated on their visible edges only (ours)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from swir_tracker_ros.types import Box

# State x = [cx, cy, w, h, vx, vy]: constant-velocity centre, random-walk size; z = [cx, cy, w, h].
STATE_DIM = 6
MEAS_DIM = 4
# Box edges as linear functions of z: left = cx - w/2, top = cy - h/2, right = cx + w/2, bottom = cy + h/2.
LEFT, TOP, RIGHT, BOTTOM = range(4)
ALL_EDGES = (LEFT, TOP, RIGHT, BOTTOM)
EDGES = np.array([[1.0, 0.0, -0.5, 0.0], [0.0, 1.0, 0.0, -0.5], [1.0, 0.0, 0.5, 0.0], [0.0, 1.0, 0.0, 0.5]])


def measurement_matrix() -> np.ndarray:
    """H of the box model: z = [cx, cy, w, h] = H x."""
    H = np.zeros((MEAS_DIM, STATE_DIM))
    H[:, :MEAS_DIM] = np.eye(MEAS_DIM)
    return H


def box_model(
    q_pos: float, q_size: float, r_pos: float, r_size: float, dt: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(F, Q, H, R) of the image-plane box model: white-noise acceleration q_pos (px/frame^2)^2 per axis,
    size random walk q_size (px^2), measurement noise std r_pos on the centre and r_size on w, h."""
    F = np.eye(STATE_DIM)
    F[0, 4] = F[1, 5] = dt
    Q = np.zeros((STATE_DIM, STATE_DIM))
    blk = q_pos * np.array([[dt**4 / 4.0, dt**3 / 2.0], [dt**3 / 2.0, dt**2]])
    for p, v in ((0, 4), (1, 5)):
        Q[np.ix_((p, v), (p, v))] = blk
    Q[2, 2] = Q[3, 3] = q_size
    H = measurement_matrix()
    R = np.diag([r_pos**2, r_pos**2, r_size**2, r_size**2])
    return F, Q, H, R


def initial_covariance(box: Box, r_pos: float, r_size: float, v0: float) -> np.ndarray:
    """P0: measurement noise on the measured components, (v0 px/frame)^2 on the unknown velocity."""
    return np.diag([r_pos**2, r_pos**2, r_size**2, r_size**2, v0**2, v0**2])


def state_from_box(box: Box) -> np.ndarray:
    return np.array([box.cx, box.cy, box.w, box.h, 0.0, 0.0])


def measurement(box: Box) -> np.ndarray:
    return np.array([box.cx, box.cy, box.w, box.h])


def box_from_state(x: np.ndarray) -> Box:
    w, h = max(float(x[2]), 1.0), max(float(x[3]), 1.0)
    return Box.from_center(float(x[0]), float(x[1]), w, h)


def gate_distance2(x: np.ndarray, P: np.ndarray, R: np.ndarray, z_center: tuple[float, float]) -> float:
    """Squared Mahalanobis distance of a detection centre to the predicted centre, nu' S^-1 nu with
    S = H P H' + R on the (cx, cy) block: the covariance ellipse of paper 004 Section 3.1."""
    S = P[:2, :2] + R[:2, :2]
    nu = np.array([z_center[0] - x[0], z_center[1] - x[1]])
    return float(nu @ np.linalg.solve(S, nu))


def gate_distances2(x: np.ndarray, P: np.ndarray, R: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """gate_distance2 for an (m, 2) array of detection centres at once."""
    S_inv = np.linalg.inv(P[:2, :2] + R[:2, :2])
    nu = np.asarray(centres, dtype=np.float64).reshape(-1, 2) - x[:2]
    return np.einsum("ij,jk,ik->i", nu, S_inv, nu)


@lru_cache(maxsize=64)
def gate_threshold(chi2_2dof: float, dof: int) -> float:
    """The chi^2 threshold with dof degrees of freedom at the confidence of the 2-dof centre gate chi2_2dof
    (P = 1 - exp(-chi2_2dof / 2)), so that a partial detection is gated at the same level as a full one."""
    if dof == 2:
        return chi2_2dof
    return float(chi2.ppf(-math.expm1(-0.5 * chi2_2dof), dof))


def edge_sigmas(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Standard deviations of the innovations of the four edges (left, top, right, bottom) of the predicted
    box: sqrt(diag(E H P H' E' + E R E')), E = EDGES."""
    EH = EDGES @ measurement_matrix()
    return np.sqrt(np.diag(EH @ P @ EH.T + EDGES @ R @ EDGES.T))


def visible_edges(pred: Box, det: Box, ratio: float, one_sided: float, tol: Sequence[float]
                  ) -> tuple[int, ...]:
    """Edges of a detection that measure the target's own outline (ours; notes seed-004 Section 4: the paper
    updates the track from every associated box, with no occlusion-aware update).

    An occluder in front of the target (a pole, another person, the image border) cuts it from one side: on
    that axis the detection is shorter than the predicted box, its near edge is where the prediction has the
    target's edge, and its far edge, on the occluder, lies inside the predicted box. An axis is cut when the
    detection is below ratio times the predicted size there, its far edge is inside the predicted box (within
    tol, px per edge: left, top, right, bottom), and the cut is one-sided: the near edge moved at most
    one_sided times as far as the far edge (a box shrunk from both sides is a change of scale, measured in
    full). Only the near edge of a cut axis is measured; both edges of an axis that is not cut are.

    A detection below ratio on both axes is a fragment (an arm coming out from behind a pole, a head over a
    wall): on one axis it reaches neither edge of the outline. Only the near edge of the axis cut most
    one-sidedly is measured, and on the other axis the fragment must lie inside the predicted box (within
    tol).

    Returns ALL_EDGES (a full detection, the paper's update) when no axis is below ratio, when the shrinkage
    does not look like an occlusion of this track, or when ratio <= 0. A larger detection is never cut.
    """
    if ratio <= 0.0:
        return ALL_EDGES
    d = (det.x, det.y, det.x + det.w, det.y + det.h)
    p = (pred.x, pred.y, pred.x + pred.w, pred.y + pred.h)
    small = 0  # axes on which the detection is below ratio times the prediction
    cut: list[tuple[float, int]] = []  # (near / far innovation, near edge) of the one-sided, inside cuts
    for lo, hi, size_d, size_p in ((LEFT, RIGHT, det.w, pred.w), (TOP, BOTTOM, det.h, pred.h)):
        if size_d >= ratio * size_p:
            continue
        small += 1
        e_lo, e_hi = abs(d[lo] - p[lo]), abs(d[hi] - p[hi])
        near, far, e_near, e_far = (lo, hi, e_lo, e_hi) if e_lo <= e_hi else (hi, lo, e_hi, e_lo)
        inside = d[far] <= p[far] + tol[far] if far == hi else d[far] >= p[far] - tol[far]
        if inside and e_near <= one_sided * e_far:
            cut.append((e_near / max(e_far, 1e-9), near))
    if not cut:
        return ALL_EDGES  # nothing small, a change of scale, or not inside this track's box: measured in full
    near = min(cut)[1]
    if small == 1:
        return tuple(e for e in ALL_EDGES if e != (near + 2) % 4)  # all but the far edge
    other = (near + 1) % 2  # the fragment's unmeasured axis: lo edge (LEFT 0 or TOP 1), hi edge other + 2
    if d[other] < p[other] - tol[other] or d[other + 2] > p[other + 2] + tol[other + 2]:
        return ALL_EDGES
    return (near,)


def track_visible_edges(x: np.ndarray, P: np.ndarray, R: np.ndarray, det: Box, ratio: float,
                        one_sided: float, gate_chi2: float) -> tuple[int, ...]:
    """visible_edges of det against the predicted box of state (x, P) with measurement noise R; the
    containment tolerance of each edge is its 1-dof gate at the confidence of gate_chi2 (k sigma)."""
    pred = box_from_state(x)
    if det.w >= ratio * pred.w and det.h >= ratio * pred.h:
        return ALL_EDGES  # the common case, without the tolerances
    tol = math.sqrt(gate_threshold(gate_chi2, 1)) * edge_sigmas(P, R)
    return visible_edges(pred, det, ratio, one_sided, tol)


def _anchor_axis(start: float, size: float, pred_start: float, pred_size: float, start_seen: bool,
                 end_seen: bool) -> tuple[float, float]:
    """(start, size) on one axis: both edges seen keep the detection's extent, none the prediction's; with
    one edge seen the predicted extent hangs from it."""
    if not start_seen and not end_seen:
        return pred_start, pred_size
    if not start_seen:
        return start + size - pred_size, pred_size
    if not end_seen:
        return start, pred_size
    return start, size


def anchored_box(pred: Box, det: Box, edges: Sequence[int]) -> Box:
    """The target's full box implied by a detection: on a cut axis the predicted extent is anchored at the
    visible edge; an axis with both edges visible keeps the detection's extent, one with none (a fragment's)
    the prediction's."""
    x, w = _anchor_axis(det.x, det.w, pred.x, pred.w, LEFT in edges, RIGHT in edges)
    y, h = _anchor_axis(det.y, det.h, pred.y, pred.h, TOP in edges, BOTTOM in edges)
    return Box(x, y, w, h)


def edge_model(H: np.ndarray, R: np.ndarray, box: Box, edges: Sequence[int]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z, H, R) of a partial measurement made of the given edges of box: z_e = E z, H_e = E H,
    R_e = E R E' (rows of the visible edges; E = EDGES). With ALL_EDGES this is the full measurement in
    another basis, so the Kalman update equals the one on [cx, cy, w, h]."""
    E = EDGES[list(edges)]
    return E @ measurement(box), E @ H, E @ R @ E.T


def edge_gate_distance2(x: np.ndarray, P: np.ndarray, H: np.ndarray, R: np.ndarray, box: Box,
                        edges: Sequence[int]) -> float:
    """Squared Mahalanobis distance nu' S^-1 nu of the visible edges of box to the same edges of the
    predicted full box (S = H_e P H_e' + R_e): the validation gate of paper 004 Section 3.1 applied to what a
    partial detection measures; chi^2 with len(edges) degrees of freedom."""
    z, He, Re = edge_model(H, R, box, edges)
    nu = z - He @ x
    return float(nu @ np.linalg.solve(He @ P @ He.T + Re, nu))


def motion_cost(
    pred: Box, det: Box, history: Sequence[tuple[float, float]], w_dst: float, w_dev: float
) -> float:
    """m(i, j) of paper 004 eq. (2) without the optical-flow term: w_dst * dst + w_dev * (sigma_x + sigma_y).

    dst is the distance of the detection centre to the predicted centre; sigma_x, sigma_y are the deviation
    of the implied displacement (detection minus last position) from the mean displacement of the track's
    history (its motion pattern so far). Both are divided by the predicted box height so the cost does not
    grow with the pedestrian's apparent size.
    """
    scale = max(pred.h, 1.0)
    dst = pred.center_distance(det) / scale
    if len(history) < 2:
        return w_dst * dst
    pts = np.asarray(history, dtype=np.float64)
    mean_step = np.diff(pts, axis=0).mean(axis=0)
    step = np.array([det.cx, det.cy]) - pts[-1]
    dev = np.abs(step - mean_step) / scale
    return w_dst * dst + w_dev * float(dev.sum())
