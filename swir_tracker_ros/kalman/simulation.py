# SPDX-License-Identifier: Apache-2.0
"""Monte Carlo radar simulation of paper 001 §4 / dissertation §6.2.1, vectorised over runs."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman.influence import Huber, Influence
from swir_tracker_ros.kalman.statlin import METHODS, alpha_fixed


@dataclass(frozen=True)
class Scenario:
    """Truth trajectory, noise and filter set-up of one simulation.

    Stated by the papers: T, Q, R, the CV filter model, the delta-contaminated noise, init eq. 32 / 6.7, CEE.
    Our choices (the papers leave them open): x0, v0, n_steps, the manoeuvre profile, sigma_o2, the start-up.
    ``manoeuvres`` is a tuple of (t_start_s, t_end_s, acceleration_m_s2); the acceleration is 0 elsewhere.
    """

    name: str
    x0: float = 1000.0
    v0: float = 50.0
    n_steps: int = 1000
    manoeuvres: tuple[tuple[float, float, float], ...] = ()
    T: float = 0.02
    Q: float = 0.1
    R: float = 1.0
    sigma_o2: float = 1000.0
    startup: str = "repeated_median"  # "eq32": raw two-point start; "repeated_median": line over n_start
    n_start: int = 15
    lost_threshold: float = 10.0  # a run is "lost" if its position RMSE after start-up exceeds this x sigma_n


def acceleration_profile(sc: Scenario) -> np.ndarray:
    """a_k for k = 0..n_steps-1, piecewise constant (paper 001 eq. 29)."""
    t = np.arange(sc.n_steps) * sc.T
    a = np.zeros(sc.n_steps)
    for t0, t1, acc in sc.manoeuvres:
        a[(t >= t0 - 1e-12) & (t < t1 - 1e-12)] = acc
    return a


def trajectory(sc: Scenario) -> np.ndarray:
    """True positions x_k, k = 1..n_steps, exact piecewise-constant-acceleration kinematics (eq. 29)."""
    a = acceleration_profile(sc)
    x = np.empty(sc.n_steps)
    pos, vel = sc.x0, sc.v0
    for k in range(sc.n_steps):
        pos = pos + vel * sc.T + 0.5 * a[k] * sc.T**2
        vel = vel + a[k] * sc.T
        x[k] = pos
    return x


@dataclass(frozen=True)
class NoiseDraws:
    """Common random numbers: the same uniforms and normals serve every delta (paired comparisons)."""

    u: np.ndarray  # U(0, 1), shape (runs, n)
    n: np.ndarray  # N(0, 1), shape (runs, n)

    def noise(self, delta: float, sigma_o2: float) -> np.ndarray:
        """v = N(0, 1) if u > delta else N(0, sigma_o2) (paper 001 eq. 15, generator as in §4)."""
        return np.where(self.u > delta, self.n, math.sqrt(sigma_o2) * self.n)


def draw_noise(runs: int, n_steps: int, seed: int) -> NoiseDraws:
    rng = np.random.default_rng(seed)
    return NoiseDraws(rng.random((runs, n_steps)), rng.standard_normal((runs, n_steps)))


def repeated_median_line(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Siegel's repeated-median line fit (breakdown 50 %) per row of y (runs, n): (slope, intercept)."""
    dt = t[None, :] - t[:, None]
    np.fill_diagonal(dt, np.nan)
    slopes = (y[:, None, :] - y[:, :, None]) / dt[None]
    b = np.nanmedian(np.nanmedian(slopes, axis=2), axis=1)
    a = np.median(y - b[:, None] * t[None, :], axis=1)
    return b, a


def start_state(y: np.ndarray, sc: Scenario) -> tuple[int, np.ndarray, np.ndarray]:
    """Initial estimate and covariance after the first k0 samples; returns (k0, x_hat (runs, 2), P0 (3,)).

    "eq32": x = [y2, (y2 - y1)/T], P0 = [[1, 1/T], [1/T, Q + 2/T^2]] (paper 001 eq. 32, dissertation 6.7).
    "robust": the same P0, state from a repeated-median line through the first n_start samples, evaluated at
    the last of them, so one or two outliers among them cannot spoil the start (our protection).
    """
    T, Q = sc.T, sc.Q
    P0 = np.array([1.0, 1.0 / T, Q + 2.0 / T**2])  # p00, p01, p11
    if sc.startup == "eq32":
        return 2, np.stack([y[:, 1], (y[:, 1] - y[:, 0]) / T], axis=1), P0
    if sc.startup == "repeated_median":
        k0 = sc.n_start
        t = np.arange(k0) * T
        b, a = repeated_median_line(t, y[:, :k0])
        return k0, np.stack([a + b * t[-1], b], axis=1), P0
    raise KalmanError(f"unknown start-up {sc.startup!r}; choose 'eq32' or 'repeated_median'")


