# SPDX-License-Identifier: Apache-2.0
"""Angular error (rad) and target rate (rad/s) -> Pelco-D pan/tilt speed bytes: feed-forward plus a P/PI
law on what remains, deadband, speed table, slew, limits; joint rates (manual jog) -> speed bytes."""

from __future__ import annotations

import math
from dataclasses import dataclass

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.speed_table import SpeedTable


@dataclass(frozen=True)
class MotionCommand:
    """One pan/tilt move in Pelco terms: dir +1 = right / up, -1 = left / down, 0 = none."""

    pan_dir: int = 0
    pan_speed: int = 0
    tilt_dir: int = 0
    tilt_speed: int = 0
    zoom: int = 0  # +1 tele (in), -1 wide (out), 0 none

    @property
    def is_stop(self) -> bool:
        return self.pan_dir == 0 and self.tilt_dir == 0 and self.zoom == 0

    def to_bytes(self, address: int) -> bytes:
        return codec.pan_tilt(address, self.pan_dir, self.pan_speed, self.tilt_dir, self.tilt_speed,
                              self.zoom)


STOP = MotionCommand()


def proportional_integral(error: float, integral: float, kp: float, ki: float) -> float:
    """Demanded joint rate, rad/s: omega = kp * e + ki * integral(e dt)."""
    return kp * error + ki * integral


def slew(previous: float, target: float, max_accel: float, dt: float) -> float:
    """Move `previous` toward `target` by at most max_accel * dt; a zero target (stop) is never delayed."""
    if target == 0.0 or max_accel <= 0.0:
        return target
    step = max_accel * dt
    return previous + min(max(target - previous, -step), step)


def limit_guard(omega: float, position: float | None, lo: float, hi: float, lookahead: float) -> float:
    """Rate clipped so that the joint reaches a soft limit no sooner than `lookahead` s from now.

    Toward hi: omega <= (hi - position) / lookahead (0 at or past the limit), symmetric toward lo, so the
    head slows down on approach instead of hitting the limit at speed. Motion back toward the allowed
    range is always permitted; an unknown position passes unchanged.
    """
    if position is None or omega == 0.0:
        return omega
    room = hi - position if omega > 0.0 else position - lo
    if room <= 0.0:
        return 0.0
    if lookahead > 0.0:
        return math.copysign(min(abs(omega), room / lookahead), omega)
    return omega


class AxisController:
    """One joint: error (rad, our sign convention) and target rate (rad/s) -> (Pelco dir, speed byte)."""

    def __init__(self, table: SpeedTable, *, kp: float, ki: float, integral_limit: float, deadband: float,
                 min_byte: int, max_byte: int, max_accel: float, invert: bool, lo: float, hi: float,
                 lookahead: float, positive_pelco_dir: int, turbo: bool = False) -> None:
        self.table = table
        self.kp, self.ki, self.integral_limit, self.deadband = kp, ki, integral_limit, deadband
        self.min_byte, self.max_byte, self.max_accel, self.turbo = min_byte, max_byte, max_accel, turbo
        self.lo, self.hi, self.lookahead = lo, hi, lookahead
        # Pelco direction that moves the joint in our positive direction (pan: left = -1, tilt: up = +1).
        self.positive_dir = -positive_pelco_dir if invert else positive_pelco_dir
        self.integral = 0.0
        self.omega = 0.0  # commanded rate after slew, rad/s (our convention)
        self.sent_rate = 0.0  # table speed of the byte chosen last, rad/s, signed (what the head will do)

    def reset(self) -> None:
        self.integral = 0.0
        self.omega = 0.0
        self.sent_rate = 0.0

    def step(self, error: float, dt: float, position: float | None = None, gain: float = 1.0,
             feed_forward: float = 0.0) -> tuple[int, int]:
        """(pelco_dir, speed_byte) for this control period: omega = feed_forward + gain * PI(error).

        Inside the deadband the P/PI term is zero (and the integral reset), so the head follows the
        feed-forward rate alone; with no feed-forward either it stops. Outside the deadband any demand
        gets at least `min_byte` (the head creeps toward the target rather than stalling short of it).
        """
        if not math.isfinite(error) or not math.isfinite(feed_forward):
            self.reset()
            return 0, 0
        if abs(error) < self.deadband or gain <= 0.0:
            self.integral = 0.0
            if abs(feed_forward) < 0.5 * math.radians(self.table.speed(self.min_byte)):
                self.reset()  # nearer to standing still than to the slowest speed: stand still
                return 0, 0
            return self.rate(feed_forward, dt, position)
        if self.ki > 0.0:
            bound = self.integral_limit / self.ki
            self.integral = min(max(self.integral + error * dt, -bound), bound)
        return self.rate(feed_forward + gain * proportional_integral(error, self.integral, self.kp, self.ki),
                         dt, position)

    def rate(self, target: float, dt: float, position: float | None = None) -> tuple[int, int]:
        """(pelco_dir, speed_byte) for a demanded joint rate (rad/s): soft limits, slew, speed table."""
        target = limit_guard(target, position, self.lo, self.hi, self.lookahead)
        if target == 0.0:
            self.reset()
            return 0, 0
        self.omega = slew(self.omega, target, self.max_accel, dt)
        if self.omega * target <= 0.0:  # still reversing through zero: hold still this period
            self.sent_rate = 0.0
            return 0, 0
        dps = math.degrees(abs(self.omega))
        byte = self.table.byte_for(dps, self.min_byte, self.max_byte)
        if self.turbo and dps >= 0.5 * (self.table.max_dps + self.table.turbo_dps):
            byte = codec.TURBO
        self.sent_rate = math.copysign(math.radians(self.table.speed(byte)), self.omega)
        direction = self.positive_dir if self.omega > 0.0 else -self.positive_dir
        return direction, byte


