# SPDX-License-Identifier: Apache-2.0
"""Adaptive Huber threshold from the peak (paper 000 eq. 38, thesis eq. 6.9); adaptive R (eq. 5.88-5.95)."""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from swir_tracker_ros.errors import KalmanError, ParameterError
from swir_tracker_ros.kalman.influence import HUBER_K, Huber, Influence
from swir_tracker_ros.paramfield import validate_params


@dataclass(frozen=True)
class ThresholdMap:
    """Piecewise-linear map peak -> Huber threshold k, given as breakpoints (peak_i, k_i), clamped outside.

    ``k = table(peak)``. A non-finite peak gives the lowest k (the detection is not trusted).
    """

    breakpoints: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        pts = self.breakpoints
        if len(pts) < 1:
            raise KalmanError("ThresholdMap needs at least one breakpoint")
        peaks = [p for p, _ in pts]
        ks = [k for _, k in pts]
        if any(not (math.isfinite(v)) for v in peaks + ks) or any(k <= 0 for k in ks):
            raise KalmanError(f"ThresholdMap breakpoints must be finite with k > 0, got {pts}")
        if any(b <= a for a, b in itertools.pairwise(peaks)):
            raise KalmanError(f"ThresholdMap peaks must be strictly increasing, got {peaks}")

    @property
    def floor_peak(self) -> float:
        """Peak of the first breakpoint: below it k is at its floor, the map's "not the target" band
        (paper 000 eq. 38: PV < 0.25; dissertation eq. 6.9: g_max < 0.125)."""
        return self.breakpoints[0][0]

    def at_floor(self, peak: float) -> bool:
        """True when `peak` lies in the floor band (below `floor_peak`, or not finite)."""
        return not (math.isfinite(peak) and peak >= self.floor_peak)

    def __call__(self, peak: float) -> float:
        if not math.isfinite(peak):
            return min(k for _, k in self.breakpoints)
        xs = [p for p, _ in self.breakpoints]
        ys = [k for _, k in self.breakpoints]
        return float(np.interp(peak, xs, ys))


PAPER000_KCF = ThresholdMap(((0.25, 0.1), (0.35, 1.5), (0.7, 1.5), (0.8, 2.5)))
"""Paper 000 eq. 38 (KCF peak value PV; identical to dissertation eq. 6.10): 0.1 below 0.25, slope 14 to 1.5
at 0.35, flat to 0.7, slope 10 to 2.5 at 0.8, 2.5 above."""

DISSERTATION_DCFCA = ThresholdMap(((0.125, 0.1), (0.15, 1.5), (0.2, 1.5), (0.25, 2.5)))
"""Dissertation eq. 6.9 (DCF-CA peak g_max): 0.1 below 0.125, slope 56 to 1.5 at 0.15, flat to 0.2,
slope 20 to 2.5 at 0.25, 2.5 above."""


def mad_scale(r: np.ndarray) -> float:
    """d_r = median(|r_i - median(r)|) / 0.6745 (dissertation eq. 5.91)."""
    r = np.asarray(r, dtype=float)
    return float(np.median(np.abs(r - np.median(r))) / 0.6745)


def m_location(r: np.ndarray, d: float, influence: Influence, m0: float = 0.0) -> float:
    """One-step M-estimate of the mean, eq. 5.92-5.93: weighted mean with w_i = psi(u)/u, u = (r_i - m0)/d."""
    r = np.asarray(r, dtype=float)
    if d <= 0:
        return float(np.mean(r))
    w = np.asarray(influence.weight((r - m0) / d), dtype=float)
    sw = float(np.sum(w))
    return float(np.sum(w * r) / sw) if sw > 0 else float(np.median(r))


def m_variance(r: np.ndarray, d: float, m: float, influence: Influence) -> float:
    """M-estimate of the variance, eq. 5.94, times d^2 (the scale factor the printed eq. 5.94 omits):
    V = d^2 mean(psi(u)^2) / mean(psi'(u))^2, u = (r_i - m)/d."""
    r = np.asarray(r, dtype=float)
    if d <= 0:
        return float(np.mean((r - m) ** 2))
    u = (r - m) / d
    den = float(np.mean(influence.dpsi(u)))
    if den <= 0:
        return float(np.mean((r - m) ** 2))
    return d * d * float(np.mean(np.asarray(influence.psi(u)) ** 2)) / (den * den)


