# SPDX-License-Identifier: Apache-2.0
"""Who owns the head (modes) and the operator's commands: jog by rate, absolute / relative / preset moves,
zoom.

Pure bookkeeping over the bridge clock; the bridge (`pelco.bridge`) writes the frames. Angles and rates
are REP-103 (pan + = left, tilt + = up), rad and rad/s.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from enum import Enum

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.feedback import Pose
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.units import angle_to_raw, wrap_rad

# A head starts a preset move within this long (s); a preset go-to is complete once the head has been
# still after it (a head already at the preset never moves).
PRESET_START_S = 0.5


class HeadMode(str, Enum):
    """Who owns the head (docs/positioner.md "Modes")."""

    IDLE = "idle"  # the bridge holds the bus and keeps the head stopped
    TRACKING = "tracking"  # the tracker's error steers the head
    MANUAL = "manual"  # an operator's jog, move, preset or zoom steers it
    RELEASED = "released"  # another controller owns the bus: the bridge writes nothing at all


class MoveKind(str, Enum):
    ABSOLUTE = "absolute"  # go to the given joint angles
    RELATIVE = "relative"  # turn by the given angles from the current pose
    PRESET = "preset"  # go to a preset stored in the head


@dataclass(frozen=True)
class MoveGoal:
    """A position move; a joint given as None keeps its angle."""

    kind: MoveKind
    pan: float | None = None
    tilt: float | None = None
    preset: int = 0
    tolerance: float = 0.0  # rad; 0 = the bridge's move_tolerance


@dataclass
class Move:
    """One position move under way: its goal (None for a preset), the frames that start it, its outcome."""

    id: int
    goal: MoveGoal
    pan: float | None  # absolute goal angles, rad (None: not moved / unknown for a preset)
    tilt: float | None
    tolerance: float
    frames: bytes
    started: float
    deadline: float
    sent: bool = False
    done: bool = False
    success: bool = False
    outcome: str = ""  # what happened, once done
    errors: list[float] = field(default_factory=list)

    def finish(self, success: bool, outcome: str) -> None:
        if not self.done:
            self.done, self.success, self.outcome = True, success, outcome


def move_problem(goal: MoveGoal, p: PositionerParams, pose: Pose | None) -> str:
    """Why a move goal cannot be carried out ('' when it can)."""
    if goal.kind == MoveKind.PRESET:
        return "" if 1 <= goal.preset <= 255 else f"preset must be 1-255, got {goal.preset}"
    if goal.pan is None and goal.tilt is None:
        return f"no joint to move: name {p.pan_joint!r} and/or {p.tilt_joint!r}"
    values = [v for v in (goal.pan, goal.tilt) if v is not None]
    if not all(math.isfinite(v) for v in values):
        return f"goal angles must be finite, got pan {goal.pan}, tilt {goal.tilt}"
    if goal.tolerance < 0.0 or not math.isfinite(goal.tolerance):
        return f"tolerance must be >= 0 rad, got {goal.tolerance}"
    if p.feedback_rate <= 0.0:
        return "position moves need position feedback (feedback_rate is 0: the head is never queried)"
    if pose is None:
        return "the head's position is unknown (no reply to the position queries yet)"
    return ""


def absolute_goal(goal: MoveGoal, pose: Pose) -> tuple[float | None, float | None]:
    """The goal's absolute joint angles (a relative goal is added to the current pose; pan wraps)."""
    if goal.kind == MoveKind.RELATIVE:
        pan = None if goal.pan is None else wrap_rad(pose.pan + goal.pan)
        tilt = None if goal.tilt is None else pose.tilt + goal.tilt
        return pan, tilt
    return (None if goal.pan is None else wrap_rad(goal.pan)), goal.tilt


