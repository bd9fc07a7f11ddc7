# SPDX-License-Identifier: Apache-2.0
"""Standard Kalman filter (paper 000 eq. 14-19): pure predict/update functions and `KalmanFilter`."""

from __future__ import annotations

from typing import Any

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman.sequential import UpdateInfo, check_matrices, coast_info, sequential_update


def predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray,
            G: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Time update, paper 000 eq. 14-15: x = F x, P = F P F' + G Q G' (G = I when None).

    Parameters: x (n,), P (n, n), F (n, n), Q (l, l), G (n, l). Returns the new (x, P); P is symmetrised.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    GQG = Q if G is None else G @ Q @ G.T
    x_new = F @ x
    # P = F P F' + G Q G'
    P_new = F @ P @ F.T + GQG
    return x_new, 0.5 * (P_new + P_new.T)


def update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray,
           H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Measurement update as one vector step, paper 000 eq. 16-19, covariance in Joseph form.

    Parameters: x (n,), P (n, n), z (m,), R (m, m), H (m, n). Raises KalmanError on a non-finite z
    (use `KalmanFilter.update`, which skips non-finite components as missed measurements).
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.atleast_2d(np.asarray(H, dtype=float))
    R = np.atleast_2d(np.asarray(R, dtype=float))
    z = np.atleast_1d(np.asarray(z, dtype=float))
    check_matrices(x, P, H, R)
    if not np.all(np.isfinite(z)):
        raise KalmanError(f"measurement z holds non-finite values: {z}")
    eps = z - H @ x  # eq. 16
    S = H @ P @ H.T + R  # eq. 20
    K = np.linalg.solve(S, H @ P).T  # eq. 17: K = P H' S^-1 (S and P symmetric)
    x_new = x + K @ eps  # eq. 18
    # Joseph form of eq. 19: P = (I - K H) P (I - K H)' + K R K'
    IKH = np.eye(len(x)) - K @ H
    P_new = IKH @ P @ IKH.T + K @ R @ K.T
    return x_new, 0.5 * (P_new + P_new.T)


def _matrices(model: Any, H: Any, Q: Any, R: Any, G: Any) -> tuple[np.ndarray, ...]:
    """Accept a model object with F, H, Q, R (and optional G, P0) or the four matrices."""
    P0 = None
    if hasattr(model, "F") and H is None:
        F, H, Q, R = model.F, model.H, model.Q, model.R
        G = getattr(model, "G", None) if G is None else G
        P0 = getattr(model, "P0", None)
    else:
        F = model
    if any(a is None for a in (F, H, Q, R)):
        raise KalmanError("give a model with F, H, Q, R or all four matrices F, H, Q, R")
    F = np.atleast_2d(np.asarray(F, dtype=float)).copy()
    n = F.shape[0]
    if F.shape != (n, n):
        raise KalmanError(f"transition matrix F must be square, got shape {F.shape}")
    H = np.atleast_2d(np.asarray(H, dtype=float)).copy()
    Q = np.atleast_2d(np.asarray(Q, dtype=float)).copy()
    R = np.atleast_2d(np.asarray(R, dtype=float)).copy()
    if G is not None:
        G = np.asarray(G, dtype=float).reshape(n, -1).copy()
        if Q.shape != (G.shape[1], G.shape[1]):
            raise KalmanError(f"Q must be {G.shape[1]}x{G.shape[1]} to match G {G.shape}, got {Q.shape}")
    elif Q.shape != (n, n):
        raise KalmanError(f"Q must be {n}x{n} without G, got shape {Q.shape}")
    return F, H, Q, R, G, (None if P0 is None else np.asarray(P0, dtype=float).copy())


class KalmanFilter:
    """Standard Kalman filter (paper 000 eq. 14-19) with public numpy state ``x, P, F, Q, H, R, G``.

    ``KalmanFilter(model)`` takes F, H, Q, R, G and P0 from a `models.BoxModel`; ``KalmanFilter(F, H, Q, R,
    G=None)`` takes matrices. ``R`` may be reassigned between steps (adaptive R), or passed to `update`.
    The update processes the components sequentially as scalars (identical to eq. 16-19 for a diagonal R;
    a non-diagonal R is decorrelated first), so that it is bit-identical to `RobustKalmanFilter` whenever
    every residual lies inside the robust threshold.
    """

    robust_components: tuple[int, ...] | None = ()
    method = "A1"

    def __init__(self, model: Any, H: Any = None, Q: Any = None, R: Any = None, *, G: Any = None,
                 x: Any = None, P: Any = None) -> None:
        self.F, self.H, self.Q, self.R, self.G, P0 = _matrices(model, H, Q, R, G)
        n = self.F.shape[0]
        self.x = np.zeros(n) if x is None else np.asarray(x, dtype=float).copy()
        if P is not None:
            self.P = np.asarray(P, dtype=float).copy()
        else:
            self.P = P0 if P0 is not None else np.eye(n)
        check_matrices(self.x, self.P, self.H, self.R)

    @property
    def dim_x(self) -> int:
        return self.F.shape[0]

    @property
    def dim_z(self) -> int:
        return self.H.shape[0]

    def initialize(self, x: Any, P: Any = None) -> None:
        """Set the state (and covariance, default: keep the current P); raises KalmanError if non-finite."""
        try:
            x = np.asarray(x, dtype=float).reshape(self.dim_x).copy()
            P = self.P if P is None else np.asarray(P, dtype=float).reshape(self.dim_x, self.dim_x).copy()
        except (TypeError, ValueError) as exc:
            n = self.dim_x
            raise KalmanError(f"initialize needs x of {n} numbers and P of {n}x{n}: {exc}") from None
        check_matrices(x, P, self.H, self.R)
        self.x, self.P = x, P

    def predict(self) -> tuple[np.ndarray, np.ndarray]:
        """Time update (paper 000 eq. 14-15); returns the predicted (x, P)."""
        self.x, self.P = predict(self.x, self.P, self.F, self.Q, self.G)
        return self.x, self.P

    def predicted_measurement(self) -> np.ndarray:
        return self.H @ self.x

    def innovation_covariance(self, R: Any = None) -> np.ndarray:
        """S = H P H' + R (paper 000 eq. 20) at the current state."""
        R = self.R if R is None else np.atleast_2d(np.asarray(R, dtype=float))
        return self.H @ self.P @ self.H.T + R

    def _influence(self) -> Any:
        return None

    def _alpha_f(self) -> float | None:
        return None

    def update(self, z: Any = None, threshold: float | None = None, R: Any = None) -> UpdateInfo:
        """Measurement update; ``z=None`` coasts (prediction only).

        Non-finite components of z are skipped as missed measurements (``info.nonfinite``); if none is
        left the step coasts. ``R`` overrides ``self.R`` for this step only. ``threshold`` overrides the
        influence threshold of a robust filter for this step (ignored by the standard filter).
        """
        R_use = self.R if R is None else np.atleast_2d(np.asarray(R, dtype=float))
        influence = self._influence()
        if z is None:
            thr = None
            if influence is not None and self.method != "A1":
                thr = float(threshold) if threshold is not None else influence.threshold
            return coast_info(self.dim_z, thr)
        try:
            z = np.asarray(z, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise KalmanError(f"measurement z must be {self.dim_z} numbers, got {z!r}") from None
        self.x, self.P, info = sequential_update(
            self.x, self.P, z, R_use, self.H, influence, self.robust_components, self.method,
            self._alpha_f(), threshold if influence is not None else None)
        return info
