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


def joint_state_to_sample(msg: JointState) -> PanTiltSample:
    """Pan/tilt positions (required) and velocities (0 when the message carries none)."""
    names = getattr(msg, "name", None)
    if names is None:
        raise MessageError("JointState.name is missing")
    ip, it = _index(names, PAN), _index(names, TILT)
    pan, tilt = _value(msg.position, ip, "position", PAN), _value(msg.position, it, "position", TILT)
    vel = list(msg.velocity)
    pan_v = _value(vel, ip, "velocity", PAN) if vel else 0.0
    tilt_v = _value(vel, it, "velocity", TILT) if vel else 0.0
    return PanTiltSample(pan, tilt, pan_v, tilt_v, stamp_to_seconds(msg.header.stamp))


def joint_state_to_pan_tilt(msg: JointState) -> tuple[float, float, float]:
    """(pan rad, tilt rad, stamp seconds) of a /positioner/joint_states message."""
    s = joint_state_to_sample(msg)
    return s.pan, s.tilt, s.stamp