def batch_filter(y: np.ndarray, x0: np.ndarray, P0: np.ndarray, sc: Scenario, method: str,
                 influence: Influence, alpha_f: float | None = None) -> np.ndarray:
    """Run A1-A4 on every row of y (runs, n) from (x0, P0); returns the position estimates (runs, n).

    Same maths as `statlin.scalar_update` with h = [1, 0], written out for the 2-state CV model:
    predict x = F x, M = F P F' + G Q G' (eq. 24); s^2 = p00 + R; K0 = M h'/s^2; x += K0 eps c;
    P = (1 - alpha) M + alpha Joseph(K0) (= (I - alpha K0 h) M, eq. 22).
    """
    if method not in METHODS:
        raise KalmanError(f"unknown method {method!r}")
    runs, n = y.shape
    T, Q, r = sc.T, sc.Q, sc.R
    x = x0[:, 0].copy()
    v = x0[:, 1].copy()
    p00 = np.full(runs, P0[0])
    p01 = np.full(runs, P0[1])
    p11 = np.full(runs, P0[2])
    out = np.empty((runs, n))
    for k in range(n):
        # prediction (paper 001 eq. 24)
        x = x + T * v
        p00, p01, p11 = p00 + 2 * T * p01 + T * T * p11, p01 + T * p11, p11 + Q
        s2 = p00 + r
        a, b = p00 / s2, p01 / s2  # K0
        eps = y[:, k] - x
        if method == "A1":
            alpha, c = 1.0, 1.0
        else:
            w = np.asarray(influence.weight(eps / np.sqrt(s2)))
            if method == "A2":
                alpha, c = w, w * w
            elif method == "A4":
                alpha, c = w, w
            else:
                alpha, c = alpha_f, alpha_f * w
        x = x + a * eps * c
        v = v + b * eps * c
        # Joseph form with K0: (I - K0 h) M (I - K0 h)' + K0 r K0'
        j00 = (1 - a) ** 2 * p00 + r * a * a
        j01 = (1 - a) * (p01 - b * p00) + r * a * b
        j11 = b * b * p00 - 2 * b * p01 + p11 + r * b * b
        p00 = (1 - alpha) * p00 + alpha * j00
        p01 = (1 - alpha) * p01 + alpha * j01
        p11 = (1 - alpha) * p11 + alpha * j11
        out[:, k] = x
    return out


def cee_curve(est: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """CEE(k) = (1/k) sum_{i<=k} |x_hat_i - x_i|^2 / |x_i|^2 (paper 001 eq. 33 with the index typo fixed)."""
    rel = (est - truth[None, :]) ** 2 / truth[None, :] ** 2
    return np.cumsum(rel, axis=1) / np.arange(1, est.shape[1] + 1)[None, :]


@dataclass
class MethodResult:
    """Per-run outcomes of one filter at one delta."""

    cee: np.ndarray  # final CEE(N) per run
    rmse: np.ndarray  # position RMSE per run
    lost: np.ndarray  # bool per run
    cee_curve_mean: np.ndarray  # mean CEE(k) over kept (not lost) runs

    @property
    def lost_rate(self) -> float:
        return float(np.mean(self.lost))

    def kept(self) -> np.ndarray:
        return self.cee[~self.lost]


@dataclass
class DeltaResult:
    delta: float
    methods: dict[str, MethodResult] = field(default_factory=dict)


def run_delta(sc: Scenario, draws: NoiseDraws, delta: float, truth: np.ndarray,
              methods: Sequence[str] = METHODS, influence: Influence | None = None,
              alpha_f: float | None = None) -> DeltaResult:
    """All filters on the same noise at one contamination degree. A3 uses alpha_f = 1 - delta (eq. 26)."""
    influence = influence or Huber()
    y = truth[None, :] + draws.noise(delta, sc.sigma_o2)
    k0, x0, P0 = start_state(y, sc)
    tr = truth[k0:]
    res = DeltaResult(delta)
    for mth in methods:
        af = (alpha_fixed(delta) if alpha_f is None else alpha_f) if mth == "A3" else None
        est = batch_filter(y[:, k0:], x0, P0, sc, mth, influence, af)
        err = est - tr[None, :]
        rmse = np.sqrt(np.mean(err**2, axis=1))
        lost = ~np.isfinite(rmse) | (rmse > sc.lost_threshold * math.sqrt(sc.R))
        curve = cee_curve(est, tr)
        kept_curve = curve[~lost].mean(axis=0) if np.any(~lost) else np.full(curve.shape[1], np.nan)
        res.methods[mth] = MethodResult(curve[:, -1], rmse, lost, kept_curve)
    return res


def run_scenario(sc: Scenario, deltas: Sequence[float], runs: int, seed: int,
                 methods: Sequence[str] = METHODS) -> list[DeltaResult]:
    truth = trajectory(sc)
    draws = draw_noise(runs, sc.n_steps, seed)
    return [run_delta(sc, draws, d, truth, methods) for d in deltas]
