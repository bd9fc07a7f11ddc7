# SPDX-License-Identifier: Apache-2.0
"""Per-track motion model, validation gate and motion cost (paper 004 eq. 2; model per notes seed-004 1.3)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from swir_tracker_ros.types import Box

# State x = [cx, cy, w, h, vx, vy]: constant-velocity centre, random-walk size; z = [cx, cy, w, h].
STATE_DIM = 6
MEAS_DIM = 4


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
    H = np.zeros((MEAS_DIM, STATE_DIM))
    H[:, :MEAS_DIM] = np.eye(MEAS_DIM)
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
