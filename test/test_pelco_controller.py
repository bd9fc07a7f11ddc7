# SPDX-License-Identifier: Apache-2.0
"""Error -> speed bytes: sign convention, deadband, speed table, min/max, slew, invert, soft limits, PI."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from swir_tracker_ros.errors import ParameterError, PelcoError
from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.controller import PanTiltController, limit_guard, slew
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.speed_table import SpeedTable, parse_table
from swir_tracker_ros.pelco.units import angle_to_raw, raw_to_angle

P = PositionerParams()


def test_speed_table_interpolates_and_inverts() -> None:
    t = SpeedTable()
    assert t.speed(0) == 0.0
    assert t.speed(24) == 5.0 and t.speed(28) == pytest.approx(7.5)
    assert t.speed(codec.TURBO) == 60.0
    for b in range(1, 64):
        assert t.byte_for(t.speed(b)) == b
    assert t.byte_for(1000.0) == 63 and t.byte_for(1000.0, hi=40) == 40
    assert t.byte_for(0.001) == 1 and t.byte_for(0.001, lo=5) == 5
    assert t.byte_for(0.0) == 0
    with pytest.raises(PelcoError):
        SpeedTable((1.0, 8.0), (2.0, 1.0))
    assert parse_table("1:0.5, 63:30") == ((1.0, 63.0), (0.5, 30.0))


def test_positive_errors_move_left_and_up_at_the_table_speed() -> None:
    c = PanTiltController(replace(P, max_accel=0.0))
    cmd = c.step(0.1, 0.05, 0.05)
    # pan + = left (CCW from above) -> Pelco left; tilt + = up -> Pelco up (docs/interfaces.md).
    assert (cmd.pan_dir, cmd.tilt_dir) == (-1, 1)
    t = SpeedTable()
    assert cmd.pan_speed == t.byte_for(math.degrees(P.kp * 0.1))
    assert cmd.tilt_speed == t.byte_for(math.degrees(P.kp * 0.05))
    cmd = PanTiltController(P).step(-0.1, -0.05, 0.05)
    assert (cmd.pan_dir, cmd.tilt_dir) == (1, -1)
    assert cmd.to_bytes(1)[3] == codec.PAN_RIGHT | codec.TILT_DOWN


def test_invert_flips_the_pelco_direction() -> None:
    cmd = PanTiltController(replace(P, invert_pan=True, invert_tilt=True)).step(0.1, 0.05, 0.05)
    assert (cmd.pan_dir, cmd.tilt_dir) == (1, -1)


def test_deadband_stops_and_resets() -> None:
    c = PanTiltController(replace(P, deadband=0.01))
    assert not c.step(0.02, 0.0, 0.05).is_stop
    cmd = c.step(0.009, -0.009, 0.05)
    assert cmd.is_stop and cmd.to_bytes(1) == codec.stop(1)
    assert c.pan.omega == 0.0


def test_min_and_max_speed_bytes_clamp() -> None:
    c = PanTiltController(replace(P, min_speed_byte=10, max_speed_byte=30, deadband=0.0001, max_accel=0.0))
    assert c.step(0.0002, 0.0, 0.05).pan_speed == 10
    assert c.step(3.0, 0.0, 0.05).pan_speed == 30


def test_turbo_only_when_allowed_and_only_on_pan() -> None:
    p = replace(P, kp=10.0, max_accel=0.0)
    assert PanTiltController(p).step(3.0, 3.0, 0.05).pan_speed == 63
    cmd = PanTiltController(replace(p, allow_turbo=True)).step(3.0, 3.0, 0.05)
    assert cmd.pan_speed == codec.TURBO and cmd.tilt_speed == 63


def test_slew_rate_limits_acceleration_but_never_delays_a_stop() -> None:
    p = replace(P, kp=10.0, max_accel=0.5)  # 0.5 rad/s^2 -> 0.025 rad/s per 50 ms period
    c = PanTiltController(p)
    speeds = [c.step(0.2, 0.0, 0.05).pan_speed for _ in range(10)]
    assert speeds == sorted(speeds) and speeds[0] < speeds[-1]
    assert c.pan.omega == pytest.approx(10 * 0.025)
    assert c.step(0.0, 0.0, 0.05).is_stop  # inside the deadband: immediate stop
    assert slew(0.3, 0.0, 0.5, 0.05) == 0.0
    assert slew(0.0, 1.0, 0.5, 0.1) == pytest.approx(0.05)


def test_reversal_passes_through_a_stop() -> None:
    c = PanTiltController(replace(P, kp=2.0, max_accel=1.0))
    for _ in range(20):
        c.step(0.2, 0.0, 0.05)
    cmd = c.step(-0.2, 0.0, 0.05)
    assert cmd.pan_dir == 0  # omega still positive while ramping toward the negative target


def test_soft_limits_block_outward_motion_only_when_position_known() -> None:
    p = replace(P, tilt_min=-0.2, tilt_max=0.3, pan_min=-1.0, pan_max=1.0, limit_lookahead=0.2)

    def step(*args, **kw):
        return PanTiltController(p).step(*args, **kw)

    assert step(0.0, 0.1, 0.05, tilt=0.30).tilt_dir == 0  # at tilt_max
    assert step(0.0, -0.1, 0.05, tilt=0.35).tilt_dir == -1  # back toward the range is allowed
    assert step(0.0, 0.1, 0.05, tilt=None).tilt_dir == 1  # unknown position: not enforced
    assert step(0.0, 0.1, 0.05, tilt=0.0).tilt_dir == 1
    assert step(0.5, 0.0, 0.05, pan=1.05).pan_dir == 0
    assert step(-0.5, 0.0, 0.05, pan=-1.2).pan_dir == 0
    assert step(0.5, 0.0, 0.05, pan=-1.2).pan_dir == -1
    assert limit_guard(0.5, 0.0, -1.0, 1.0, 0.2) == 0.5
    assert limit_guard(0.5, 0.95, -1.0, 1.0, 0.2) == pytest.approx(0.25)  # slows down on approach
    assert limit_guard(-0.5, 0.95, -1.0, 1.0, 0.2) == -0.5


def test_pi_integral_grows_and_is_bounded() -> None:
    p = replace(P, kp=0.0, ki=1.0, integral_limit=0.05, max_accel=0.0, deadband=0.001)
    c = PanTiltController(p)
    first = c.step(0.1, 0.0, 0.05).pan_speed
    for _ in range(100):
        last = c.step(0.1, 0.0, 0.05).pan_speed
    assert first < last == SpeedTable().byte_for(math.degrees(0.05))


def test_position_words_round_trip_and_vendor_sign() -> None:
    # The reference reply "pan 123.45 deg" on a head whose word grows to the right is 123.45 deg right.
    assert math.degrees(raw_to_angle(12345, -1, 0.0)) == pytest.approx(-123.45)
    assert math.degrees(raw_to_angle(35000, -1, 0.0)) == pytest.approx(10.0)  # 36000 - x: up for tilt
    for deg in (-179.99, -45.0, 0.0, 12.34, 180.0):
        for sign in (-1, 1):
            raw = angle_to_raw(math.radians(deg), sign, 30.0)
            assert 0 <= raw < 36000
            assert math.degrees(raw_to_angle(raw, sign, 30.0)) == pytest.approx(deg, abs=0.006)


def test_default_params_validate_and_match_metadata() -> None:
    validate_params(PositionerParams().validate())


@pytest.mark.parametrize("change", [
    {"pan_position_sign": 0}, {"min_speed_byte": 40, "max_speed_byte": 20},
    {"tilt_min": 1.0, "tilt_max": 0.5},
    {"pan_speed_table": [1.0, 2.0]}, {"tilt_speed_table": list(range(9, 0, -1))}, {"watchdog_timeout": 0.0},
    {"keepalive_period": 0.01}, {"port": ""}, {"kp": math.nan}, {"pan_turbo_speed": 1.0},
])
def test_invalid_params_raise_naming_the_field(change) -> None:
    with pytest.raises(ParameterError) as err:
        replace(P, **change).validate()
    assert any(name.split("_")[0] in str(err.value) for name in change)
