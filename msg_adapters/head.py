# SPDX-License-Identifier: Apache-2.0
"""The pan-tilt head's control surface (swir_tracker_interfaces) <-> plain values: mode, jog, moves,
presets, zoom, and the joint state under the bridge's joint names (docs/positioner.md)."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from sensor_msgs.msg import JointState

from msg_adapters.errors import MessageError
from msg_adapters.joint_state import PanTiltSample
from msg_adapters.stamps import header, stamp_to_seconds
from swir_tracker_interfaces.action import MoveHead
from swir_tracker_interfaces.msg import HeadJog, HeadMode
from swir_tracker_interfaces.srv import HeadPreset, SetHeadMode, ZoomHead

MODE_NAMES = ("IDLE", "TRACKING", "MANUAL", "RELEASED")  # HeadMode / SetHeadMode constants
MOVE_KINDS = ("ABSOLUTE", "RELATIVE", "PRESET")  # MoveHead goal constants


def _constant(cls: Any, names: tuple[str, ...], name: str, what: str) -> int:
    if name.upper() not in names:
        raise MessageError(f"{what} must be one of {[n.lower() for n in names]}, got {name!r}")
    return int(getattr(cls, name.upper()))


def _name(cls: Any, names: tuple[str, ...], value: int, what: str) -> str:
    for n in names:
        if int(getattr(cls, n)) == int(value):
            return n.lower()
    raise MessageError(f"{what} {value} is not one of " + ", ".join(f"{n}={getattr(cls, n)}" for n in names))


# -- mode -------------------------------------------------------------------------------------------------
def mode_msg(mode: str, reason: str, stamp: float) -> HeadMode:
    """positioner/mode: 'idle' | 'tracking' | 'manual' | 'released', why, when (s)."""
    return HeadMode(header=header(stamp), mode=_constant(HeadMode, MODE_NAMES, mode, "mode"),
                    reason=str(reason))


def mode_from_msg(msg: HeadMode) -> tuple[str, str, float]:
    """(mode name, reason, stamp in seconds) of a positioner/mode message."""
    return _name(HeadMode, MODE_NAMES, msg.mode, "HeadMode.mode"), str(msg.reason), \
        stamp_to_seconds(msg.header.stamp)


def set_mode_request(mode: str) -> SetHeadMode.Request:
    return SetHeadMode.Request(mode=_constant(SetHeadMode.Request, MODE_NAMES, mode, "mode"))


def mode_from_request(request: SetHeadMode.Request) -> str:
    """The requested mode's name; `MessageError` naming the valid values for an unknown one."""
    return _name(SetHeadMode.Request, MODE_NAMES, request.mode, "SetHeadMode.mode")


def set_mode_reply(response: SetHeadMode.Response, success: bool, message: str, mode: str
                   ) -> SetHeadMode.Response:
    response.success, response.message = bool(success), str(message)
    response.mode = _constant(SetHeadMode.Request, MODE_NAMES, mode, "mode")  # constants live in the request
    return response


def set_mode_result(response: SetHeadMode.Response | None) -> tuple[bool, str, str]:
    """(success, message, mode now) of a set_mode call; (False, 'no response', '') without one."""
    if response is None:
        return False, "no response", ""
    return bool(response.success), str(response.message), _name(SetHeadMode.Request, MODE_NAMES,
                                                                 response.mode, "SetHeadMode.mode")


# -- jog ----------------------------------------------------------------------------------------------
def _joint_values(names: Any, values: Any, field: str) -> dict[str, float]:
    names, values = [str(n) for n in names], [float(v) for v in values]
    if len(names) != len(values):
        raise MessageError(f"{len(names)} joint_names but {len(values)} {field}")
    if len(set(names)) != len(names):
        raise MessageError(f"joint_names repeat a joint: {names}")
    if not all(math.isfinite(v) for v in values):
        raise MessageError(f"{field} must be finite, got {values}")
    return dict(zip(names, values))


def _known(joints: dict[str, float], pan_joint: str, tilt_joint: str) -> tuple[float | None, float | None]:
    unknown = sorted(set(joints) - {pan_joint, tilt_joint})
    if unknown:
        raise MessageError(f"unknown joints {unknown}: this head has {pan_joint!r} and {tilt_joint!r}")
    return joints.get(pan_joint), joints.get(tilt_joint)


def jog_msg(velocities: dict[str, float], stamp: float = 0.0) -> HeadJog:
    """positioner/jog: joint name -> rate (rad/s)."""
    return HeadJog(header=header(stamp), joint_names=list(velocities),
                   velocities=[float(v) for v in velocities.values()])


