# SPDX-License-Identifier: Apache-2.0
"""Parameters of the positioner bridge (flat dataclass, docs/interfaces.md "Parameters")."""

from __future__ import annotations

import math
from dataclasses import dataclass

from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param, validate_params
from swir_tracker_ros.pelco.speed_table import DEFAULT_BYTES, DEFAULT_DPS, DEFAULT_TURBO_DPS, table_problem


@dataclass
class PositionerParams:
    """Serial link, control law, speed tables, position convention and soft limits of a Pelco-D head."""

    # link
    port: str = param(
        "/dev/ttyUSB0",
        "pyserial URL: device path (/dev/ttyUSB0), socket://host:port (serial device server), loop://",
    )
    baud: int = param(9600, "line speed, 8N1 (2400, 4800 or 9600)", 1200, 115200)
    address: int = param(1, "Pelco-D address of the head (receiver id)", 1, 255)
    reconnect_min: float = param(
        0.2, "first retry delay after the port vanished or failed to open, s", 0.01, 60.0
    )
    reconnect_max: float = param(5.0, "retry delay ceiling (doubling backoff), s", 0.01, 600.0)
    # rates and safety
    control_rate: float = param(
        20.0, "control loop rate, Hz (a frame is written only on change or keep-alive)", 1.0, 200.0
    )
    keepalive_period: float = param(
        0.5, "re-send the current command (stop included) after this long, s; 0 = only on change", 0.0, 60.0
    )
    watchdog_timeout: float = param(
        0.5, "stop when no track/pan_tilt_error arrived for this long, s", 0.05, 10.0
    )
    occluded_gain: float = param(
        0.0, "P/PI gain factor on the tracker's predicted error while it reports 'occluded'; 0: the head "
        "coasts on the target's last measured rate alone (coast_time, coast_decay)", 0.0, 1.0
    )
    feedback_rate: float = param(10.0, "pan/tilt position query rate, Hz (0 = never query)", 0.0, 50.0)
    reply_timeout: float = param(0.25, "give up waiting for a query reply after this long, s", 0.01, 5.0)
    feedback_timeout: float = param(
        1.0, "feedback older than this is unknown (soft limits off, no JointState), s", 0.05, 60.0
    )
    joint_state_rate: float = param(10.0, "/positioner/joint_states publish rate, Hz", 0.1, 100.0)
    require_feedback: bool = param(False, "refuse to move while the position is unknown")
    frame_id: str = param("", "header.frame_id of the JointState messages")
    # control law: a P/PI loop on the angular error
    kp: float = param(
        2.0, "proportional gain on what the feed-forward leaves, rad/s per rad of error", 0.0, 100.0
    )
    ki: float = param(0.0, "integral gain, rad/s per rad*s (0 = P only)", 0.0, 100.0)
    integral_limit: float = param(0.1, "bound of the integral term's contribution, rad/s", 0.0, 10.0)
    deadband: float = param(
        0.0005, "no P/PI correction when |error| is below this (the feed-forward still runs), rad", 0.0, 0.5
    )
    min_speed_byte: int = param(1, "slowest speed byte used outside the deadband", 1, 63)
    max_speed_byte: int = param(63, "fastest speed byte (0x3F)", 1, 63)
    allow_turbo: bool = param(False, "use pan turbo (0xFF) when the demand is past the table's top speed")
    max_accel: float = param(
        2.0, "slew-rate limit of the commanded speed, rad/s^2 (0 = none; stops are never delayed)", 0.0, 100.0
    )
    invert_pan: bool = param(
        False, "head mounted so that Pelco 'left' turns it right: flips pan commands and pan feedback"
    )
    invert_tilt: bool = param(False, "flips tilt commands and tilt feedback (head mounted upside down)")
    # speed tables: deg/s measured at the given speed bytes, linear in between, (0, 0) implied
    speed_table_bytes: list[float] = param(
        list(DEFAULT_BYTES), "speed bytes of the table breakpoints, strictly increasing, in (0, 63]"
    )
    pan_speed_table: list[float] = param(
        list(DEFAULT_DPS), "pan deg/s at speed_table_bytes, strictly increasing"
    )
    tilt_speed_table: list[float] = param(
        list(DEFAULT_DPS), "tilt deg/s at speed_table_bytes, strictly increasing"
    )
    pan_turbo_speed: float = param(DEFAULT_TURBO_DPS, "pan deg/s at turbo (0xFF)", 0.0, 1000.0)
    # position words: angle = sign * (word / 100 - zero), wrapped to (-180, 180] deg
    pan_position_sign: int = param(
        -1, "+1 if the pan word grows to the left (CCW from above), -1 if it grows to the right", -1, 1
    )
    pan_zero_deg: float = param(0.0, "pan word (deg) at our pan 0", 0.0, 360.0)
    tilt_position_sign: int = param(
        -1, "+1 if the tilt word grows upwards, -1 if downwards (common: 0-9000 down, 36000-x up)", -1, 1
    )
    tilt_zero_deg: float = param(0.0, "tilt word (deg) at the horizon", 0.0, 360.0)
    # soft limits, our convention (rad); enforced when the position is known
    pan_min: float = param(
        -math.pi, "soft pan limit, rad (pan_min = -pi and pan_max = pi: no pan limit)", -math.pi, math.pi
    )
    pan_max: float = param(math.pi, "soft pan limit, rad", -math.pi, math.pi)
    tilt_min: float = param(-math.pi / 4, "soft tilt limit, rad", -math.pi / 2, math.pi / 2)
    tilt_max: float = param(math.pi / 2, "soft tilt limit, rad", -math.pi / 2, math.pi / 2)
    limit_lookahead: float = param(
        0.3, "block motion that would cross a soft limit within this many seconds, s", 0.0, 5.0
    )
    # who owns the head, joint names (docs/positioner.md "Modes", "Control surface")
    initial_mode: str = param(
        "tracking", "mode at start (unmanaged) or on activate (managed); tracking follows the tracker",
        choices=("idle", "tracking", "manual", "released"),
    )
    pan_joint: str = param("pan", "name of the pan joint in joint states, jogs and moves")
    tilt_joint: str = param("tilt", "name of the tilt joint in joint states, jogs and moves")
    zoom_joint: str = param("zoom", "name of the zoom joint in joint states (position 0 wide to 1 tele)")
    # following a moving target (tracking mode)
    feed_forward: float = param(
        1.0, "gain on the target's angular rate (track/target_rate) added to the speed command; 0 = P/PI",
        0.0, 2.0,
    )
    max_input_age: float = param(
        0.3, "an error or rate older than this (its camera frame to now) gets no feed-forward, s", 0.01, 5.0
    )
    error_prediction_max: float = param(
        0.25, "carry a fresh error forward to now over at most this much of its age (target minus head "
        "rate), s; 0 = off", 0.0, 1.0,
    )
    lead_limit: float = param(
        0.003, "the feed-forward fades out as the head gets ahead of the tracked target, to zero at this "
        "lead, rad (the target is stopping faster than its measured rate says); 0 = off", 0.0, 0.1,
    )
    coast_time: float = param(
        1.0, "while the tracker reports 'occluded', keep feeding the target's last measured rate forward "
        "this long, s", 0.0, 10.0,
    )
    coast_decay: float = param(1.0, "then fade the feed-forward out over this long, s", 0.0, 10.0)
    # manual control (positioner/jog, positioner/move, presets, zoom)
    jog_timeout: float = param(
        0.5, "dead-man: the jog stops when no positioner/jog arrived for this long, s", 0.05, 5.0
    )
    move_tolerance: float = param(
        0.002, "a move is complete when every joint is within this of its goal and still, rad", 0.0002, 0.1
    )
    move_timeout: float = param(
        30.0, "a move or preset not complete after this long is aborted, s", 0.5, 600.0
    )
    zoom_feedback: bool = param(
        False, "also query the zoom position (heads that answer 0x55) and publish it as the zoom joint"
    )
    zoom_word_max: int = param(
        65535, "zoom position word at full tele: the zoom joint's position is word / zoom_word_max", 1, 65535
    )

    def validate(self) -> PositionerParams:
        """Raise `ParameterError` naming the first bad field (`paramfield.validate_params`); returns self."""
        validate_params(self)
        return self

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if not self.port:
            raise ParameterError("port must be a device path or pyserial URL, got ''")
        for name in ("pan_position_sign", "tilt_position_sign"):
            if getattr(self, name) not in (-1, 1):
                raise ParameterError(f"{name} must be -1 or +1, got {getattr(self, name)}")
        if self.min_speed_byte > self.max_speed_byte:
            raise ParameterError(
                f"min_speed_byte {self.min_speed_byte} exceeds max_speed_byte {self.max_speed_byte}"
            )
        if self.reconnect_min > self.reconnect_max:
            raise ParameterError(
                f"reconnect_min {self.reconnect_min} exceeds reconnect_max {self.reconnect_max}"
            )
        for axis in ("pan", "tilt"):
            if getattr(self, f"{axis}_min") >= getattr(self, f"{axis}_max"):
                raise ParameterError(
                    f"{axis}_min {getattr(self, f'{axis}_min')} must be below {axis}_max "
                    f"{getattr(self, f'{axis}_max')}"
                )
            table = getattr(self, f"{axis}_speed_table")
            problem = table_problem(
                self.speed_table_bytes,
                table,
                self.pan_turbo_speed if axis == "pan" else table[-1] if table else 0.0,
            )
            if problem:
                raise ParameterError(f"{axis}_speed_table / speed_table_bytes: {problem}")
        names = (self.pan_joint, self.tilt_joint, self.zoom_joint)
        if not all(n.strip() for n in names) or len(set(names)) != 3:
            raise ParameterError(f"pan_joint, tilt_joint and zoom_joint must be distinct, non-empty names, "
                                 f"got {list(names)}")
        if 0 < self.keepalive_period < 1.0 / self.control_rate:
            raise ParameterError(
                f"keepalive_period {self.keepalive_period} is shorter than one control "
                f"period ({1.0 / self.control_rate:.3f} s)"
            )