class PanTiltController:
    """Both joints from one `PositionerParams`."""

    def __init__(self, p: PositionerParams) -> None:
        xs = tuple(p.speed_table_bytes)
        common = dict(kp=p.kp, ki=p.ki, integral_limit=p.integral_limit, deadband=p.deadband,
                      min_byte=p.min_speed_byte, max_byte=p.max_speed_byte, max_accel=p.max_accel,
                      lookahead=p.limit_lookahead)
        pan_limited = p.pan_min > -math.pi + 1e-6 or p.pan_max < math.pi - 1e-6  # +-pi: continuous pan
        self.pan = AxisController(
            SpeedTable(xs, tuple(p.pan_speed_table), p.pan_turbo_speed), invert=p.invert_pan,
            lo=p.pan_min if pan_limited else -math.inf, hi=p.pan_max if pan_limited else math.inf,
            positive_pelco_dir=-1, turbo=p.allow_turbo, **common)
        self.tilt = AxisController(
            SpeedTable(xs, tuple(p.tilt_speed_table), p.tilt_speed_table[-1]), invert=p.invert_tilt,
            lo=p.tilt_min, hi=p.tilt_max, positive_pelco_dir=1, **common)

    def reset(self) -> None:
        self.pan.reset()
        self.tilt.reset()

    def step(self, pan_error: float, tilt_error: float, dt: float, pan: float | None = None,
             tilt: float | None = None, gain: float = 1.0,
             feed_forward: tuple[float, float] = (0.0, 0.0)) -> MotionCommand:
        """Tracking: errors (rad) and the target's rates (rad/s, `feed_forward`) -> one pan/tilt command."""
        pd, ps = self.pan.step(pan_error, dt, pan, gain, feed_forward[0])
        td, ts = self.tilt.step(tilt_error, dt, tilt, gain, feed_forward[1])
        return MotionCommand(pd, ps, td, ts)

    def rates(self, pan_rate: float, tilt_rate: float, dt: float, pan: float | None = None,
              tilt: float | None = None, zoom: int = 0) -> MotionCommand:
        """Manual jog: demanded joint rates (rad/s) -> one pan/tilt(/zoom) command."""
        pd, ps = self.pan.rate(pan_rate, dt, pan)
        td, ts = self.tilt.rate(tilt_rate, dt, tilt)
        return MotionCommand(pd, ps, td, ts, zoom)

    @property
    def sent_rates(self) -> tuple[float, float]:
        """The joint rates (rad/s) of the bytes chosen last: the head's own rate, as commanded."""
        return self.pan.sent_rate, self.tilt.sent_rate
