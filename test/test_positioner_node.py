# SPDX-License-Identifier: Apache-2.0
"""positioner_bridge and pelco_sim as separate processes over a real pty and over socket:// on loopback."""

from __future__ import annotations

import contextlib
import math
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest
import rclpy
from conftest import REPO, ros_probe
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import JointState
from test_pelco_sim import read_trace, start_sim

from msg_adapters.diagnostics import status_values
from msg_adapters.errors import MessageError
from msg_adapters.joint_state import joint_state_to_sample
from msg_adapters.track_state import track_result_to_msg
from swir_tracker_ros.pelco.speed_table import SpeedTable
from swir_tracker_ros.types import Box, TrackResult, TrackState

KP = 1.0
PUBLISHER = """
import sys, time, rclpy
from geometry_msgs.msg import Vector3Stamped
rclpy.init()
node = rclpy.create_node('fake_tracker')
pub = node.create_publisher(Vector3Stamped, '/track/pan_tilt_error', 10)
while True:
    msg = Vector3Stamped()
    msg.vector.x, msg.vector.y = float(sys.argv[1]), float(sys.argv[2])
    pub.publish(msg)
    time.sleep(0.04)
"""


class Probe:
    """The test's side of the graph: publishes tracker outputs, records joint states and diagnostics."""

    def __init__(self, ctx: Context) -> None:
        self.node = Node("positioner_probe", context=ctx)
        self.err_pub = self.node.create_publisher(Vector3Stamped, "/track/pan_tilt_error", 10)
        self.state_pub = self.node.create_publisher(DiagnosticArray, "/track/state", 10)
        self.joints: list = []
        self.diag: dict[str, str] = {}
        self.diag_ids: dict[str, str] = {}  # status name -> hardware_id
        self.node.create_subscription(JointState, "/positioner/joint_states",
                                      lambda m: self.joints.append(joint_state_to_sample(m)), 10)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 10)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)

    def _on_diag(self, msg: DiagnosticArray) -> None:
        self.diag_ids.update({st.name: st.hardware_id for st in msg.status})
        with contextlib.suppress(MessageError):
            self.diag = status_values(msg, "positioner")

    def run(self, seconds: float, error: tuple[float, float] | None = None, state: TrackState | None = None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if error is not None:
                msg = Vector3Stamped()
                msg.vector.x, msg.vector.y = error
                self.err_pub.publish(msg)
            if state is not None:
                result = TrackResult(box=Box(0.0, 0.0, 1.0, 1.0), state=state)
                self.state_pub.publish(track_result_to_msg(result, Vector3Stamped().header))
            self.executor.spin_once(timeout_sec=0.04)

    def until(self, predicate, timeout: float, error=None, state=None) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            self.run(0.1, error, state)
        return bool(predicate())


@pytest.fixture
def probe() -> Iterator[Probe]:
    with ros_probe(Probe) as p:
        yield p


def velocity_now(trace) -> tuple[float, float]:
    rows = read_trace(trace)
    return (rows[-1]["pan_velocity"], rows[-1]["tilt_velocity"]) if rows else (0.0, 0.0)


def expected_rate(error: float) -> float:
    """rad/s the head reaches for a constant error: P law, then the speed byte's table speed."""
    t = SpeedTable()
    return math.radians(t.speed(t.byte_for(math.degrees(KP * abs(error)))))


def start_bridge(processes, port: str, *extra: str):
    args = ["--ros-args", "--params-file", str(REPO / "params" / "positioner.yaml"),
            "-p", f"port:={port}", "-p", f"kp:={KP}", "-p", "deadband:=0.02",
            "-p", "reconnect_min:=0.1", "-p", "reconnect_max:=0.4"]
    for e in extra:
        args += ["-p", e]
    return processes.start("positioner_bridge", *args)


def test_pty_direction_speed_deadband_and_sigterm_stop(processes, tmp_path, probe) -> None:
    _sim, url, trace = start_sim(processes, tmp_path, "--link", str(tmp_path / "pelco"))
    bridge = start_bridge(processes, url)
    err = (0.1, 0.05)
    want = (expected_rate(err[0]), expected_rate(err[1]))

    def at_speed() -> bool:
        v = velocity_now(trace)
        return abs(v[0] - want[0]) < 2e-6 and abs(v[1] - want[1]) < 2e-6

    def stopped() -> bool:
        return velocity_now(trace) == (0.0, 0.0)

    # positive errors: pan + (left, CCW from above) and tilt + (up), at the table speed of the P command
    assert probe.until(at_speed, 20.0, err), (velocity_now(trace), want, processes.log(bridge))
    assert probe.until(lambda: probe.joints and probe.joints[-1].pan > 0.0 and probe.joints[-1].tilt > 0.0,
                       3.0, err)
    # inside the deadband (0.02 rad) with messages still arriving: stop
    in_deadband = (0.01, -0.015)
    assert probe.until(stopped, 3.0, in_deadband, TrackState.TRACKING)
    assert probe.until(lambda: probe.diag.get("reason") == "deadband or limit", 3.0, in_deadband), probe.diag
    # tracker lost: stop although the error is large
    assert probe.until(lambda: velocity_now(trace)[0] < 0.0, 3.0, (-0.2, 0.0), TrackState.TRACKING)
    assert probe.until(stopped, 3.0, (-0.2, 0.0), TrackState.LOST)
    probe.run(0.5, (-0.2, 0.0), TrackState.LOST)
    assert stopped()
    # moving again, then SIGTERM: the bridge writes a stop before closing (this head has no timeout)
    assert probe.until(lambda: velocity_now(trace)[0] < 0.0, 3.0, (-0.2, 0.0), TrackState.TRACKING)
    assert processes.stop(bridge, signal.SIGTERM) == 0
    assert "stop written" in processes.log(bridge)
    assert probe.until(stopped, 3.0)
    time.sleep(0.5)
    assert stopped()


def test_watchdog_and_port_outage(processes, tmp_path, probe) -> None:
    # A head that stops by itself 0.5 s after its last valid frame (the bridge keeps it alive every 0.2 s).
    sim, url, trace = start_sim(processes, tmp_path, "--link", str(tmp_path / "pelco"),
                                "--command-timeout", "0.5", "--disconnect-for", "2.0")
    bridge = start_bridge(processes, url, "keepalive_period:=0.2", "watchdog_timeout:=0.5")
    tracker = subprocess.Popen([sys.executable, "-c", PUBLISHER, "0.1", "0.0"], start_new_session=True)
    try:
        assert probe.until(lambda: velocity_now(trace)[0] > 0.0, 20.0), processes.log(bridge)
        probe.run(0.5)
        assert velocity_now(trace)[0] > 0.0
        tracker.kill()  # the tracker's publisher dies without a word
        t_kill = time.time()
    finally:
        if tracker.poll() is None:
            tracker.kill()
        tracker.wait(10)
    probe.run(1.5)
    rows = [r for r in read_trace(trace) if r["time"] > t_kill]
    stopped_at = next((r["time"] for r in rows if r["pan_velocity"] == 0.0), math.inf)
    # watchdog 0.5 s + one control period + deceleration (+ scheduling slack on a loaded machine); the
    # bridge's keep-alives would otherwise keep this head moving forever
    assert stopped_at - t_kill < 0.5 + 1.0
    assert velocity_now(trace) == (0.0, 0.0)
    assert probe.until(lambda: probe.diag.get("reason", "").startswith("watchdog"), 3.0), probe.diag

    # port outage while the tracker keeps asking for motion
    assert probe.until(lambda: velocity_now(trace)[0] > 0.0, 5.0, (0.1, 0.0))
    sim.send_signal(signal.SIGUSR1)
    t_off = time.time()
    probe.run(2.2, (0.1, 0.0))
    outage = [r for r in read_trace(trace) if r["time"] > t_off and r["connected"] == 0.0]
    assert outage and outage[-1]["pan_velocity"] == 0.0  # stopped meanwhile
    assert probe.until(lambda: velocity_now(trace)[0] > 0.0, 10.0, (0.1, 0.0)), processes.log(bridge)
    assert bridge.poll() is None
    log = processes.log(bridge)
    assert "after an outage" in log and log.count("retrying every") == 1


def test_socket_url_with_corrupted_bytes(processes, tmp_path, probe) -> None:
    sim, url, trace = start_sim(processes, tmp_path, "--tcp", "0", "--corrupt", "0.01", "--seed", "5",
                                "--initial-pan", "20")
    bridge = start_bridge(processes, url)
    err = (-0.15, -0.1)
    assert probe.until(lambda: velocity_now(trace)[0] < 0.0, 20.0, err), processes.log(bridge)
    assert probe.until(lambda: int(probe.diag.get("checksum_errors", "0")) > 0 and len(probe.joints) > 5,
                       15.0, err), probe.diag
    # issue 39: the status carries the node's full name, hardware_id the address AND the port (two heads at
    # address 1 on their own lines differ)
    assert probe.diag_ids.get("/positioner_bridge: positioner") == f"pelco-d:1@{url}", probe.diag_ids
    pan_v, tilt_v = velocity_now(trace)
    assert pan_v < 0.0 and tilt_v < 0.0  # right and down
    assert bridge.poll() is None
    # joint states agree with the true pose at their stamps (both on the wall clock)
    rows = read_trace(trace)
    js = probe.joints[-1]
    near = min(rows, key=lambda r: abs(r["time"] - js.stamp))
    assert abs(near["time"] - js.stamp) < 0.1
    assert js.pan == pytest.approx(near["pan"], abs=0.01) and js.tilt == pytest.approx(near["tilt"], abs=0.01)
    assert js.pan_velocity < 0.0
    processes.stop(bridge, signal.SIGINT)
    processes.stop(sim)
    stats = dict(kv.split("=") for kv in processes.log(sim).splitlines()[-1].split()[1:])
    assert int(stats["corrupted"]) > 0 and int(stats["frames"]) > 10, stats


def test_invalid_parameters_exit_2(processes) -> None:
    bridge = processes.start("positioner_bridge", "--ros-args", "-p", "port:=loop://", "-p", "tilt_min:=1.0",
                             "-p", "tilt_max:=0.5")
    assert bridge.wait(30) == 2
    assert "tilt_min" in processes.log(bridge)
