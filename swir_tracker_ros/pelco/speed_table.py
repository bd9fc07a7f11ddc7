# SPDX-License-Identifier: Apache-2.0
"""Pelco-D speed byte <-> angular speed (deg/s): heads are not linear in degrees per second."""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from swir_tracker_ros.errors import PelcoError
from swir_tracker_ros.pelco.codec import MAX_SPEED, TURBO

# A typical mid-range head (slow creep at byte 1, about 40 deg/s at 0x3F, turbo 60 deg/s). Replace with the
# table of the real head: measure deg/s at a few bytes (pelco_sim uses the same default).
DEFAULT_BYTES: tuple[float, ...] = (1.0, 8.0, 16.0, 24.0, 32.0, 40.0, 48.0, 56.0, 63.0)
DEFAULT_DPS: tuple[float, ...] = (0.1, 0.5, 2.0, 5.0, 10.0, 16.0, 24.0, 32.0, 40.0)
DEFAULT_TURBO_DPS = 60.0


@dataclass(frozen=True)
class SpeedTable:
    """Piecewise-linear speed curve through (0, 0) and the breakpoints (byte, deg/s), both increasing."""

    bytes_: tuple[float, ...] = DEFAULT_BYTES
    dps: tuple[float, ...] = DEFAULT_DPS
    turbo_dps: float = DEFAULT_TURBO_DPS

    def __post_init__(self) -> None:
        problem = table_problem(self.bytes_, self.dps, self.turbo_dps)
        if problem:
            raise PelcoError(problem)
        object.__setattr__(self, "_xs", (0.0, *map(float, self.bytes_)))
        object.__setattr__(self, "_ys", (0.0, *map(float, self.dps)))

    @property
    def max_dps(self) -> float:
        """Speed at byte 0x3F (the curve is held flat past its last breakpoint)."""
        return self.speed(MAX_SPEED)

    def speed(self, byte: int) -> float:
        """deg/s commanded by a speed byte (0 -> 0, 0xFF -> turbo)."""
        if byte == TURBO:
            return self.turbo_dps
        return _interp(float(byte), self._xs, self._ys)

    def byte_for(self, dps: float, lo: int = 1, hi: int = MAX_SPEED) -> int:
        """Speed byte in [lo, hi] whose table speed is nearest to |dps|; 0 for dps == 0."""
        dps = abs(dps)
        if dps == 0.0:
            return 0
        x = _interp(dps, self._ys, self._xs) if dps < self._ys[-1] else self._xs[-1]
        b0 = int(x)
        cands = [b for b in (b0, b0 + 1) if lo <= b <= hi] or [min(max(b0, lo), hi)]
        return min(cands, key=lambda b: abs(self.speed(b) - dps))


def table_problem(bytes_: Sequence[float], dps: Sequence[float], turbo_dps: float) -> str:
    """Why a speed table is invalid ('' when it is fine)."""
    if len(bytes_) != len(dps) or not bytes_:
        return f"speed table needs as many bytes as speeds (>= 1), got {len(bytes_)} and {len(dps)}"
    if any(not 0 < b <= MAX_SPEED for b in bytes_):
        return f"speed table bytes must lie in (0, 63], got {list(bytes_)}"
    if any(b2 <= b1 for b1, b2 in itertools.pairwise(bytes_)):
        return f"speed table bytes must increase strictly, got {list(bytes_)}"
    if any(v <= 0 for v in dps) or any(v2 <= v1 for v1, v2 in itertools.pairwise(dps)):
        return f"speed table deg/s must be positive and increase strictly, got {list(dps)}"
    if turbo_dps < dps[-1]:
        return f"turbo speed {turbo_dps} deg/s is below the table's top speed {dps[-1]}"
    return ""


def _interp(x: float, xs: Sequence[float], ys: Sequence[float]) -> float:
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    i = bisect.bisect_right(xs, x)
    x0, x1, y0, y1 = xs[i - 1], xs[i], ys[i - 1], ys[i]
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


def parse_table(text: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """'1:0.1,8:0.5,...' (byte:deg/s pairs) -> (bytes, deg/s); `PelcoError` on malformed text."""
    try:
        pairs = [p.split(":") for p in text.replace(" ", "").split(",") if p]
        xs = tuple(float(b) for b, _ in pairs)
        ys = tuple(float(v) for _, v in pairs)
    except ValueError as exc:
        raise PelcoError(f"speed table {text!r} is not 'byte:deg_per_s,...' ({exc})") from exc
    return xs, ys
