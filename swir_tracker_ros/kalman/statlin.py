# SPDX-License-Identifier: Apache-2.0
"""Statistically linearised M-robust scalar update: A1-A4 of paper 001 (dissertation eq. 5.34-5.52)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman.influence import HUBER_K, Influence

METHODS = ("A1", "A2", "A3", "A4")
"""A1 standard KF; A2 variable alpha_k (paper 001 eq. 28, dissertation eq. 5.52, the recommended one);
A3 fixed alpha_f (paper 001 eq. 26/27); A4 quasi-linear A2 = paper 000 eq. 33-35 (clipped innovation)."""


def _phi(x: float) -> float:
    """Standard normal CDF."""
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def alpha_fixed(delta: float, k: float = HUBER_K, form: str = "26") -> float:
    """Fixed SL coefficient of A3.

    ``form="26"``: alpha_f = 1 - delta (paper 001 eq. 26, dissertation eq. 5.50; what the papers simulate).
    ``form="27"``: alpha_f = 2 (1 - delta) erf(k) with the Gaussian-integral erf(x) = Phi(x) - 1/2
    (paper 001 eq. 27, dissertation eq. 5.51; 0.8664 (1 - delta) for k = 1.5).
    """
    if not (0.0 <= delta < 1.0):
        raise KalmanError(f"contamination degree delta must be in [0, 1), got {delta!r}")
    if form == "26":
        return 1.0 - delta
    if form == "27":
        return 2.0 * (1.0 - delta) * (_phi(k) - 0.5)
    raise KalmanError(f"alpha_fixed form must be '26' or '27', got {form!r}")


def alpha_optimal_gaussian(sigma: float, k: float = HUBER_K) -> float:
    """Exact SL coefficient (eq. 17) E{psi_H(z) z}/sigma^2 = 2 Phi(k/sigma) - 1 for z ~ N(0, sigma^2)."""
    return 2.0 * _phi(k / sigma) - 1.0


def alpha_optimal_mixture(delta: float, sigma_o2: float, k: float = HUBER_K) -> float:
    """Exact SL coefficient (paper 001 eq. 17) under the contaminated normal (63), Huber psi."""
    num = (1 - delta) * alpha_optimal_gaussian(1.0, k) + delta * sigma_o2 * alpha_optimal_gaussian(
        math.sqrt(sigma_o2), k)
    return num / ((1 - delta) + delta * sigma_o2)


@dataclass(frozen=True)
class ScalarStep:
    """Diagnostics of one scalar (component) update."""

    innovation: float  # eps = y - h x_bar (paper 001 eq. 11)
    scale: float  # s = sqrt(h M h' + r) (paper 001 eq. 19, paper 000 eq. 31)
    normalized: float  # u = eps / s
    weight: float  # psi(u)/u (paper 000 eq. 32, paper 001 eq. 28)
    alpha: float  # SL coefficient actually used in the gain (1 for A1)


def coefficients(w: float, method: str, alpha_f: float | None) -> tuple[float, float]:
    """(alpha, c): gain coefficient alpha and state-correction factor c, with x = x_bar + K0 eps c.

    K0 = M h'/s^2 is the Kalman gain. From paper 001 eq. (23) x = x_bar + alpha K0 s psi(u) and psi(u) = w u:
    A1: alpha = 1, c = 1.   A2: alpha = w, c = w^2 (redescending: |K0 eps c| <= K0 s k).
    A3: alpha = alpha_f, c = alpha_f w.   A4: alpha = w, c = w (paper 000 eq. 33-34: K_R eps).
    """
    if method == "A1":
        return 1.0, 1.0
    if method == "A2":
        return w, w * w
    if method == "A4":
        return w, w
    if method == "A3":
        if alpha_f is None:
            raise KalmanError("method A3 needs alpha_f (see statlin.alpha_fixed)")
        return alpha_f, alpha_f * w
    raise KalmanError(f"unknown method {method!r}; choose one of {METHODS}")


@lru_cache(maxsize=4)
def _eye(n: int) -> np.ndarray:
    """Read-only n x n identity, built once (np.eye's call overhead showed in the per-frame profile)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def scalar_update(x: np.ndarray, P: np.ndarray, y: float, h: np.ndarray, r: float,
                  influence: Influence | None, method: str = "A2",
                  alpha_f: float | None = None) -> tuple[np.ndarray, np.ndarray, ScalarStep]:
    """One scalar SL-M-robust update (paper 001 eq. 11, 14, 19, 22, 23, 28; dissertation eq. 5.43-5.52).

    ``influence=None`` or ``method="A1"`` gives the standard Kalman update (paper 000 eq. 16-19).
    The covariance of the paper, P = (I - alpha K0 h) M (eq. 22), is computed in the equivalent form
    P = (1 - alpha) M + alpha [(I - K0 h) M (I - K0 h)' + K0 r K0'], a convex combination of the prior and
    the Joseph-form Kalman posterior, so it stays symmetric positive semi-definite for alpha in [0, 1].
    alpha is clamped to [0, 1]. With alpha == 1 the result is bit-identical to the standard update.

    Returns the new (x, P) and a `ScalarStep`; inputs are not modified.
    """
    x_new, P_new, eps, s, u, w, alpha = scalar_step(x, P, y, h, r, influence, method, alpha_f)
    return x_new, P_new, ScalarStep(eps, s, u, w, alpha)


def scalar_step(x: np.ndarray, P: np.ndarray, y: float, h: np.ndarray, r: float,
                influence: Influence | None, method: str,
                alpha_f: float | None) -> tuple[np.ndarray, np.ndarray, float, float, float, float, float]:
    """`scalar_update` returning its diagnostics as a plain tuple (x, P, eps, s, u, w, alpha).

    The per-component loop of `sequential.sequential_update` calls this: the frozen `ScalarStep` costs
    more to build than several of the array operations here. The operations, their order and their
    operand types are those of the standard update, so the results are the same bits; ``y`` and ``r``
    may be Python floats or numpy float64 scalars (the same IEEE operations either way).
    """
    g = P @ h  # M h'
    s2 = float(h @ g) + r
    if not (s2 > 0.0 and math.isfinite(s2)):
        raise KalmanError(f"innovation variance h M h' + r = {s2!r} is not a positive finite number")
    s = math.sqrt(s2)
    eps = float(y - h @ x)
    u = eps / s
    if influence is None or method == "A1":
        w = alpha = c = 1.0
    else:
        w = float(influence.weight(u))
        alpha, c = coefficients(w, method, alpha_f)
        alpha = min(max(alpha, 0.0), 1.0)
    K0 = g / s2
    x_new = x + K0 * (eps * c)
    # Joseph form for the Kalman gain K0: P = (I - K0 h) M (I - K0 h)' + K0 r K0'
    IKH = _eye(len(x)) - K0[:, None] * h[None, :]
    J = IKH @ P @ IKH.T + (r * K0)[:, None] * K0[None, :]
    J = 0.5 * (J + J.T)
    P_new = J if alpha == 1.0 else (1.0 - alpha) * P + alpha * J
    return x_new, P_new, eps, s, u, w, alpha
