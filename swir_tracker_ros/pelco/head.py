# SPDX-License-Identifier: Apache-2.0
"""Simulated Pelco-D head dynamics: speed table, acceleration limit, presets, zoom, position replies."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.speed_table import SpeedTable
from swir_tracker_ros.pelco.units import FULL_TURN, angle_to_raw, raw_to_angle, wrap_deg

# The simulated vendor convention (the bridge's defaults): pan word grows to the right, tilt word grows
# downwards (0-9000 below the horizon, 36000 - x above), both in hundredths of a degree.
PAN_SIGN, TILT_SIGN = -1, -1


@dataclass
class HeadConfig:
    address: int = 1
    pan_table: SpeedTable = field(default_factory=SpeedTable)
    tilt_table: SpeedTable = field(default_factory=SpeedTable)
    max_accel: float = 120.0  # deg/s^2 per axis
    tilt_min: float = -90.0  # mechanical stops, deg (our convention, up positive)
    tilt_max: float = 90.0
    command_timeout: float = 0.0  # stop after this long without a valid frame, s (0: never, like most heads)
    zoom_max: int = 0xFFFF  # zoom position word at full tele (the 0x5D reply's scale; vendor-specific)
    zoom_time: float = 4.0  # s from full wide to full tele at the lens's one zoom speed


class _Joint:
    wraps = False  # pan wraps at +-180 deg, tilt does not

    def __init__(self, angle: float) -> None:
        self.angle = angle  # deg, our convention
        self.velocity = 0.0  # deg/s
        self.target_velocity = 0.0
        self.goal: float | None = None  # absolute position mode

    def advance(self, dt: float, accel: float, vmax: float) -> None:
        if self.goal is not None:
            d = wrap_deg(self.goal - self.angle) if self.wraps else self.goal - self.angle
            if abs(d) < 0.01 and abs(self.velocity) <= accel * dt:
                self.angle, self.velocity, self.goal, self.target_velocity = self.goal, 0.0, None, 0.0
                return
            # brake so as to arrive at rest: v = sqrt(2 a |d|)
            self.target_velocity = math.copysign(min(vmax, math.sqrt(2.0 * accel * abs(d))), d)
        dv = self.target_velocity - self.velocity
        step = accel * dt if accel > 0 else abs(dv)
        self.velocity += min(max(dv, -step), step)
        self.angle += self.velocity * dt


class _Pan(_Joint):
    wraps = True


class HeadModel:
    """State in our sign convention (deg, deg/s); `apply(frame)` returns the reply bytes, if any."""

    def __init__(self, config: HeadConfig, pan: float = 0.0, tilt: float = 0.0) -> None:
        self.cfg = config
        self.pan, self.tilt = _Pan(wrap_deg(pan)), _Joint(tilt)
        self.presets: dict[int, tuple[float, float]] = {}
        self.zoom = 0.0  # zoom position word, 0 (wide) .. cfg.zoom_max (tele)
        self.zoom_dir = 0  # +1 tele, -1 wide, 0 none (from the last standard frame)
        self.last_frame_time = -math.inf
        self.frames = 0
        self.ignored = 0  # frames for other addresses or unsupported commands

    def apply(self, frame: codec.Frame, now: float) -> bytes | None:
        if frame.address != self.cfg.address:
            self.ignored += 1
            return None
        self.frames += 1
        self.last_frame_time = now
        motion = frame.motion()
        if motion is not None:
            pan_dir, pan_speed, tilt_dir, tilt_speed = motion
            # A standard frame is the complete pan/tilt state (a lens-only frame stops pan and tilt).
            # Pelco right turns the head clockwise seen from above: negative pan in our convention.
            self.pan.goal = self.tilt.goal = None
            self.pan.target_velocity = -pan_dir * self.cfg.pan_table.speed(pan_speed)
            self.tilt.target_velocity = tilt_dir * self.cfg.tilt_table.speed(min(tilt_speed, codec.MAX_SPEED))
            self.zoom_dir = frame.zoom
            return None
        c, w = frame.cmd2, frame.word
        if c == codec.QUERY_PAN:
            return codec.position_reply(self.cfg.address, "pan", angle_to_raw(math.radians(self.pan.angle),
                                                                              PAN_SIGN, 0.0))
        if c == codec.QUERY_TILT:
            return codec.position_reply(self.cfg.address, "tilt", angle_to_raw(math.radians(self.tilt.angle),
                                                                               TILT_SIGN, 0.0))
        if c == codec.QUERY_ZOOM:
            return codec.position_reply(self.cfg.address, "zoom", round(self.zoom))
        if c == codec.SET_PAN_POSITION and w < FULL_TURN:
            self.pan.goal = math.degrees(raw_to_angle(w, PAN_SIGN, 0.0))
        elif c == codec.SET_TILT_POSITION:
            self.tilt.goal = self._clamp_tilt(math.degrees(raw_to_angle(w, TILT_SIGN, 0.0)))
        elif c == codec.SET_PRESET and frame.data2:
            self.presets[frame.data2] = (self.pan.angle, self.tilt.angle)
        elif c == codec.CLEAR_PRESET:
            self.presets.pop(frame.data2, None)
        elif c == codec.GOTO_PRESET and frame.data2 in self.presets:
            self.pan.goal, self.tilt.goal = self.presets[frame.data2]
        else:
            self.ignored += 1
        return None

    def _clamp_tilt(self, t: float) -> float:
        return min(max(t, self.cfg.tilt_min), self.cfg.tilt_max)

    def advance(self, dt: float, now: float) -> None:
        cfg = self.cfg
        if cfg.command_timeout > 0 and now - self.last_frame_time > cfg.command_timeout:
            for joint in (self.pan, self.tilt):  # continuous moves only; position moves run to their goal
                if joint.goal is None:
                    joint.target_velocity = 0.0
            self.zoom_dir = 0
        if self.zoom_dir and cfg.zoom_time > 0:
            step = self.zoom_dir * cfg.zoom_max * dt / cfg.zoom_time
            self.zoom = min(max(self.zoom + step, 0.0), cfg.zoom_max)
        self.pan.advance(dt, cfg.max_accel, cfg.pan_table.turbo_dps)
        self.pan.angle = wrap_deg(self.pan.angle)
        self.tilt.advance(dt, cfg.max_accel, cfg.tilt_table.max_dps)
        if not cfg.tilt_min <= self.tilt.angle <= cfg.tilt_max:  # mechanical end stop
            self.tilt.angle = self._clamp_tilt(self.tilt.angle)
            self.tilt.velocity = 0.0
