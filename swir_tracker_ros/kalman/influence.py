# SPDX-License-Identifier: Apache-2.0
"""Influence functions psi(u), weights psi(u)/u, slopes psi'(u) (paper 000 eq. 26, dissertation 5.82-5.87)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Protocol, runtime_checkable

import numpy as np

from swir_tracker_ros.errors import KalmanError

ArrayLike = float | np.ndarray


@runtime_checkable
class Influence(Protocol):
    """What the robust update needs from an influence function.

    All methods are vectorised over ``u`` (a float or an ndarray of normalised residuals). Every
    implementation here is normalised to unit slope at the origin, ``psi'(0) = 1``, so that
    ``weight(u) = psi(u)/u`` lies in [0, 1] and equals 1 near 0 (efficiency robustness, paper 001 §2.7).
    """

    threshold: float

    def psi(self, u: ArrayLike) -> ArrayLike: ...

    def weight(self, u: ArrayLike) -> ArrayLike: ...

    def dpsi(self, u: ArrayLike) -> ArrayLike: ...

    def with_threshold(self, k: float) -> Influence: ...


def _positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise KalmanError(f"influence parameter {name} must be a positive finite number, got {value!r}")


def _weight_from_psi(psi_u: np.ndarray, u: np.ndarray) -> np.ndarray:
    """psi(u)/u with the eq. 32 (paper 000) convention: weight 1 where u == 0."""
    out = np.ones_like(u, dtype=float)
    nz = u != 0
    out[nz] = psi_u[nz] / u[nz]
    return out


def _ret(value: np.ndarray, like: ArrayLike) -> ArrayLike:
    return float(value) if np.ndim(like) == 0 else value


HUBER_K = 1.5
"""Huber threshold Delta of paper 000 eq. 26 / paper 001 eq. 14 ("Huber 1.5"); the package's one default."""