def jog_rates(msg: HeadJog, pan_joint: str, tilt_joint: str) -> tuple[float, float]:
    """(pan rate, tilt rate) in rad/s of a jog; a joint not named is 0. `MessageError` for an unknown
    joint, a length mismatch or a non-finite rate."""
    pan, tilt = _known(_joint_values(msg.joint_names, msg.velocities, "velocities"), pan_joint, tilt_joint)
    return pan or 0.0, tilt or 0.0


# -- presets, zoom ------------------------------------------------------------------------------------
def preset_request(preset: int) -> HeadPreset.Request:
    return HeadPreset.Request(preset=int(preset))


def preset_from_request(request: HeadPreset.Request) -> int:
    return int(request.preset)


def zoom_request(direction: int) -> ZoomHead.Request:
    return ZoomHead.Request(direction=int(direction))


def zoom_from_request(request: ZoomHead.Request) -> int:
    return int(request.direction)


# -- moves --------------------------------------------------------------------------------------------
class MoveRequest(NamedTuple):
    """A MoveHead goal as plain values: kind 'absolute' | 'relative' | 'preset', angles (rad, None = keep)."""

    kind: str
    pan: float | None
    tilt: float | None
    preset: int
    tolerance: float


def move_goal_msg(kind: str, positions: dict[str, float] | None = None, preset: int = 0,
                  tolerance: float = 0.0) -> MoveHead.Goal:
    positions = positions or {}
    return MoveHead.Goal(kind=_constant(MoveHead.Goal, MOVE_KINDS, kind, "kind"), joint_names=list(positions),
                         position=[float(v) for v in positions.values()], preset=int(preset),
                         tolerance=float(tolerance))


def move_request(goal: MoveHead.Goal, pan_joint: str, tilt_joint: str) -> MoveRequest:
    """The goal's values; `MessageError` for an unknown kind or joint, unequal lengths, a non-finite angle."""
    kind = _name(MoveHead.Goal, MOVE_KINDS, goal.kind, "MoveHead.kind")
    pan = tilt = None
    if kind != "preset":
        pan, tilt = _known(_joint_values(goal.joint_names, goal.position, "position"), pan_joint, tilt_joint)
    return MoveRequest(kind, pan, tilt, int(goal.preset), float(goal.tolerance))


def move_feedback(positions: dict[str, float], errors: list[float], elapsed: float) -> MoveHead.Feedback:
    return MoveHead.Feedback(joint_names=list(positions), position=[float(v) for v in positions.values()],
                             error=[float(e) for e in errors], elapsed=float(elapsed))


def move_result(success: bool, message: str, positions: dict[str, float], errors: list[float]
                ) -> MoveHead.Result:
    return MoveHead.Result(success=bool(success), message=str(message), joint_names=list(positions),
                           position=[float(v) for v in positions.values()], error=[float(e) for e in errors])


def move_result_values(result: MoveHead.Result) -> tuple[bool, str, dict[str, float], list[float]]:
    """(success, message, joint name -> final angle, final errors) of a MoveHead result."""
    return (bool(result.success), str(result.message), dict(zip(result.joint_names, result.position)),
            list(result.error))


def move_feedback_values(feedback: MoveHead.Feedback) -> tuple[dict[str, float], list[float], float]:
    return dict(zip(feedback.joint_names, feedback.position)), list(feedback.error), float(feedback.elapsed)


# -- joint state ---------------------------------------------------------------------------------------
def head_joint_state(sample: PanTiltSample, frame_id: str = "", names: tuple[str, str] = ("pan", "tilt"),
                     zoom: float | None = None, zoom_name: str = "zoom") -> JointState:
    """positioner/joint_states under the bridge's joint names; with `zoom` (0 wide .. 1 tele) a third joint.

    The zoom joint has a position and no velocity, so the velocity array then covers the first two joints
    only (sensor_msgs/JointState allows it: readers index by name, and `joint_state.joint_state_to_sample`
    reads pan and tilt).
    """
    values = (sample.pan, sample.tilt, sample.pan_velocity, sample.tilt_velocity)
    if not all(math.isfinite(v) for v in values):
        raise MessageError(f"pan/tilt sample must be finite, got {values}")
    joint_names, position = list(names), [float(sample.pan), float(sample.tilt)]
    if zoom is not None and math.isfinite(zoom):
        joint_names.append(zoom_name)
        position.append(float(zoom))
    return JointState(header=header(sample.stamp, frame_id), name=joint_names, position=position,
                      velocity=[float(sample.pan_velocity), float(sample.tilt_velocity)], effort=[])


def joint_positions(msg: JointState) -> dict[str, float]:
    """Joint name -> position of a JointState (any names)."""
    return {str(n): float(p) for n, p in zip(msg.name, msg.position)}
