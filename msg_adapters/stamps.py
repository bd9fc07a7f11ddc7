# SPDX-License-Identifier: Apache-2.0
"""builtin_interfaces/Time and std_msgs/Header <-> float seconds."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from std_msgs.msg import Header

from msg_adapters.errors import MessageError


def stamp_to_seconds(stamp: Time) -> float:
    """Seconds since the epoch of a `builtin_interfaces/Time`."""
    try:
        return float(stamp.sec) + float(stamp.nanosec) * 1e-9
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"stamp is not a builtin_interfaces/Time ({exc})") from exc


def seconds_to_stamp(seconds: float) -> Time:
    """`builtin_interfaces/Time` for non-negative seconds (nanoseconds rounded, carried into sec)."""
    if not math.isfinite(seconds) or seconds < 0:
        raise MessageError(f"stamp seconds must be finite and >= 0, got {seconds}")
    sec = int(seconds)
    nanosec = round((seconds - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return Time(sec=sec, nanosec=nanosec)


def header(stamp: Time | float, frame_id: str = "") -> Header:
    """A `std_msgs/Header` from a Time message or float seconds."""
    if not isinstance(stamp, Time):
        stamp = seconds_to_stamp(float(stamp))
    return Header(stamp=stamp, frame_id=frame_id)
