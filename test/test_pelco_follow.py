# SPDX-License-Identifier: Apache-2.0
"""Following a moving target: feed-forward of its rate, coasting while occluded, stale inputs (issue 34)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from test_pelco_bridge import Rig

from swir_tracker_ros.pelco.controller import PanTiltController
from swir_tracker_ros.pelco.follow import Demand, Follower, carried_error, coast_factor, lead_factor
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.speed_table import SpeedTable
from swir_tracker_ros.types import TrackState

P = PositionerParams(port="loop://")


def test_coast_factor_holds_then_fades_out() -> None:
    assert coast_factor(0.0, 1.0, 1.0) == coast_factor(1.0, 1.0, 1.0) == 1.0
    assert coast_factor(1.5, 1.0, 1.0) == pytest.approx(0.5)
    assert coast_factor(2.0, 1.0, 1.0) == coast_factor(9.0, 1.0, 1.0) == 0.0
    assert coast_factor(1.01, 1.0, 0.0) == 0.0  # no decay: off at once


def test_carried_error_moves_the_error_on_by_the_rate_difference_over_its_age() -> None:
    assert carried_error(0.01, 0.02, 0.02, 0.2, 0.25) == 0.01  # head as fast as the target: unchanged
    assert carried_error(0.01, 0.02, 0.0, 0.1, 0.25) == pytest.approx(0.01 + 0.02 * 0.1)
    assert carried_error(0.01, 0.02, 0.0, 5.0, 0.25) == pytest.approx(0.01 + 0.02 * 0.25)  # capped


def test_follower_feeds_a_fresh_rate_forward_and_drops_a_stale_one() -> None:
    f = Follower(P)
    assert f.demand(0.0, (0.0, 0.0)).startswith("watchdog")
    f.on_error(0.01, 0.002, now=10.0, age=0.08)  # the head lags the target: its rate is trusted in full
    f.on_rate(0.014, 0.001, now=10.0, age=0.08)
    d = f.demand(10.02, (0.014, 0.0))
    assert isinstance(d, Demand) and d.feed_forward == (0.014, 0.001) and f.feed_forward_on
    assert d.error_age == pytest.approx(0.10)
    assert d.pan_error == pytest.approx(0.01) and d.tilt_error == pytest.approx(0.002 + 0.001 * 0.10)
    f.on_rate(0.014, 0.001, now=10.0, age=P.max_input_age + 0.01)  # the rate's frame is too old
    d = f.demand(10.02, (0.0, 0.0))
    assert d.feed_forward == (0.0, 0.0) and not f.feed_forward_on and d.pan_error == 0.01
    f.on_state(TrackState.LOST, 10.03)
    assert f.demand(10.04, (0.0, 0.0)) == "tracker lost"


def test_occlusion_coasts_on_the_last_measured_rate_for_a_bounded_time() -> None:
    """While occluded the head keeps the rate the target had while last tracked (the median of the last
    half second: not the sag as it slid behind the occluder, nor the tracker's own slowing prediction),
    for coast_time, then fades it out; the predicted error steers with occluded_gain."""
    f = Follower(replace(P, coast_time=1.0, coast_decay=1.0, occluded_gain=0.0))
    f.on_state(TrackState.TRACKING, -0.4)
    for k, rate in enumerate([0.03, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 0.012, 0.008]):
        f.on_error(0.0, 0.0, now=-0.4 + 0.05 * k)
        f.on_rate(rate, 0.0, now=-0.4 + 0.05 * k)
    f.on_state(TrackState.OCCLUDED, 0.1)
    for t, weight in ((0.6, 1.0), (1.6, 0.5), (2.6, 0.0)):
        f.on_error(-0.3, 0.0, now=t)  # the prediction has fallen behind the head
        f.on_rate(0.005, 0.0, now=t)  # and slows down
        d = f.demand(t, (0.02, 0.0))
        assert d.feed_forward[0] == pytest.approx(0.02 * weight) and d.gain == 0.0, t
    f.on_state(TrackState.TRACKING, 2.7)
    f.on_error(0.0, 0.0, now=2.7)
    f.on_rate(0.015, 0.0, now=2.7)
    assert f.demand(2.7, (0.0, 0.0)).feed_forward[0] == pytest.approx(0.015)  # seen again: its own rate
    f.reset()
    f.on_state(TrackState.OCCLUDED, 3.0)
    f.on_error(0.0, 0.0, now=3.0)
    assert f.demand(3.0, (0.0, 0.0)).feed_forward == (0.0, 0.0)  # no rate measured before: no coasting


def test_controller_follows_the_feed_forward_inside_the_deadband_and_adds_it_outside() -> None:
    p = replace(P, deadband=0.01, max_accel=0.0)
    table = SpeedTable()
    cmd = PanTiltController(p).step(0.001, 0.0, 0.05, feed_forward=(-0.02, 0.0))
    assert cmd.pan_dir == 1 and cmd.pan_speed == table.byte_for(math.degrees(0.02))  # Pelco right = -pan
    assert PanTiltController(p).step(0.001, 0.0, 0.05, feed_forward=(1e-4, 0.0)).is_stop  # below byte 1
    cmd = PanTiltController(p).step(0.05, 0.0, 0.05, feed_forward=(0.02, 0.0))
    assert cmd.pan_speed == table.byte_for(math.degrees(p.kp * 0.05 + 0.02))


def _closed_loop(rig: Rig, target, heard_rate, latency: float, until: float):
    """Drive the fake-clock rig's simulated head after a target at angle target(t) (rad, pan): the bridge
    hears the error `latency` s late and the rate heard_rate(t); yields (t, target, head) every 0.04 s."""
    history: list[tuple[float, float]] = []
    while rig.t < until:
        t, head = rig.t, math.radians(rig.link.head.pan.angle)
        history.append((t, target(t) - head))
        seen = [e for s, e in history if s <= t - latency]
        rate = heard_rate(t)
        if seen:
            rig.bridge.on_error(seen[-1], 0.0, now=t, age=latency)
            rig.bridge.on_rate(rate, 0.0, now=t, age=latency)
        rig.run(0.04)
        yield t, target(t), head


def _ramp_lag(feed_forward: float) -> float:
    """Mean |error| over the last 5 s of a target moving at a constant 1 deg/s, the error seen with a
    0.1 s latency (the tracker's), on the fake-clock rig with a simulated head."""
    rig = Rig(feed_forward=feed_forward, kp=1.0, deadband=0.0005, max_accel=0.5)
    rate = math.radians(1.0)
    loop = _closed_loop(rig, lambda t: rate * t, lambda t: rate, 0.1, 12.0)
    lag = [abs(target - head) for t, target, head in loop if t > 7.0]
    return sum(lag) / len(lag)


def test_feed_forward_removes_the_lag_of_a_proportional_loop_on_a_ramp() -> None:
    without, with_ff = _ramp_lag(0.0), _ramp_lag(1.0)
    assert without == pytest.approx(math.radians(1.0) / 1.0, rel=0.25)  # rate / kp: the P loop's lag
    assert with_ff < 0.25 * without


def test_lead_factor_trusts_the_rate_while_the_head_lags_and_fades_it_as_the_head_leads() -> None:
    assert lead_factor(0.01, 0.02, 0.005) == 1.0 and lead_factor(0.0, 0.02, 0.005) == 1.0  # lagging / on it
    assert lead_factor(-0.0025, 0.02, 0.005) == pytest.approx(0.5)  # ahead of a target moving +
    assert lead_factor(0.0025, -0.02, 0.005) == pytest.approx(0.5)  # ahead of a target moving -
    assert lead_factor(-0.01, 0.02, 0.005) == 0.0 and lead_factor(-0.01, 0.02, 0.0) == 1.0  # 0: off


def _overshoot_at_a_stop(lead_limit: float) -> float:
    """How far (rad) the head runs past a target that walks at 1.5 deg/s for 6 s and stops, on the
    fake-clock rig; the rate reaches the bridge through a first-order lag of 0.5 s (a Kalman velocity
    follows a stop over several frames) and the error 0.04 s late."""
    rig = Rig(lead_limit=lead_limit, max_accel=0.5)
    true_rate, stop_at, measured = math.radians(1.5), 6.0, [0.0]

    def heard(t: float) -> float:  # first-order lag of the true rate, 0.04 s steps
        measured[0] += ((true_rate if t < stop_at else 0.0) - measured[0]) * 0.04 / 0.5
        return measured[0]

    loop = _closed_loop(rig, lambda t: true_rate * min(t, stop_at), heard, 0.04, 9.0)
    return max(head - target for t, target, head in loop if t > stop_at)


def test_fading_the_rate_as_the_head_leads_cuts_the_overshoot_when_the_target_stops() -> None:
    assert _overshoot_at_a_stop(0.003) < 0.7 * _overshoot_at_a_stop(0.0)
