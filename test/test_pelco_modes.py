# SPDX-License-Identifier: Apache-2.0
"""Who owns the head and the operator's commands, on the fake-clock rig: modes, jog, moves, presets, zoom."""

from __future__ import annotations

import math

import pytest
from test_pelco_bridge import Rig

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.bridge import HeadMode, MoveGoal, MoveKind

STOP = codec.Frame(1, 0, 0, 0, 0)


def frames_after(rig: Rig, n: int) -> list[codec.Frame]:
    return rig.link.written[n:]


def test_release_writes_a_stop_then_nothing_and_a_take_back_starts_with_a_stop() -> None:
    rig = Rig()
    rig.run(1.0, error=(0.1, 0.0))
    assert rig.bridge.mode == HeadMode.TRACKING and rig.link.head.pan.velocity > 0.0
    n = len(rig.link.written)
    ok, text = rig.bridge.set_mode(HeadMode.RELEASED, "test", now=rig.t)
    assert ok and "released" in text
    assert frames_after(rig, n) == [STOP]
    n = len(rig.link.written)
    rig.run(5.0, error=(0.1, 0.0))  # tracking errors keep coming: nothing, not even keep-alives or queries
    assert frames_after(rig, n) == []
    assert rig.bridge.jog(0.1, 0.0, now=rig.t)[0] is False
    assert not rig.bridge.preset("set", 3)[0] and "released" in rig.bridge.preset("set", 3)[1]
    assert rig.bridge.shutdown() == "released" and frames_after(rig, n) == []  # leaves without a word
    rig = Rig()
    rig.run(0.5)
    rig.bridge.set_mode(HeadMode.RELEASED, "test", now=rig.t)
    rig.run(1.0)
    n = len(rig.link.written)
    rig.bridge.set_mode(HeadMode.TRACKING, "take back", now=rig.t)
    rig.run(0.5, error=(0.1, 0.0))
    assert frames_after(rig, n)[0] == STOP and len(frames_after(rig, n)) > 1


def test_tracking_errors_move_the_head_only_in_tracking_mode() -> None:
    rig = Rig(initial_mode="idle")
    rig.run(1.0, error=(0.1, 0.05))
    assert rig.link.head.pan.velocity == 0.0 and rig.bridge.reason == "idle"
    assert all(m[0] == 0 and m[2] == 0 for m in rig.motions())
    rig.bridge.set_mode(HeadMode.TRACKING, "test", now=rig.t)
    rig.run(1.0, error=(0.1, 0.05))
    assert rig.link.head.pan.velocity > 0.0


def test_a_jog_preempts_tracking_with_a_stop_first_and_stops_by_itself() -> None:
    rig = Rig()
    rig.run(1.0, error=(0.1, 0.0))
    n = len(rig.link.written)
    assert rig.bridge.jog(-0.05, 0.02, now=rig.t) == (True, "jogging")
    assert rig.bridge.mode == HeadMode.MANUAL and frames_after(rig, n)[0] == STOP
    for _ in range(10):  # an operator holding the stick, 10 jogs/s, while the tracker still publishes
        rig.bridge.jog(-0.05, 0.02, now=rig.t)
        rig.run(0.1, error=(0.1, 0.0))
    assert rig.link.head.pan.velocity < 0.0 < rig.link.head.tilt.velocity
    rig.run(rig.bridge.p.jog_timeout + 0.3, error=(0.1, 0.0))  # the jogs stop: the dead-man stops the head
    assert rig.link.head.pan.velocity == 0.0 and rig.link.head.tilt.velocity == 0.0
    assert [f for f in rig.link.written if not f.extended][-1] == STOP and rig.bridge.mode == HeadMode.MANUAL


