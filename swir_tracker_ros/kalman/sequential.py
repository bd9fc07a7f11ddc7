# SPDX-License-Identifier: Apache-2.0
"""Sequential scalar processing of a vector measurement (paper 000 §IV-A, paper 001 §2.10)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman.influence import Influence
from swir_tracker_ros.kalman.statlin import METHODS, scalar_step


@dataclass(frozen=True)
class UpdateInfo:
    """What one measurement update did, per measurement component (length m arrays).

    ``used[j]`` is False for a component that was skipped (non-finite value or a non-finite result); its
    innovation, normalised residual and weight are reported as 0, 0 and 0. With a non-diagonal R the
    components are the decorrelated ones (L^-1 z with R = L L').
    """

    coasted: bool  # no component was used: the step is prediction only (z=None, or nothing finite)
    nonfinite: bool  # z held non-finite values that were skipped as missed measurements
    used: np.ndarray  # bool (m,)
    innovations: np.ndarray  # eps_j = y_j - h_j x (sequential, i.e. after components < j)
    normalized: np.ndarray  # u_j = eps_j / s_j, s_j = sqrt(h_j M h_j' + r_j) (paper 000 eq. 31)
    weights: np.ndarray  # psi(u_j)/u_j (paper 000 eq. 32); 1 for components given the standard update
    alphas: np.ndarray  # SL gain coefficient used (paper 001 eq. 23); 1 for the standard update
    threshold: float | None  # influence threshold used for the robust components (None: standard filter)

    @property
    def max_abs_normalized(self) -> float:
        return float(np.max(np.abs(self.normalized))) if self.normalized.size else 0.0


def coast_info(m: int, threshold: float | None, nonfinite: bool = False) -> UpdateInfo:
    z = np.zeros(m)
    return UpdateInfo(True, nonfinite, np.zeros(m, dtype=bool), z, z.copy(), z.copy(), z.copy(), threshold)


def all_finite(a: np.ndarray) -> bool:
    """``np.isfinite(a).all()`` at half its per-call cost on the filter's small arrays (count_nonzero skips
    the generic reduction machinery of ndarray.all)."""
    return np.count_nonzero(np.isfinite(a)) == a.size


def check_matrices(x: np.ndarray, P: np.ndarray, H: np.ndarray, R: np.ndarray) -> None:
    """Shape and finiteness checks; raises KalmanError with a sentence naming the problem."""
    n = x.shape[0] if x.ndim == 1 else -1
    if x.ndim != 1:
        raise KalmanError(f"state x must be a 1-D vector, got shape {x.shape}")
    if P.shape != (n, n):
        raise KalmanError(f"covariance P must be {n}x{n}, got shape {P.shape}")
    if H.ndim != 2 or H.shape[1] != n:
        raise KalmanError(f"observation matrix H must be m x {n}, got shape {H.shape}")
    m = H.shape[0]
    if R.shape != (m, m):
        raise KalmanError(f"measurement covariance R must be {m}x{m}, got shape {R.shape}")
    for name, a in (("x", x), ("P", P), ("H", H), ("R", R)):
        if not all_finite(a):
            raise KalmanError(f"{name} holds non-finite values")
    if np.count_nonzero(R.diagonal() <= 0):
        raise KalmanError(f"measurement variances diag(R) must be positive, got {np.diag(R)}")


def sequential_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray, H: np.ndarray,
                      influence: Influence | None = None, robust_components: Sequence[int] | None = None,
                      method: str = "A2", alpha_f: float | None = None,
                      threshold: float | None = None) -> tuple[np.ndarray, np.ndarray, UpdateInfo]:
    """Process z component by component as scalar observations (paper 000 §IV-A, paper 001 §2.10).

    Non-finite components of z are skipped (missed measurement) and never reach the state. A non-diagonal R
    is decorrelated first: with R = L L' (Cholesky), z' = L^-1 z, H' = L^-1 H, R' = I (paper 000, text
    before eq. 31). Components listed in ``robust_components`` (all when None) get the M-robust update of
    ``method`` with ``influence`` (``threshold`` overrides its threshold); the others the standard update.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.atleast_2d(np.asarray(H, dtype=float))
    R = np.atleast_2d(np.asarray(R, dtype=float))
    z = np.atleast_1d(np.asarray(z, dtype=float))
    check_matrices(x, P, H, R)
    m = H.shape[0]
    if z.shape != (m,):
        raise KalmanError(f"measurement z must have {m} components, got shape {z.shape}")
    if method not in METHODS:
        raise KalmanError(f"unknown method {method!r}; choose one of {METHODS}")
    robust = set(range(m)) if robust_components is None else {int(j) for j in robust_components}
    if any(j < 0 or j >= m for j in robust):
        raise KalmanError(f"robust_components {sorted(robust)} out of range for {m} measurement components")
    if threshold is not None:
        if not (math.isfinite(threshold) and threshold > 0):
            raise KalmanError(f"threshold must be a positive finite number, got {threshold!r}")
        if influence is not None:
            influence = influence.with_threshold(threshold)
    used_threshold = influence.threshold if (influence is not None and robust and method != "A1") else None

    finite = np.isfinite(z)
    if m and np.count_nonzero(finite) == m:  # the usual case: every component, no fancy-indexed copies
        nonfinite = False
        idx: Sequence[int] | np.ndarray = range(m)
        zs, Rs = z, R
        Hs = H if H.flags.c_contiguous else np.ascontiguousarray(H)  # rows laid out as those of H[idx]
    else:
        nonfinite = not bool(finite.all())
        idx = np.flatnonzero(finite)
        if idx.size == 0:
            return x.copy(), P.copy(), coast_info(m, used_threshold, nonfinite)
        zs, Hs, Rs = z[idx], H[idx], R[np.ix_(idx, idx)]
    # off-diagonal nonzeros (R is finite with a positive diagonal: check_matrices)
    if np.count_nonzero(Rs) != np.count_nonzero(Rs.diagonal()):
        try:
            L = np.linalg.cholesky(Rs)
        except np.linalg.LinAlgError:
            raise KalmanError("measurement covariance R is not positive definite") from None
        zs = np.linalg.solve(L, zs)
        Hs = np.linalg.solve(L, Hs)
        rs: list[float] = [1.0] * len(idx)
    else:
        rs = Rs.diagonal().tolist()
    ys: list[float] = zs.tolist()  # Python floats: the same IEEE operations as float64 scalars, faster

    used = np.zeros(m, dtype=bool)
    innov, norm, weights, alphas = (np.zeros(m) for _ in range(4))
    for pos, j in enumerate(idx):
        is_robust = j in robust
        xn, Pn, eps, _, u, w, alpha = scalar_step(x, P, ys[pos], Hs[pos], rs[pos],
                                                  influence if is_robust else None,
                                                  method if is_robust else "A1", alpha_f)
        if not (all_finite(xn) and all_finite(Pn)):
            nonfinite = True  # overflow from an absurd value: treat as missed, keep the state clean
            continue
        x, P = xn, Pn
        used[j] = True
        innov[j], norm[j], weights[j], alphas[j] = eps, u, w, alpha
    coasted = not np.count_nonzero(used)
    return x, P, UpdateInfo(coasted, nonfinite, used, innov, norm, weights, alphas, used_threshold)
