# SPDX-License-Identifier: Apache-2.0
"""Parameters of the positioner bridge (flat dataclass, docs/interfaces.md "Parameters")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.pelco.speed_table import DEFAULT_BYTES, DEFAULT_DPS, DEFAULT_TURBO_DPS, table_problem


def _m(doc: str, lo: float | None = None, hi: float | None = None) -> dict:
    """Field metadata of docs/interfaces.md: doc, optional min / max."""
    meta: dict = {"doc": doc}
    if lo is not None:
        meta["min"] = lo
    if hi is not None:
        meta["max"] = hi
    return meta


@dataclass
class PositionerParams:
    """Serial link, control law, speed tables, position convention and soft limits of a Pelco-D head."""

    # link
    port: str = field(default="/dev/ttyUSB0", metadata=_m(
        "pyserial URL: device path (/dev/ttyUSB0), socket://host:port (serial device server), loop://"))
    baud: int = field(default=9600, metadata=_m("line speed, 8N1 (2400, 4800 or 9600)", 1200, 115200))
    address: int = field(default=1, metadata=_m("Pelco-D address of the head (receiver id)", 1, 255))
    reconnect_min: float = field(default=0.2, metadata=_m(
        "first retry delay after the port vanished or failed to open, s", 0.01, 60.0))
    reconnect_max: float = field(default=5.0, metadata=_m(
        "retry delay ceiling (doubling backoff), s", 0.01, 600.0))
    # rates and safety
    control_rate: float = field(default=20.0, metadata=_m(
        "control loop rate, Hz (a frame is written only on change or keep-alive)", 1.0, 200.0))
    keepalive_period: float = field(default=0.5, metadata=_m(
        "re-send the current command (stop included) after this long, s; 0 = only on change", 0.0, 60.0))
    watchdog_timeout: float = field(default=0.5, metadata=_m(
        "stop when no /track/pan_tilt_error arrived for this long, s", 0.05, 10.0))
    occluded_gain: float = field(default=0.5, metadata=_m(
        "gain factor while the tracker reports 'occluded' (0 = stop)", 0.0, 1.0))
    feedback_rate: float = field(default=10.0, metadata=_m(
        "pan/tilt position query rate, Hz (0 = never query)", 0.0, 50.0))
    reply_timeout: float = field(default=0.25, metadata=_m(
        "give up waiting for a query reply after this long, s", 0.01, 5.0))
    feedback_timeout: float = field(default=1.0, metadata=_m(
        "feedback older than this is unknown (soft limits off, no JointState), s", 0.05, 60.0))
    joint_state_rate: float = field(default=10.0, metadata=_m(
        "/positioner/joint_states publish rate, Hz", 0.1, 100.0))
    require_feedback: bool = field(default=False, metadata=_m("refuse to move while the position is unknown"))
    frame_id: str = field(default="", metadata=_m("header.frame_id of the JointState messages"))
    # control law: a P/PI loop on the angular error
    kp: float = field(default=1.0, metadata=_m("proportional gain, rad/s per rad of error", 0.0, 100.0))
    ki: float = field(default=0.0, metadata=_m("integral gain, rad/s per rad*s (0 = P only)", 0.0, 100.0))
    integral_limit: float = field(default=0.1, metadata=_m(
        "bound of the integral term's contribution, rad/s", 0.0, 10.0))
    deadband: float = field(default=0.005, metadata=_m("stop when |error| is below this, rad", 0.0, 0.5))
    min_speed_byte: int = field(default=1, metadata=_m("slowest speed byte used outside the deadband", 1, 63))
    max_speed_byte: int = field(default=63, metadata=_m("fastest speed byte (0x3F)", 1, 63))
    allow_turbo: bool = field(default=False, metadata=_m(
        "use pan turbo (0xFF) when the demand is past the table's top speed"))
    max_accel: float = field(default=2.0, metadata=_m(
        "slew-rate limit of the commanded speed, rad/s^2 (0 = none; stops are never delayed)", 0.0, 100.0))
    invert_pan: bool = field(default=False, metadata=_m(
        "head mounted so that Pelco 'left' turns it right: flips pan commands and pan feedback"))
    invert_tilt: bool = field(default=False, metadata=_m(
        "flips tilt commands and tilt feedback (head mounted upside down)"))
    # speed tables: deg/s measured at the given speed bytes, linear in between, (0, 0) implied
    speed_table_bytes: list[float] = field(default_factory=lambda: list(DEFAULT_BYTES), metadata=_m(
        "speed bytes of the table breakpoints, strictly increasing, in (0, 63]"))
    pan_speed_table: list[float] = field(default_factory=lambda: list(DEFAULT_DPS), metadata=_m(
        "pan deg/s at speed_table_bytes, strictly increasing"))
    tilt_speed_table: list[float] = field(default_factory=lambda: list(DEFAULT_DPS), metadata=_m(
        "tilt deg/s at speed_table_bytes, strictly increasing"))
    pan_turbo_speed: float = field(default=DEFAULT_TURBO_DPS, metadata=_m(
        "pan deg/s at turbo (0xFF)", 0.0, 1000.0))
    # position words: angle = sign * (word / 100 - zero), wrapped to (-180, 180] deg
    pan_position_sign: int = field(default=-1, metadata=_m(
        "+1 if the pan word grows to the left (CCW from above), -1 if it grows to the right", -1, 1))
    pan_zero_deg: float = field(default=0.0, metadata=_m("pan word (deg) at our pan 0", 0.0, 360.0))
    tilt_position_sign: int = field(default=-1, metadata=_m(
        "+1 if the tilt word grows upwards, -1 if downwards (common: 0-9000 down, 36000-x up)", -1, 1))
    tilt_zero_deg: float = field(default=0.0, metadata=_m("tilt word (deg) at the horizon", 0.0, 360.0))
    # soft limits, our convention (rad); enforced when the position is known
    pan_min: float = field(default=-math.pi, metadata=_m(
        "soft pan limit, rad (pan_min = -pi and pan_max = pi: no pan limit)", -math.pi, math.pi))
    pan_max: float = field(default=math.pi, metadata=_m("soft pan limit, rad", -math.pi, math.pi))
    tilt_min: float = field(default=-math.pi / 4, metadata=_m(
        "soft tilt limit, rad", -math.pi / 2, math.pi / 2))
    tilt_max: float = field(default=math.pi / 2, metadata=_m(
        "soft tilt limit, rad", -math.pi / 2, math.pi / 2))
    limit_lookahead: float = field(default=0.3, metadata=_m(
        "block motion that would cross a soft limit within this many seconds, s", 0.0, 5.0))

    def validate(self) -> PositionerParams:
        """Raise `ParameterError` naming the first bad field; returns self."""
        for f in fields(self):
            v = getattr(self, f.name)
            lo, hi, choices = f.metadata.get("min"), f.metadata.get("max"), f.metadata.get("choices")
            if isinstance(v, float) and not math.isfinite(v):
                raise ParameterError(f"{f.name} must be finite, got {v}")
            if (lo is not None and v < lo) or (hi is not None and v > hi):
                raise ParameterError(f"{f.name} must lie in [{lo}, {hi}], got {v}")
            if choices is not None and v not in choices:
                raise ParameterError(f"{f.name} must be one of {choices}, got {v!r}")
        if not self.port:
            raise ParameterError("port must be a device path or pyserial URL, got ''")
        for name in ("pan_position_sign", "tilt_position_sign"):
            if getattr(self, name) not in (-1, 1):
                raise ParameterError(f"{name} must be -1 or +1, got {getattr(self, name)}")
        if self.min_speed_byte > self.max_speed_byte:
            raise ParameterError(f"min_speed_byte {self.min_speed_byte} exceeds max_speed_byte "
                                 f"{self.max_speed_byte}")
        if self.reconnect_min > self.reconnect_max:
            raise ParameterError(f"reconnect_min {self.reconnect_min} exceeds reconnect_max "
                                 f"{self.reconnect_max}")
        for axis in ("pan", "tilt"):
            if getattr(self, f"{axis}_min") >= getattr(self, f"{axis}_max"):
                raise ParameterError(f"{axis}_min {getattr(self, f'{axis}_min')} must be below {axis}_max "
                                     f"{getattr(self, f'{axis}_max')}")
            table = getattr(self, f"{axis}_speed_table")
            problem = table_problem(self.speed_table_bytes, table, self.pan_turbo_speed if axis == "pan" else
                                    table[-1] if table else 0.0)
            if problem:
                raise ParameterError(f"{axis}_speed_table / speed_table_bytes: {problem}")
        if 0 < self.keepalive_period < 1.0 / self.control_rate:
            raise ParameterError(f"keepalive_period {self.keepalive_period} is shorter than one control "
                                 f"period ({1.0 / self.control_rate:.3f} s)")
        return self