def test_absolute_relative_and_preset_moves_complete_with_feedback() -> None:
    rig = Rig()
    rig.run(0.5)
    move, problem = rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, pan=0.2, tilt=-0.1), now=rig.t)
    assert problem == "" and rig.bridge.mode == HeadMode.MANUAL
    while not move.done and rig.t < 20.0:
        rig.run(0.1)
    assert move.success, move.outcome
    assert all(abs(e) <= rig.bridge.p.move_tolerance for e in move.errors) and len(move.errors) == 2
    assert math.radians(rig.link.head.pan.angle) == pytest.approx(0.2, abs=rig.bridge.p.move_tolerance)
    assert rig.bridge.preset("set", 5) == (True, "preset 5 stored")
    move, _ = rig.bridge.start_move(MoveGoal(MoveKind.RELATIVE, pan=-0.3), now=rig.t)
    while not move.done and rig.t < 40.0:
        rig.run(0.1)
    assert move.success and math.radians(rig.link.head.pan.angle) == pytest.approx(-0.1, abs=0.003)
    assert math.radians(rig.link.head.tilt.angle) == pytest.approx(-0.1, abs=0.003)  # tilt not named: kept
    move, _ = rig.bridge.start_move(MoveGoal(MoveKind.PRESET, preset=5), now=rig.t)
    while not move.done and rig.t < 60.0:
        rig.run(0.1)
    assert move.success and math.radians(rig.link.head.pan.angle) == pytest.approx(0.2, abs=0.003)


def test_bad_moves_are_refused_with_their_reason_and_a_cancel_stops_the_head() -> None:
    rig = Rig(tilt_max=0.5)
    move, problem = rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, pan=0.1), now=rig.t)
    assert move is None and "unknown" in problem  # no position feedback yet
    rig.run(0.5)
    assert "soft limits" in rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, tilt=0.6), now=rig.t)[1]
    assert "no joint" in rig.bridge.start_move(MoveGoal(MoveKind.RELATIVE), now=rig.t)[1]
    assert "1-255" in rig.bridge.start_move(MoveGoal(MoveKind.PRESET, preset=0), now=rig.t)[1]
    assert "finite" in rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, pan=math.nan), now=rig.t)[1]
    assert rig.bridge.mode == HeadMode.TRACKING  # a refused command takes nothing over
    move, _ = rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, pan=2.0), now=rig.t)
    rig.run(0.5)
    assert rig.link.head.pan.velocity != 0.0
    rig.bridge.cancel_move(move, now=rig.t)
    rig.run(0.5)
    assert move.done and not move.success and move.outcome == "cancelled"
    assert rig.link.head.pan.velocity == 0.0
    second, _ = rig.bridge.start_move(MoveGoal(MoveKind.ABSOLUTE, pan=1.0), now=rig.t)
    rig.bridge.jog(0.0, 0.01, now=rig.t)
    assert second.done and second.outcome == "pre-empted by a jog"


def test_zoom_runs_until_stopped_and_its_position_is_reported() -> None:
    rig = Rig(zoom_feedback=True)
    rig.run(0.5)
    assert rig.bridge.zoom(2)[0] is False
    assert rig.bridge.zoom(1, now=rig.t) == (True, "zooming in")
    rig.run(1.0)
    assert any(f.zoom == 1 for f in rig.link.written)
    rig.bridge.zoom(0, now=rig.t)
    rig.run(0.5)
    zoom = rig.bridge.feedback.zoom_position(rig.t)
    assert zoom is not None and 0.0 < zoom < 1.0
    assert zoom == pytest.approx(rig.link.head.zoom / rig.link.head.cfg.zoom_max, abs=0.01)


def test_the_configure_check_names_a_head_that_does_not_answer() -> None:
    import time

    from swir_tracker_ros.pelco.feedback import probe_head

    rig = Rig(address=2)  # the simulated head listens on address 1: nobody answers address 2
    rig.link.poll()
    b = rig.bridge
    problem = probe_head(b.link, b.decoder, b.feedback, 0.1, time.monotonic)
    assert "no reply from the head at address 2" in problem
    rig = Rig()
    rig.link.poll()
    b = rig.bridge
    assert probe_head(b.link, b.decoder, b.feedback, 0.1, time.monotonic) == ""
