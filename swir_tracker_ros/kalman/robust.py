# SPDX-License-Identifier: Apache-2.0
"""M-robust Kalman update (paper 000 eq. 31-35, paper 001 A2-A4) and the `RobustKalmanFilter` object."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman.influence import Huber, Influence
from swir_tracker_ros.kalman.sequential import UpdateInfo, sequential_update
from swir_tracker_ros.kalman.standard import KalmanFilter
from swir_tracker_ros.kalman.statlin import METHODS


def robust_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray, H: np.ndarray,
                  influence: Influence | None = None, robust_components: Sequence[int] | None = None,
                  method: str = "A2", alpha_f: float | None = None,
                  threshold: float | None = None) -> tuple[np.ndarray, np.ndarray, UpdateInfo]:
    """M-robust measurement update, components processed sequentially as scalars.

    Per robust scalar component (paper 000 eq. 31-35; paper 001 eq. 11, 14, 19, 22, 23, 28):
    d = sqrt(h P h' + r), u = eps/d, w = psi(u)/u, gain K = alpha P h'/d^2 and
    A2 (default, dissertation final system): alpha = w, x = x + K d psi(u);
    A3: alpha = alpha_f (fixed), x = x + K d psi(u);  A4 (= paper 000 eq. 33-34): alpha = w, x = x + K eps;
    P = (I - K h) P (eq. 35 / 22) in a PSD-safe form (see `statlin.scalar_update`).
    Components not in ``robust_components`` (None: all) get the standard update (eq. 16-19).
    ``influence`` defaults to Huber() (k = HUBER_K). Returns (x, P, UpdateInfo); inputs are not modified.
    """
    if influence is None:
        influence = Huber()
    return sequential_update(x, P, z, R, H, influence, robust_components, method, alpha_f, threshold)


class RobustKalmanFilter(KalmanFilter):
    """M-robust Kalman filter: standard prediction, robust update on chosen components.

    ``RobustKalmanFilter(model_or_F, H=None, Q=None, R=None, *, influence=Huber(),
    robust_components=(0, 1), method="A2", alpha_f=None, G=None, x=None, P=None)``.
    ``robust_components=(0, 1)`` makes the box centre robust and gives the size the standard update
    (paper 000 §IV-B); ``None`` makes every component robust. ``method`` is one of A1-A4
    (`statlin.METHODS`); A3 needs ``alpha_f`` (`statlin.alpha_fixed`). ``update(z, threshold=k)``
    uses threshold k for this step only (adaptive threshold, paper 000 eq. 38).
    """

    def __init__(self, model: Any, H: Any = None, Q: Any = None, R: Any = None, *,
                 influence: Influence | None = None, robust_components: Sequence[int] | None = (0, 1),
                 method: str = "A2", alpha_f: float | None = None, G: Any = None, x: Any = None,
                 P: Any = None) -> None:
        super().__init__(model, H, Q, R, G=G, x=x, P=P)
        if method not in METHODS:
            raise KalmanError(f"unknown method {method!r}; choose one of {METHODS}")
        if method == "A3" and alpha_f is None:
            raise KalmanError("method A3 needs alpha_f (see statlin.alpha_fixed)")
        if alpha_f is not None and not (0.0 <= alpha_f <= 1.0):
            raise KalmanError(f"alpha_f must be in [0, 1], got {alpha_f!r}")
        m = self.dim_z
        comps = None if robust_components is None else tuple(int(j) for j in robust_components)
        if comps is not None and any(j < 0 or j >= m for j in comps):
            raise KalmanError(f"robust_components {comps} out of range for {m} measurement components")
        self.influence: Influence = Huber() if influence is None else influence
        self.robust_components = comps
        self.method = method
        self.alpha_f = alpha_f

    def _influence(self) -> Influence:
        return self.influence

    def _alpha_f(self) -> float | None:
        return self.alpha_f
