# SPDX-License-Identifier: Apache-2.0
"""builtin_interfaces/Time and std_msgs/Header <-> float seconds or integer nanoseconds."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from msg_adapters.backend import CLOCK, HEADER, RCLPY, TIME, Backend
from msg_adapters.errors import MessageError

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time
    from std_msgs.msg import Header

NS = 1_000_000_000


def stamp_to_seconds(stamp: Time) -> float:
    """Seconds since the epoch of a `builtin_interfaces/Time`."""
    try:
        return float(stamp.sec) + float(stamp.nanosec) * 1e-9
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"stamp is not a builtin_interfaces/Time ({exc})") from exc


def stamp_to_ns(stamp: Time) -> int:
    """Nanoseconds since the epoch of a `builtin_interfaces/Time` (exact; bags key frames by it)."""
    try:
        return int(stamp.sec) * NS + int(stamp.nanosec)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"stamp is not a builtin_interfaces/Time ({exc})") from exc


def seconds_to_stamp(seconds: float, backend: Backend = RCLPY) -> Time:
    """`builtin_interfaces/Time` for non-negative seconds (nanoseconds rounded, carried into sec)."""
    if not math.isfinite(seconds) or seconds < 0:
        raise MessageError(f"stamp seconds must be finite and >= 0, got {seconds}")
    sec = int(seconds)
    nanosec = round((seconds - sec) * 1e9)
    if nanosec >= NS:
        sec, nanosec = sec + 1, nanosec - NS
    return backend.cls(TIME)(sec=sec, nanosec=nanosec)


def ns_to_stamp(stamp_ns: int, backend: Backend = RCLPY) -> Time:
    """`builtin_interfaces/Time` for non-negative integer nanoseconds."""
    if stamp_ns < 0:
        raise MessageError(f"stamp must be >= 0 ns, got {stamp_ns}")
    return backend.cls(TIME)(sec=int(stamp_ns) // NS, nanosec=int(stamp_ns) % NS)


def _is_time(stamp: object) -> bool:
    return hasattr(stamp, "sec") and hasattr(stamp, "nanosec")


def header(stamp: Time | float, frame_id: str = "", backend: Backend = RCLPY) -> Header:
    """A `std_msgs/Header` from a Time message or float seconds."""
    if not _is_time(stamp):
        stamp = seconds_to_stamp(float(stamp), backend)
    return backend.cls(HEADER)(stamp=stamp, frame_id=frame_id)


def header_of(msg: Any) -> Header:
    """The header of a stamped message (outputs are stamped with their input's header)."""
    hdr = getattr(msg, "header", None)
    if hdr is None or not _is_time(getattr(hdr, "stamp", None)):
        raise MessageError(f"{type(msg).__name__} has no std_msgs/Header")
    return hdr


def msg_seconds(msg: Any) -> float:
    """Header stamp of a stamped message, seconds."""
    return stamp_to_seconds(header_of(msg).stamp)


def msg_ns(msg: Any) -> int:
    """Header stamp of a stamped message, integer nanoseconds."""
    return stamp_to_ns(header_of(msg).stamp)


def serialized_seconds(raw: bytes) -> float:
    """Header stamp (seconds) of a CDR-serialized stamped message, without decoding the rest of it.

    A stamped message starts with its `std_msgs/Header`, whose first field is the stamp: after the 4-byte
    CDR encapsulation header (byte 1: 0 big-endian, 1 little-endian) come `int32 sec` and `uint32 nanosec`.
    Used where only the stamp of a large message (a camera image) is needed.
    """
    data = bytes(raw[:12])
    if len(data) < 12 or data[0] != 0 or data[1] not in (0, 1):
        raise MessageError(f"{len(raw)} bytes are not a CDR-serialized stamped message")
    order = "little" if data[1] == 1 else "big"
    sec = int.from_bytes(data[4:8], order, signed=True)
    nanosec = int.from_bytes(data[8:12], order, signed=False)
    return sec + nanosec * 1e-9


def clock_msg(stamp: Time, backend: Backend = RCLPY) -> Any:
    """`rosgraph_msgs/Clock` for a simulated time (the harness replays a bag on /clock)."""
    return backend.cls(CLOCK)(clock=stamp)
