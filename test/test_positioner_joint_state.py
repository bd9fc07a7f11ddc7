# SPDX-License-Identifier: Apache-2.0
"""JointState adapter of /positioner/joint_states: round trip, joint order, bad messages."""

from __future__ import annotations

import math

import pytest
from sensor_msgs.msg import JointState

from msg_adapters.errors import MessageError
from msg_adapters.joint_state import (
    PanTiltSample,
    joint_state_to_pan_tilt,
    joint_state_to_sample,
    pan_tilt_to_joint_state,
)


def test_round_trip() -> None:
    sample = PanTiltSample(0.25, -0.1, 0.05, -0.02, 1234.5)
    msg = pan_tilt_to_joint_state(sample, "head")
    assert list(msg.name) == ["pan", "tilt"] and msg.header.frame_id == "head"
    back = joint_state_to_sample(msg)
    assert back.pan == 0.25 and back.tilt == -0.1 and back.pan_velocity == 0.05
    assert back.stamp == pytest.approx(1234.5, abs=1e-9)
    assert joint_state_to_pan_tilt(msg) == (0.25, -0.1, pytest.approx(1234.5, abs=1e-9))


def test_joints_found_by_name_and_velocity_optional() -> None:
    msg = JointState(name=["zoom", "tilt", "pan"], position=[3.0, 0.2, -0.4])
    s = joint_state_to_sample(msg)
    assert (s.pan, s.tilt, s.pan_velocity, s.tilt_velocity) == (-0.4, 0.2, 0.0, 0.0)


@pytest.mark.parametrize("msg", [
    JointState(name=["pan"], position=[0.1]),
    JointState(name=["pan", "tilt"], position=[0.1]),
    JointState(name=["pan", "tilt"], position=[0.1, math.nan]),
    JointState(name=["pan", "tilt"], position=[0.1, 0.2], velocity=[0.0]),
])
def test_bad_messages_raise_message_error(msg) -> None:
    with pytest.raises(MessageError):
        joint_state_to_sample(msg)


def test_non_finite_sample_is_refused() -> None:
    with pytest.raises(MessageError):
        pan_tilt_to_joint_state(PanTiltSample(math.inf, 0.0))
