# SPDX-License-Identifier: Apache-2.0
"""sensor_msgs/JointState on /positioner/joint_states <-> pan/tilt angles (rad), velocities (rad/s), stamp."""

from __future__ import annotations

import math
from dataclasses import dataclass

from sensor_msgs.msg import JointState

from msg_adapters.errors import MessageError
from msg_adapters.stamps import header, stamp_to_seconds

PAN = "pan"
TILT = "tilt"


@dataclass(frozen=True)
class PanTiltSample:
    """Head pose, docs/interfaces.md convention: pan + = left (CCW from above), tilt + = up."""

    pan: float  # rad
    tilt: float  # rad
    pan_velocity: float = 0.0  # rad/s
    tilt_velocity: float = 0.0  # rad/s
    stamp: float = 0.0  # seconds (header stamp)


def pan_tilt_to_joint_state(sample: PanTiltSample, frame_id: str = "") -> JointState:
    """A JointState with names `pan`, `tilt`, positions in rad and velocities in rad/s."""
    values = (sample.pan, sample.tilt, sample.pan_velocity, sample.tilt_velocity)
    if not all(math.isfinite(v) for v in values):
        raise MessageError(f"pan/tilt sample must be finite, got {values}")
    return JointState(
        header=header(sample.stamp, frame_id), name=[PAN, TILT],
        position=[float(sample.pan), float(sample.tilt)],
        velocity=[float(sample.pan_velocity), float(sample.tilt_velocity)], effort=[],
    )


def _index(names: list[str], joint: str) -> int:
    try:
        return list(names).index(joint)
    except ValueError as exc:
        raise MessageError(f"JointState.name {list(names)} has no joint {joint!r}") from exc


def _value(seq, i: int, field: str, joint: str) -> float:
    if i >= len(seq):
        raise MessageError(f"JointState.{field} has {len(seq)} entries, none for joint {joint!r} (index {i})")
    out = float(seq[i])
    if not math.isfinite(out):
        raise MessageError(f"JointState.{field}[{i}] ({joint}) is not finite: {out}")
    return out


def joint_state_to_sample(msg: JointState, pan_joint: str = PAN, tilt_joint: str = TILT) -> PanTiltSample:
    """Pan/tilt positions (required) and velocities (0 when the message carries none) of the joints named
    `pan_joint` and `tilt_joint` (the bring-up's joint names)."""
    names = getattr(msg, "name", None)
    if names is None:
        raise MessageError("JointState.name is missing")
    ip, it = _index(names, pan_joint), _index(names, tilt_joint)
    pan = _value(msg.position, ip, "position", pan_joint)
    tilt = _value(msg.position, it, "position", tilt_joint)
    vel = list(msg.velocity)
    pan_v = _value(vel, ip, "velocity", pan_joint) if vel else 0.0
    tilt_v = _value(vel, it, "velocity", tilt_joint) if vel else 0.0
    return PanTiltSample(pan, tilt, pan_v, tilt_v, stamp_to_seconds(msg.header.stamp))


def joint_state_to_pan_tilt(msg: JointState, pan_joint: str = PAN, tilt_joint: str = TILT
                            ) -> tuple[float, float, float]:
    """(pan rad, tilt rad, stamp seconds) of a joint-states message (joints `pan_joint`, `tilt_joint`)."""
    s = joint_state_to_sample(msg, pan_joint, tilt_joint)
    return s.pan, s.tilt, s.stamp


def joint_position(msg: JointState, joint: str) -> float | None:
    """The finite position of `joint` in a joint-states message, or None when it carries none (e.g. the
    zoom joint of a head that does not report its zoom)."""
    names = list(getattr(msg, "name", None) or [])
    if joint not in names:
        return None
    i = names.index(joint)
    if i >= len(msg.position) or not math.isfinite(float(msg.position[i])):
        return None
    return float(msg.position[i])
