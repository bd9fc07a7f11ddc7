# SPDX-License-Identifier: Apache-2.0
"""Pelco-D position words (hundredths of a degree) <-> joint angles in our sign convention (rad)."""

from __future__ import annotations

import math

FULL_TURN = 36000  # hundredths of a degree


def wrap_deg(deg: float) -> float:
    """Angle in (-180, 180]."""
    out = math.fmod(deg, 360.0)
    if out <= -180.0:
        out += 360.0
    elif out > 180.0:
        out -= 360.0
    return out


def raw_to_angle(raw: int, sign: int, zero_deg: float) -> float:
    """Joint angle (rad) of a position word: wrap(sign * (raw / 100 - zero_deg)).

    `sign` = +1 when the word grows in our positive direction (pan left, tilt up), -1 when it grows the
    other way (most heads: pan words grow to the right, tilt words grow downwards with 36000 - x above the
    horizon); `zero_deg` is the word (in degrees) at our zero.
    """
    return math.radians(wrap_deg(sign * (raw / 100.0 - zero_deg)))


def angle_to_raw(angle: float, sign: int, zero_deg: float) -> int:
    """Inverse of `raw_to_angle`, a word in [0, 35999]."""
    return round((sign * math.degrees(angle) + zero_deg) * 100.0) % FULL_TURN


def wrap_rad(a: float) -> float:
    return math.radians(wrap_deg(math.degrees(a)))