@dataclass
class AdaptiveNoiseParams:
    """Windows and policy of the adaptive R estimator (dissertation §5.5.1, which leaves the values open)."""

    n_d: int = field(default=10, metadata={"doc": "MAD window n_d (eq. 5.91), thesis range 3-10", "min": 3,
                                           "max": 10})
    n_r: int = field(default=50, metadata={"doc": "M-estimation window n_r (eq. 5.92-5.94), 50-500", "min": 3,
                                           "max": 500})
    warmup: int = field(default=30, metadata={"doc": "residuals per component before R is adapted; nominal R "
                                                     "until then", "min": 3, "max": 500})
    k: float = field(default=HUBER_K, metadata={"doc": "Huber threshold used inside eq. 5.93-5.94",
                                                "min": 0.1, "max": 10.0})
    floor: float = field(default=0.1, metadata={"doc": "lower bound of R_hat as a fraction of the nominal R",
                                                "min": 0.0, "max": 1.0})
    formula: str = field(default="thesis", metadata={
        "doc": "thesis: R = |V - H P H'| (eq. 5.95 as printed); postfit: R = V + H P H' (the post-fit "
               "residual of an optimal filter has covariance R - H P H')", "choices": ("thesis", "postfit")})

    def validate(self) -> None:
        validate_params(self)

    def check(self) -> None:
        """Cross-field rule (run by `paramfield.validate_params` after the fields)."""
        if self.warmup < self.n_d:
            raise ParameterError(f"AdaptiveNoiseParams.warmup = {self.warmup} must be >= n_d = {self.n_d}")


class AdaptiveNoise:
    """Per-component adaptive measurement variance from post-fit residuals (dissertation eq. 5.88-5.95).

    Feed the residual r = z - H x_post after each update with ``push(z, x, P, H)`` and read ``R`` (diagonal).
    Components whose measurement was missing (non-finite or not used) are not pushed. Until a component has
    ``warmup`` residuals its nominal variance is used. R_hat_j = max(|V_j - (H P H')_jj|, floor R0_jj)
    (eq. 5.95; the abs as printed, the floor is our addition against a collapsing R).
    """

    def __init__(self, R0: np.ndarray, params: AdaptiveNoiseParams | None = None,
                 components: Sequence[int] | None = None, influence: Influence | None = None) -> None:
        self.params = params or AdaptiveNoiseParams()
        self.params.validate()
        self.R0 = np.atleast_2d(np.asarray(R0, dtype=float)).copy()
        m = self.R0.shape[0]
        self.components = tuple(range(m)) if components is None else tuple(int(j) for j in components)
        self.influence = influence or Huber(self.params.k)
        self._hist = [deque(maxlen=self.params.n_r) for _ in range(m)]
        self.R = self.R0.copy()

    def reset(self) -> None:
        for h in self._hist:
            h.clear()
        self.R = self.R0.copy()

    def estimate(self, j: int, hph: float) -> float | None:
        """R_hat for component j given (H P H')_jj, or None during warm-up."""
        hist = self._hist[j]
        if len(hist) < self.params.warmup:
            return None
        r = np.fromiter(hist, dtype=float)
        d = mad_scale(r[-self.params.n_d:])  # eq. 5.91
        m = m_location(r, d, self.influence)  # eq. 5.92-5.93, m0 = 0
        V = m_variance(r, d, m, self.influence)  # eq. 5.94 (times d^2)
        R = abs(V - hph) if self.params.formula == "thesis" else V + hph  # eq. 5.95 / corrected sign
        return max(R, self.params.floor * float(self.R0[j, j]))

    def push(self, z: np.ndarray, x: np.ndarray, P: np.ndarray, H: np.ndarray,
             used: np.ndarray | None = None) -> np.ndarray:
        """Add the post-fit residuals r = z - H x (eq. 5.88) and return the new diagonal R."""
        z = np.asarray(z, dtype=float).reshape(-1)
        res = z - H @ x
        hph = np.diag(H @ P @ H.T)
        R = self.R0.copy()
        for j in self.components:
            ok = math.isfinite(res[j]) and (used is None or bool(used[j]))
            if ok:
                self._hist[j].append(float(res[j]))
            est = self.estimate(j, float(hph[j]))
            R[j, j] = R[j, j] if est is None else est
        self.R = R
        return R