@dataclass(frozen=True)
class Huber:
    """Huber's psi = min(|u|, k) sgn(u) (paper 000 eq. 26, paper 001 eq. 14); k = 1.5 is "Huber 1.5"."""

    k: float = field(default=HUBER_K, metadata={"doc": "saturation threshold Delta", "min": 0.0})

    def __post_init__(self) -> None:
        _positive("k", self.k)

    @property
    def threshold(self) -> float:
        return self.k

    def psi(self, u: ArrayLike) -> ArrayLike:
        a = np.asarray(u, dtype=float)
        return _ret(np.clip(a, -self.k, self.k), u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        """psi(u)/u: exactly 1.0 for |u| <= k, k/|u| beyond (paper 000 eq. 32, paper 001 eq. 28)."""
        if isinstance(u, float):  # fast path for the per-component filter update
            au = abs(u)
            return 1.0 if au <= self.k else self.k / au
        a = np.abs(np.asarray(u, dtype=float))
        out = np.ones_like(a)
        big = a > self.k
        out[big] = self.k / a[big]
        return _ret(out, u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        a = np.abs(np.asarray(u, dtype=float))
        return _ret((a <= self.k).astype(float), u)

    def with_threshold(self, k: float) -> Huber:
        k = float(k)
        # the same k (the flat part of the adaptive threshold map): no new object (replace() costs ~4 us)
        return self if k == self.k else replace(self, k=k)


@dataclass(frozen=True)
class Clipping:
    """Cut-off (censoring) psi = u for |u| <= k, else 0 (dissertation eq. 5.82, Fig. 5.2 uses k = 3)."""

    k: float = field(default=3.0, metadata={"doc": "cut-off threshold Delta", "min": 0.0})

    def __post_init__(self) -> None:
        _positive("k", self.k)

    @property
    def threshold(self) -> float:
        return self.k

    def psi(self, u: ArrayLike) -> ArrayLike:
        a = np.asarray(u, dtype=float)
        return _ret(np.where(np.abs(a) <= self.k, a, 0.0), u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        a = np.asarray(u, dtype=float)
        return _ret((np.abs(a) <= self.k).astype(float), u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        return self.weight(u)

    def with_threshold(self, k: float) -> Clipping:
        return replace(self, k=float(k))


@dataclass(frozen=True)
class Hampel:
    """Hampel's three-part redescending psi (dissertation eq. 5.83; Fig. 5.3: a = 1.7, b = 3.4, c = 8.5).

    psi = u (|u| <= a); a sgn(u) (a < |u| <= b); a sgn(u) (c - |u|)/(c - b) (b < |u| <= c); 0 beyond c.
    """

    a: float = field(default=1.7, metadata={"doc": "end of the linear part", "min": 0.0})
    b: float = field(default=3.4, metadata={"doc": "end of the flat part", "min": 0.0})
    c: float = field(default=8.5, metadata={"doc": "rejection point", "min": 0.0})

    def __post_init__(self) -> None:
        for name in ("a", "b", "c"):
            _positive(name, getattr(self, name))
        if not self.a <= self.b < self.c:
            raise KalmanError(f"Hampel needs a <= b < c, got a={self.a}, b={self.b}, c={self.c}")

    @property
    def threshold(self) -> float:
        return self.a

    def psi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        a = np.abs(x)
        s = np.sign(x)
        out = np.where(a <= self.a, x, 0.0)
        out = np.where((a > self.a) & (a <= self.b), self.a * s, out)
        out = np.where((a > self.b) & (a <= self.c), self.a * s * (self.c - a) / (self.c - self.b), out)
        return _ret(out, u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        x = np.atleast_1d(np.asarray(u, dtype=float))
        return _ret(_weight_from_psi(np.atleast_1d(self.psi(x)), x).reshape(np.shape(u)), u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        a = np.abs(np.asarray(u, dtype=float))
        out = np.where(a <= self.a, 1.0, 0.0)
        out = np.where((a > self.b) & (a <= self.c), -self.a / (self.c - self.b), out)
        return _ret(out, u)

    def with_threshold(self, k: float) -> Hampel:
        """Scale (a, b, c) so that a = k, keeping the shape."""
        f = float(k) / self.a
        return replace(self, a=self.a * f, b=self.b * f, c=self.c * f)


@dataclass(frozen=True)
class Andrews:
    """Andrews' sine psi = k sin(u/k) for |u| <= k pi, else 0 (dissertation eq. 5.84, 1.5 < k < 2).

    The dissertation prints sin(u/k); the factor k gives psi'(0) = 1 (weight 1 at u = 0), which the
    statistically linearised gain needs to reduce to the Kalman gain for small residuals.
    """

    k: float = field(default=1.5, metadata={"doc": "Delta; rejection point k*pi", "min": 0.0})

    def __post_init__(self) -> None:
        _positive("k", self.k)

    @property
    def threshold(self) -> float:
        return self.k

    def psi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(np.where(np.abs(x) <= self.k * math.pi, self.k * np.sin(x / self.k), 0.0), u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        x = np.atleast_1d(np.asarray(u, dtype=float))
        return _ret(_weight_from_psi(np.atleast_1d(self.psi(x)), x).reshape(np.shape(u)), u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(np.where(np.abs(x) <= self.k * math.pi, np.cos(x / self.k), 0.0), u)

    def with_threshold(self, k: float) -> Andrews:
        return replace(self, k=float(k))


@dataclass(frozen=True)
class Tukey:
    """Tukey's biweight psi = u (1 - (u/k)^2)^2 for |u| <= k, else 0 (dissertation eq. 5.85).

    k = 4.685 gives 95 % efficiency under the normal."""

    k: float = field(default=4.685, metadata={"doc": "rejection point Delta", "min": 0.0})

    def __post_init__(self) -> None:
        _positive("k", self.k)

    @property
    def threshold(self) -> float:
        return self.k

    def psi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(x * np.asarray(self.weight(x)), u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        t = 1.0 - (x / self.k) ** 2
        return _ret(np.where(np.abs(x) <= self.k, t * t, 0.0), u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        t = (x / self.k) ** 2
        return _ret(np.where(np.abs(x) <= self.k, (1.0 - t) * (1.0 - 5.0 * t), 0.0), u)

    def with_threshold(self, k: float) -> Tukey:
        return replace(self, k=float(k))


@dataclass(frozen=True)
class Smith:
    """Smith's psi = u (1 - (u/k)^2) for |u| <= k, else 0 (dissertation eq. 5.87, normalised to psi'(0) = 1).

    The dissertation prints u (k^2 - u^2), i.e. this psi times k^2; no parameter value is given there.
    """

    k: float = field(default=3.0, metadata={"doc": "rejection point Delta", "min": 0.0})

    def __post_init__(self) -> None:
        _positive("k", self.k)

    @property
    def threshold(self) -> float:
        return self.k

    def psi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(x * np.asarray(self.weight(x)), u)

    def weight(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(np.where(np.abs(x) <= self.k, 1.0 - (x / self.k) ** 2, 0.0), u)

    def dpsi(self, u: ArrayLike) -> ArrayLike:
        x = np.asarray(u, dtype=float)
        return _ret(np.where(np.abs(x) <= self.k, 1.0 - 3.0 * (x / self.k) ** 2, 0.0), u)

    def with_threshold(self, k: float) -> Smith:
        return replace(self, k=float(k))


INFLUENCES: dict[str, type] = {
    "huber": Huber, "clipping": Clipping, "hampel": Hampel, "andrews": Andrews, "tukey": Tukey,
    "smith": Smith,
}


def make_influence(name: str, **params: float) -> Influence:
    """Build an influence function by name: huber, clipping, hampel, andrews, tukey or smith."""
    try:
        cls = INFLUENCES[name.lower()]
    except KeyError:
        known = sorted(INFLUENCES)
        raise KalmanError(f"unknown influence function {name!r}; choose one of {known}") from None
    return cls(**params)
