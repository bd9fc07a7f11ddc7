# SPDX-License-Identifier: Apache-2.0
"""The bridge's control surface as processes against pelco_sim (issue 34): moves with feedback, presets,
jog dead-man, release and take-back, the lifecycle; every byte on the wire is checked."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import rclpy
from conftest import REPO, ros_probe
from geometry_msgs.msg import Vector3Stamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import JointState
from test_pelco_sim import read_trace, start_sim

from msg_adapters.head import (
    jog_msg,
    joint_positions,
    mode_from_msg,
    move_goal_msg,
    move_result_values,
    preset_request,
    set_mode_request,
    set_mode_result,
)
from msg_adapters.qos import profile
from msg_adapters.trigger import trigger_result
from swir_tracker_interfaces.action import MoveHead
from swir_tracker_interfaces.msg import HeadJog, HeadMode
from swir_tracker_interfaces.srv import HeadPreset, SetHeadMode
from swir_tracker_ros import topics
from swir_tracker_ros.pelco import codec

STOP = codec.stop(1)


class Operator:
    """The test's side: an operator's console (action, services, jog) plus the tracker's error stream."""

    def __init__(self, ctx: Context) -> None:
        self.node = Node("operator_probe", context=ctx)
        self.joints: list[dict[str, float]] = []
        self.modes: list[tuple[str, str, float]] = []
        self.node.create_subscription(JointState, topics.JOINT_STATES,
                                      lambda m: self.joints.append(joint_positions(m)), 10)
        self.node.create_subscription(HeadMode, topics.HEAD_MODE,
                                      lambda m: self.modes.append(mode_from_msg(m)), profile(topics.LATCHED))
        self.jog_pub = self.node.create_publisher(HeadJog, topics.HEAD_JOG, 10)
        self.err_pub = self.node.create_publisher(Vector3Stamped, topics.PAN_TILT_ERROR, 10)
        self.move = ActionClient(self.node, MoveHead, topics.HEAD_MOVE)
        self.clients = {name: self.node.create_client(cls, name) for name, cls in (
            (topics.HEAD_SET_MODE, SetHeadMode), (topics.HEAD_SET_PRESET, HeadPreset),
            (topics.HEAD_GOTO_PRESET, HeadPreset), ("/positioner_bridge/change_state", ChangeState),
            ("/positioner_bridge/get_state", GetState))}
        self.executor = rclpy.executors.SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)

    def spin(self, seconds: float, every=None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if every is not None:
                every()
            self.executor.spin_once(timeout_sec=0.05)

    def until(self, predicate, timeout: float = 20.0, every=None) -> bool:
        """Spin (calling `every` each 0.05 s) until predicate() holds: DDS discovery between two processes
        takes its time on a loaded machine, so the first messages may not be heard."""
        end = time.monotonic() + timeout
        while time.monotonic() < end and not predicate():
            self.spin(0.1, every)
        return bool(predicate())

    def wait(self, future, timeout: float = 30.0):
        end = time.monotonic() + timeout
        while not future.done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        assert future.done(), "no answer"
        return future.result()

    def call(self, name: str, request, timeout: float = 30.0):
        client = self.clients[name]
        end = time.monotonic() + timeout
        while not client.service_is_ready() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return self.wait(client.call_async(request), timeout)

    def run_move(self, goal) -> tuple[tuple, int]:
        """(result values, feedback messages received) of one MoveHead goal."""
        end = time.monotonic() + 30.0
        while not self.move.server_is_ready() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        feedback: list = []
        handle = self.wait(self.move.send_goal_async(goal, feedback_callback=feedback.append))
        result = self.wait(handle.get_result_async(), 40.0)
        return move_result_values(result.result), len(feedback)

    def error(self, pan: float) -> None:
        msg = Vector3Stamped()
        msg.vector.x = pan
        self.err_pub.publish(msg)


@pytest.fixture
def operator() -> Iterator[Operator]:
    with ros_probe(Operator) as p:
        yield p


def pan_velocity(trace: Path) -> float:
    """The simulated head's pan rate in its newest complete trace row (0 before the first)."""
    rows = read_trace(trace)
    return rows[-1]["pan_velocity"] if rows else 0.0


def wire(path: Path) -> list[tuple[float, bytes]]:
    """pelco_sim's --wire-log: (unix time, bytes) of every chunk read from the line."""
    if not path.exists():
        return []
    return [(float(t), bytes.fromhex(h)) for t, h in (line.split() for line in path.read_text().splitlines())]


def assert_every_frame_valid(chunks: list[tuple[float, bytes]]) -> None:
    decoder = codec.StreamDecoder()
    frames = [f for _, data in chunks for f in decoder.feed(data)]
    assert frames and decoder.checksum_errors == 0 and decoder.discarded == 0, vars(decoder)
    assert sum(len(d) for _, d in chunks) == 7 * len(frames)  # no byte outside a valid frame


def start(processes, tmp_path: Path, *params: str, managed: bool = False):
    log = tmp_path / "wire.txt"
    sim, url, trace = start_sim(processes, tmp_path, "--link", str(tmp_path / "pelco"),
                                "--wire-log", str(log))
    args = ["--managed"] if managed else []
    args += ["--ros-args", "--params-file", str(REPO / "params" / "positioner.yaml"), "-p", f"port:={url}"]
    for p in params:
        args += ["-p", p]
    return sim, processes.start("positioner_bridge", *args), trace, log


def test_moves_with_feedback_a_preset_round_trip_and_reasons_for_bad_requests(processes, tmp_path, operator):
    _sim, bridge, trace, log = start(processes, tmp_path)
    end = time.monotonic() + 30.0
    while not operator.joints and time.monotonic() < end:
        operator.spin(0.1)
    assert operator.joints, processes.log(bridge)
    (ok, message, final, errors), feedback = operator.run_move(move_goal_msg("absolute", {"pan": 0.05,
                                                                                           "tilt": -0.03}))
    assert ok and feedback >= 1, (message, processes.log(bridge))
    assert final["pan"] == pytest.approx(0.05, abs=0.002) and final["tilt"] == pytest.approx(-0.03, abs=0.002)
    assert all(abs(e) <= 0.002 for e in errors)
    stored = trigger_result(operator.call(topics.HEAD_SET_PRESET, preset_request(7)))
    assert stored == (True, "preset 7 stored")
    (ok, _, final, _), _ = operator.run_move(move_goal_msg("relative", {"pan": -0.1}))
    assert ok and final["pan"] == pytest.approx(-0.05, abs=0.003)
    (ok, message, final, _), _ = operator.run_move(move_goal_msg("preset", preset=7))
    assert ok, message
    rows = read_trace(trace)
    assert rows[-1]["pan"] == pytest.approx(0.05, abs=0.002)  # back at the pose stored as preset 7
    assert rows[-1]["tilt"] == pytest.approx(-0.03, abs=0.002)
    (ok, message, _, _), _ = operator.run_move(move_goal_msg("absolute", {"roll": 0.1}))
    assert not ok and "unknown joints ['roll']" in message
    ok, message = trigger_result(operator.call(topics.HEAD_GOTO_PRESET, preset_request(0)))
    assert not ok and "1-255" in message
    assert [m[0] for m in operator.modes][-1] == "manual" and bridge.poll() is None
    assert_every_frame_valid(wire(log))


def test_a_jog_stops_by_itself_release_is_silent_and_a_take_back_starts_with_a_stop(
        processes, tmp_path, operator):
    _sim, bridge, trace, log = start(processes, tmp_path)
    def jog() -> None:  # the operator holds the stick
        operator.jog_pub.publish(jog_msg({"pan": 0.1}))

    def moving() -> bool:
        return pan_velocity(trace) > 0.0

    assert operator.until(moving, every=jog), processes.log(bridge)
    operator.spin(0.5, every=jog)
    t_last_jog = time.time()
    operator.spin(2.0)  # no more jogs, no other command: the bridge's dead-man stops the head
    assert pan_velocity(trace) == 0.0
    assert any(t > t_last_jog and data.endswith(STOP) for t, data in wire(log))
    ok, message, mode = set_mode_result(operator.call(topics.HEAD_SET_MODE, set_mode_request("released")))
    assert ok and mode == "released", message
    t_released = time.time()
    operator.spin(10.5, every=lambda: operator.error(0.1))  # the tracker asks for motion all along
    after = [c for c in wire(log) if c[0] > t_released]  # the simulator may read the stop a few ms late
    assert all(data == STOP and t < t_released + 0.5 for t, data in after), after
    # so from 0.5 s after the answer: 10 s, 0 bytes on the bus, not even a keep-alive or a query
    late: list = []
    node = operator.node
    node.create_subscription(HeadMode, topics.HEAD_MODE, lambda m: late.append(mode_from_msg(m)[0]),
                             profile(topics.LATCHED))
    operator.spin(1.0)
    assert late == ["released"]  # a late subscriber learns who owns the head
    t_take = time.time()
    ok, _, mode = set_mode_result(operator.call(topics.HEAD_SET_MODE, set_mode_request("tracking")))
    assert ok and mode == "tracking"
    operator.spin(1.0, every=lambda: operator.error(0.1))
    after = b"".join(data for t, data in wire(log) if t > t_take)
    assert after.startswith(STOP) and len(after) > len(STOP)
    assert_every_frame_valid(wire(log))


def test_lifecycle_configure_activate_deactivate_cleanup(processes, tmp_path, operator):
    _sim, bridge, trace, log = start(processes, tmp_path, managed=True)

    def transition(tid: int) -> bool:
        return bool(operator.call("/positioner_bridge/change_state",
                                  ChangeState.Request(transition=Transition(id=tid))).success)

    operator.call("/positioner_bridge/get_state", GetState.Request())
    assert wire(log) == []  # unconfigured: the port is not even open
    assert transition(Transition.TRANSITION_CONFIGURE), processes.log(bridge)
    assert "the head answers" in processes.log(bridge)
    configured = wire(log)
    assert configured and all(data == codec.query(1, "pan") for _, data in configured)  # the check only
    t_active = time.time()
    assert transition(Transition.TRANSITION_ACTIVATE)
    def moving() -> bool:
        return pan_velocity(trace) > 0.0

    assert operator.until(moving, every=lambda: operator.error(0.1)), processes.log(bridge)
    assert b"".join(d for t, d in wire(log) if t >= t_active).startswith(STOP)
    assert operator.until(lambda: ("tracking", "lifecycle activate") in [m[:2] for m in operator.modes])
    t_inactive = time.time()
    assert transition(Transition.TRANSITION_DEACTIVATE)
    operator.spin(1.0, every=lambda: operator.error(0.1))
    assert pan_velocity(trace) == 0.0
    quiet = [d for t, d in wire(log) if t >= t_inactive]
    assert quiet and quiet[-1].endswith(STOP)  # the stop, then silence while inactive
    assert transition(Transition.TRANSITION_CLEANUP) and "port closed" in processes.log(bridge)
    state = operator.call("/positioner_bridge/get_state", GetState.Request()).current_state.label
    assert state == "unconfigured"
    assert_every_frame_valid(wire(log))
    assert processes.stop(bridge) == 0 and "terminate called" not in processes.log(bridge)
