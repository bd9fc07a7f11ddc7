# SPDX-License-Identifier: Apache-2.0
"""msg_adapters.rate (the target's angular rate) and msg_adapters.head (the head's control surface)."""

from __future__ import annotations

import math

import pytest

from msg_adapters.camera_info import intrinsics_from_fov
from msg_adapters.errors import MessageError
from msg_adapters.geometry import pan_tilt_error
from msg_adapters.head import (
    head_joint_state,
    jog_msg,
    jog_rates,
    joint_positions,
    mode_from_msg,
    mode_from_request,
    mode_msg,
    move_goal_msg,
    move_request,
    set_mode_reply,
    set_mode_request,
    set_mode_result,
)
from msg_adapters.joint_state import PanTiltSample, joint_state_to_sample
from msg_adapters.rate import head_rate, target_rate

INTR = intrinsics_from_fov(576, 504, 8.0)


@pytest.mark.parametrize("u, v", [(288.0, 252.0), (40.0, 460.0), (500.0, 30.0)])
def test_target_rate_is_the_time_derivative_of_the_error(u, v) -> None:
    """A box centre moving (du, dv) px per frame: the rate equals the finite difference of
    `pan_tilt_error` over one frame period (REP-103: moving right in the image is a negative pan rate)."""
    du, dv, period = 2.3, -0.7, 0.04
    rate = target_rate(u, v, (du, dv), period, INTR)
    e0, e1 = pan_tilt_error(u, v, INTR), pan_tilt_error(u + du, v + dv, INTR)
    assert rate[0] == pytest.approx((e1[0] - e0[0]) / period, rel=2e-3) and rate[0] < 0.0
    assert rate[1] == pytest.approx((e1[1] - e0[1]) / period, rel=2e-3) and rate[1] > 0.0
    moved = target_rate(u, v, (du, dv), period, INTR, head_rate=(0.01, -0.02))
    assert moved == pytest.approx((rate[0] + 0.01, rate[1] - 0.02))  # without ego-motion compensation


def test_head_rate_from_the_pose_history() -> None:
    def pose_at(t: float) -> tuple[float, float] | None:
        return (0.1 * t, -0.05 * t) if t >= 0 else None

    assert head_rate(pose_at, 2.0, 0.04) == pytest.approx((0.1, -0.05))
    assert head_rate(pose_at, 0.01, 0.04) is None and head_rate(pose_at, 2.0, 0.0) is None


def test_mode_messages_and_requests_round_trip() -> None:
    name, reason, stamp = mode_from_msg(mode_msg("released", "operator", 12.5))
    assert (name, reason, stamp) == ("released", "operator", 12.5)
    assert mode_from_request(set_mode_request("manual")) == "manual"
    with pytest.raises(MessageError, match="idle"):
        set_mode_request("drifting")
    request = set_mode_request("idle")
    request.mode = 9
    with pytest.raises(MessageError, match="TRACKING=1"):
        mode_from_request(request)
    from swir_tracker_interfaces.srv import SetHeadMode

    reply = set_mode_reply(SetHeadMode.Response(), True, "ok", "tracking")
    assert set_mode_result(reply) == (True, "ok", "tracking") and set_mode_result(None)[0] is False


def test_jogs_and_moves_name_the_bridge_joints_and_refuse_others() -> None:
    assert jog_rates(jog_msg({"tilt": -0.1}), "pan", "tilt") == (0.0, -0.1)
    assert jog_rates(jog_msg({"az": 0.2}), "az", "el") == (0.2, 0.0)  # joint names from parameters
    with pytest.raises(MessageError, match="unknown joints"):
        jog_rates(jog_msg({"roll": 0.1}), "pan", "tilt")
    bad = jog_msg({"pan": 0.1})
    bad.velocities = [0.1, 0.2]
    with pytest.raises(MessageError, match="2 velocities"):
        jog_rates(bad, "pan", "tilt")
    with pytest.raises(MessageError, match="finite"):
        jog_rates(jog_msg({"pan": math.inf}), "pan", "tilt")
    req = move_request(move_goal_msg("relative", {"pan": 0.1}, tolerance=0.001), "pan", "tilt")
    assert (req.kind, req.pan, req.tilt, req.tolerance) == ("relative", 0.1, None, 0.001)
    assert move_request(move_goal_msg("preset", {"roll": 1.0}, preset=4), "pan", "tilt").preset == 4
    goal = move_goal_msg("absolute", {"pan": 0.1})
    goal.kind = 7
    with pytest.raises(MessageError, match="ABSOLUTE=0"):
        move_request(goal, "pan", "tilt")


def test_joint_state_under_the_bridge_names_with_the_zoom() -> None:
    sample = PanTiltSample(0.1, -0.2, 0.01, 0.0, 3.0)
    msg = head_joint_state(sample, "head", zoom=0.25)
    assert joint_positions(msg) == {"pan": 0.1, "tilt": -0.2, "zoom": 0.25}
    assert joint_state_to_sample(msg) == sample  # the tracker's reader still finds pan and tilt
    assert list(head_joint_state(sample, names=("az", "el")).name) == ["az", "el"]
