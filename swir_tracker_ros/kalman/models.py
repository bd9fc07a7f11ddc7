# SPDX-License-Identifier: Apache-2.0
"""Box motion models: 7-state KCF (paper 000 eq. 9, 36, 37) and 8-state DCF-CA (dissertation eq. 6.1-6.3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.types import Box


@dataclass(frozen=True, eq=False)
class BoxModel:
    """Constant-velocity box model: F, G, H, Q, R, a start covariance P0 and the box <-> state mapping.

    ``kind`` is ``"area_aspect"`` (paper 000's state [xc, yc, s, r, vx, vy, vs], s = w h, r = w/h) or
    ``"width_height"`` (the dissertation's state [xc, yc, w, h, vxc, vyc, vw, vh]). The measurement is
    always H x: the first 4 state entries.
    """

    kind: str
    F: np.ndarray
    G: np.ndarray
    H: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    P0: np.ndarray
    names: tuple[str, ...]

    def measurement_from_box(self, box: Box) -> np.ndarray:
        """The measurement vector z = H x of a box: [xc, yc, s, r] (area_aspect), else [xc, yc, w, h]."""
        if self.kind == "area_aspect":
            r = box.w / box.h if box.h != 0 else math.nan
            return np.array([box.cx, box.cy, box.w * box.h, r])
        return np.array([box.cx, box.cy, box.w, box.h])

    def state_from_box(self, box: Box) -> np.ndarray:
        """Start state: the box measurement and zero velocities (dissertation eq. 6.1)."""
        if not box.is_valid():
            raise KalmanError(f"cannot start a box model from an invalid box {box}")
        x = np.zeros(self.F.shape[0])
        x[:4] = self.measurement_from_box(box)
        return x

    def box_from_state(self, x: np.ndarray) -> Box:
        """Box of a state; a non-positive size (or area or aspect) gives w = h = 0 (not is_valid)."""
        x = np.asarray(x, dtype=float)
        cx, cy = float(x[0]), float(x[1])
        if self.kind == "area_aspect":
            s, r = float(x[2]), float(x[3])
            w, h = (math.sqrt(s * r), math.sqrt(s / r)) if s > 0 and r > 0 else (0.0, 0.0)
        else:
            w, h = max(float(x[2]), 0.0), max(float(x[3]), 0.0)
        return Box.from_center(cx, cy, w, h)


def _cv_transition(n_pos: int, n_vel: int, T: float) -> np.ndarray:
    """F with the first n_vel position entries driven by the velocities (CV model)."""
    n = n_pos + n_vel
    F = np.eye(n)
    for i in range(n_vel):
        F[i, n_pos + i] = T
    return F


def kcf_box_model(T: float = 1.0) -> BoxModel:
    """Paper 000 KCF-pipeline model: state eq. 9, F and H eq. 36, Q and R eq. 37, G = I7, T = 1 frame.

    P0 (not given in paper 000): diag(R, 100, 100, 100): the first box is a measurement with covariance
    R, centre velocity variance 100 px^2/frame^2 as in paper 001's video filter P0, and the same for vs.
    """
    F = _cv_transition(4, 3, T)
    H = np.hstack([np.eye(4), np.zeros((4, 3))])
    Q = np.diag([1.0, 1.0, 1.0, 1.0, 0.1, 0.1, 0.01])
    R = np.diag([1.0, 1.0, 10.0, 10.0])
    P0 = np.diag([1.0, 1.0, 10.0, 10.0, 100.0, 100.0, 100.0])
    return BoxModel("area_aspect", F, np.eye(7), H, Q, R, P0, ("xc", "yc", "s", "r", "vx", "vy", "vs"))


def dcfca_box_model(w: float, h: float, sigma_p: float = 0.05, sigma_v: float = 0.00625,
                    T: float = 1.0) -> BoxModel:
    """Dissertation DCF-CA model: state eq. 4.93, F eq. 6.2, H = [I4 0], G = I8, Q and R eq. 6.3.

    Q = diag((sp w)^2, (sp h)^2, (sp w)^2, (sp h)^2, (sv w)^2, (sv h)^2, (sv w)^2, (sv h)^2),
    R = diag((sp w)^2, (sp h)^2, (sp w)^2, (sp h)^2), with w, h the first (ground-truth) box size.
    P0 (not given in the dissertation): diag(R, 100, 100, (10 sv w)^2, (10 sv h)^2): centre velocity
    variance as paper 001's video filter, size velocity ten times the process-noise standard deviation.
    """
    if not (math.isfinite(w) and math.isfinite(h) and w > 0 and h > 0):
        raise KalmanError(f"dcfca_box_model needs a positive finite box size, got w={w!r}, h={h!r}")
    pw, ph, vw, vh = (sigma_p * w) ** 2, (sigma_p * h) ** 2, (sigma_v * w) ** 2, (sigma_v * h) ** 2
    F = _cv_transition(4, 4, T)
    H = np.hstack([np.eye(4), np.zeros((4, 4))])
    Q = np.diag([pw, ph, pw, ph, vw, vh, vw, vh])
    R = np.diag([pw, ph, pw, ph])
    P0 = np.diag([pw, ph, pw, ph, 100.0, 100.0, 100.0 * vw, 100.0 * vh])
    names = ("xc", "yc", "w", "h", "vxc", "vyc", "vw", "vh")
    return BoxModel("width_height", F, np.eye(8), H, Q, R, P0, names)
