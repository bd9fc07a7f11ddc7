# SPDX-License-Identifier: Apache-2.0
"""The ROS-free bridge core on a fake clock: watchdog, tracker state, keep-alive, reconnect, feedback."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.bridge import PositionerBridge
from swir_tracker_ros.pelco.head import HeadConfig, HeadModel
from swir_tracker_ros.pelco.link import SerialLink
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.types import TrackState

DT = 0.01


class HeadLink:
    """A SerialLink stand-in wired to a simulated head; `up = False` makes the port vanish."""

    def __init__(self, head: HeadModel | None = None) -> None:
        self.head = head or HeadModel(HeadConfig())
        self.up = True
        self.connected = False
        self.connects = self.failures = 0
        self.written: list[codec.Frame] = []
        self.pending = b""
        self.now = 0.0

    def poll(self, now=None) -> bool:
        if self.connected or not self.up:
            return False
        self.connected = True
        self.connects += 1
        return True

    def write(self, data: bytes) -> bool:
        if not (self.connected and self.up):
            self.connected = False
            return False
        for frame in codec.StreamDecoder().feed(data):
            self.written.append(frame)
            self.pending += self.head.apply(frame, self.now) or b""
        return True

    def read(self, size: int = 4096) -> bytes:
        out, self.pending = self.pending, b""
        return out

    def drain(self) -> bool:
        return self.connected

    def close(self) -> None:
        self.connected = False


class Rig:
    def __init__(self, **changes) -> None:
        self.t = 0.0
        self.link = HeadLink()
        self.bridge = PositionerBridge(replace(PositionerParams(port="loop://"), **changes), self.link,
                                       clock=lambda: self.t)

    def run(self, seconds: float, error: tuple[float, float] | None = None) -> None:
        end = self.t + seconds
        while self.t < end - 1e-9:
            if error is not None:
                self.bridge.on_error(*error, now=self.t)
            self.link.now = self.t
            self.bridge.step(self.t)
            self.link.head.advance(DT, self.t)
            self.t += DT

    def motions(self) -> list[tuple[int, int, int, int]]:
        return [m for f in self.link.written if (m := f.motion()) is not None]


def test_first_frame_is_a_stop_and_an_error_moves_the_head_left() -> None:
    rig = Rig()
    rig.run(0.05)
    assert rig.link.written[0].to_bytes() == codec.stop(1)
    rig.run(1.0, error=(0.1, 0.0))
    assert rig.motions()[-1][0] == -1  # Pelco left
    assert rig.link.head.pan.velocity > 0  # our pan + (CCW from above)
    assert rig.bridge.reason == "moving"


def test_watchdog_stops_after_the_last_error_message() -> None:
    rig = Rig(watchdog_timeout=0.5)
    rig.run(1.0, error=(0.1, 0.1))
    n = len(rig.link.written)
    rig.run(0.45)
    assert all(f.motion() != (0, 0, 0, 0) for f in rig.link.written[n:] if f.motion())
    rig.run(0.15)
    assert rig.motions()[-1] == (0, 0, 0, 0)
    assert rig.bridge.reason.startswith("watchdog")


@pytest.mark.parametrize("state, moves", [(TrackState.LOST, False), (TrackState.IDLE, False),
                                          (TrackState.TRACKING, True), (TrackState.OCCLUDED, True)])
def test_tracker_state_gates_motion(state, moves) -> None:
    rig = Rig(occluded_gain=0.5)
    rig.bridge.on_state(state)
    rig.run(0.5, error=(0.1, 0.0))
    assert (rig.motions()[-1] != (0, 0, 0, 0)) == moves


def test_occluded_gain_zero_stops_without_a_rate_to_coast_on() -> None:
    rig = Rig(occluded_gain=0.0)
    rig.bridge.on_state(TrackState.OCCLUDED)
    rig.run(0.5, error=(0.1, 0.0))
    assert rig.motions()[-1] == (0, 0, 0, 0)


def test_sends_on_change_or_keepalive_only() -> None:
    rig = Rig(keepalive_period=0.5, feedback_rate=0.0, control_rate=20.0, max_accel=0.0)
    rig.run(2.0, error=(0.1, 0.0))
    # one stop at connect, one move on the first control period, then a keep-alive every 0.5 s
    assert 4 <= len(rig.link.written) <= 6
    rig2 = Rig(keepalive_period=0.0, feedback_rate=0.0, max_accel=0.0)
    rig2.run(2.0, error=(0.1, 0.0))
    assert len(rig2.link.written) == 2


def test_port_loss_then_return_resumes_with_a_stop_first() -> None:
    rig = Rig()
    rig.run(0.5, error=(0.1, 0.0))
    rig.link.up = False
    rig.run(0.5, error=(0.1, 0.0))
    assert not rig.link.connected and rig.bridge.reason == "link down"
    n = len(rig.link.written)
    rig.link.up = True
    rig.run(0.5, error=(0.1, 0.0))
    assert rig.link.written[n].to_bytes() == codec.stop(1)
    assert rig.motions()[-1][0] == -1


def test_feedback_pose_soft_limit_and_shutdown() -> None:
    rig = Rig(tilt_max=math.radians(10.0), limit_lookahead=0.3)
    rig.run(3.0, error=(0.0, 0.5))  # keeps asking for up
    pose = rig.bridge.pose(rig.t)
    assert pose is not None
    head = rig.link.head
    assert pose.tilt == pytest.approx(math.radians(head.tilt.angle), abs=math.radians(2.0))
    assert 8.0 < head.tilt.angle < 10.2 and head.tilt.velocity == 0.0  # slowed down, stopped at the limit
    assert rig.bridge.feedback.replies > 10 and rig.bridge.decoder.checksum_errors == 0
    assert rig.bridge.shutdown() == "written"
    assert rig.link.written[-1].to_bytes() == codec.stop(1) and not rig.link.connected


def test_serial_link_never_raises_and_logs_an_outage_once() -> None:
    logs: list[tuple[str, str]] = []
    t = [0.0]
    link = SerialLink("socket://127.0.0.1:1", log=lambda lvl, txt: logs.append((lvl, txt)),
                      clock=lambda: t[0], backoff_min=0.1, backoff_max=0.4)
    tries = 0
    for _ in range(50):
        link.poll()
        assert link.write(b"x") is False and link.read() == b""
        t[0] += 0.05
        tries = link.failures
    assert not link.connected and 4 <= tries <= 10  # backoff doubles to 0.4 s
    assert len(logs) == 1 and logs[0][0] == "warn"
    loop = SerialLink("loop://", clock=lambda: t[0])
    assert loop.poll() and loop.write(codec.stop(1)) and loop.read() == codec.stop(1)
    loop.close()