def limit_problem(pan: float | None, tilt: float | None, p: PositionerParams) -> str:
    """Why absolute goal angles lie outside the soft limits ('' when inside)."""
    pan_limited = p.pan_min > -math.pi + 1e-6 or p.pan_max < math.pi - 1e-6
    if pan is not None and pan_limited and not p.pan_min <= pan <= p.pan_max:
        return f"pan goal {pan:.4f} rad is outside the soft limits [{p.pan_min:.4f}, {p.pan_max:.4f}]"
    if tilt is not None and not p.tilt_min <= tilt <= p.tilt_max:
        return f"tilt goal {tilt:.4f} rad is outside the soft limits [{p.tilt_min:.4f}, {p.tilt_max:.4f}]"
    return ""


def position_frames(pan: float | None, tilt: float | None, p: PositionerParams) -> bytes:
    """Pelco-D set-position frames (0x4B pan, 0x4D tilt) for absolute angles, in the head's convention."""
    out = b""
    if pan is not None:
        sign = -p.pan_position_sign if p.invert_pan else p.pan_position_sign
        out += codec.set_pan_position(p.address, angle_to_raw(pan, sign, p.pan_zero_deg))
    if tilt is not None:
        sign = -p.tilt_position_sign if p.invert_tilt else p.tilt_position_sign
        out += codec.set_tilt_position(p.address, angle_to_raw(tilt, sign, p.tilt_zero_deg))
    return out


def move_done(move: Move, pose: Pose | None, now: float) -> tuple[bool, list[float]]:
    """(complete, remaining errors in rad) of a move: every goal joint within tolerance and the head still;
    a preset once the head has been still after `PRESET_START_S`."""
    if pose is None:
        return False, []
    if move.goal.kind == MoveKind.PRESET:
        return now - move.started >= PRESET_START_S and pose.still and pose.time > move.started, []
    errors = []
    if move.pan is not None:
        errors.append(wrap_rad(pose.pan - move.pan))
    if move.tilt is not None:
        errors.append(pose.tilt - move.tilt)
    return pose.still and all(abs(e) <= move.tolerance for e in errors), errors


class Manual:
    """The operator's commands in manual mode: at most one of a jog (rates with a dead-man deadline) and a
    position move, plus a continuous zoom."""

    def __init__(self, params: PositionerParams) -> None:
        self.p = params
        self.jog_rates = (0.0, 0.0)
        self.jog_until = -math.inf
        self.zoom = 0
        self.move: Move | None = None
        self._ids = itertools.count(1)

    def clear(self, reason: str) -> None:
        """End everything (a mode change): a running move is aborted with `reason`."""
        self.abort_move(reason)
        self.jog_rates, self.jog_until, self.zoom = (0.0, 0.0), -math.inf, 0

    def abort_move(self, reason: str) -> None:
        if self.move is not None and not self.move.done:
            self.move.finish(False, reason)
        self.move = None

    def jog(self, pan_rate: float, tilt_rate: float, now: float) -> None:
        """Move at these rates until `jog_timeout` after the last jog (a dead-man command)."""
        self.abort_move("pre-empted by a jog")
        self.jog_rates, self.jog_until = (pan_rate, tilt_rate), now + self.p.jog_timeout

    def start(self, goal: MoveGoal, pose: Pose | None, now: float) -> Move:
        """A new position move (the caller checked `move_problem`); a running one is pre-empted."""
        self.abort_move("pre-empted by a new move")
        self.jog_until = -math.inf
        tolerance = goal.tolerance or self.p.move_tolerance
        if goal.kind == MoveKind.PRESET:
            pan = tilt = None
            frames = codec.goto_preset(self.p.address, goal.preset)
        else:
            pan, tilt = absolute_goal(goal, pose)
            frames = position_frames(pan, tilt, self.p)
        self.move = Move(next(self._ids), goal, pan, tilt, tolerance, frames, now, now + self.p.move_timeout)
        return self.move

    def jog_active(self, now: float) -> bool:
        return now < self.jog_until

    def rates(self, now: float) -> tuple[float, float]:
        """The jog's rates while its dead-man deadline holds, else zero."""
        return self.jog_rates if self.jog_active(now) else (0.0, 0.0)
