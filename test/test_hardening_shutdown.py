# SPDX-License-Identifier: Apache-2.0
"""Issue 14, item 4: one or two SIGINTs (a terminal's Ctrl-C plus `ros2 launch`'s own) or a SIGTERM end
every node with exit code 0 and no traceback; the bridge's stop is the last frame the head receives."""

from __future__ import annotations

import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import rclpy
from conftest import ProcessSet, ros_probe, wait_for
from geometry_msgs.msg import Vector3Stamped
from rclpy.context import Context
from rclpy.node import Node
from test_pelco_sim import start_sim

STOP = "00 00 00 00"  # cmd1 cmd2 data1 data2 of the Pelco-D stop
SIGNALS = {"INT": [signal.SIGINT], "INT+INT 0 ms": [signal.SIGINT, 0.0, signal.SIGINT],
           "INT+INT 10 ms": [signal.SIGINT, 0.01, signal.SIGINT],
           "INT+INT 40 ms": [signal.SIGINT, 0.04, signal.SIGINT], "TERM": [signal.SIGTERM]}


def send(proc, steps: list) -> int:
    for s in steps:
        if isinstance(s, float):
            time.sleep(s)
        else:
            proc.send_signal(s)
    return proc.wait(15)


def clean(log: str) -> bool:
    return "Traceback" not in log and "KeyboardInterrupt" not in log and " failed:" not in log


class ErrorPublisher:
    def __init__(self, ctx: Context) -> None:
        self.node = Node("shutdown_probe", context=ctx)
        self.pub = self.node.create_publisher(Vector3Stamped, "/track/pan_tilt_error", 10)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)

    def publish_for(self, seconds: float, pan: float = 0.2) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            msg = Vector3Stamped()
            msg.vector.x, msg.vector.y = pan, 0.0
            self.pub.publish(msg)
            self.executor.spin_once(timeout_sec=0.03)


@pytest.fixture
def errors() -> Iterator[ErrorPublisher]:
    with ros_probe(ErrorPublisher) as p:
        yield p


def frames(path: Path) -> list[str]:
    """'cmd1 cmd2 data1 data2' of every frame pelco_sim received, in order."""
    return [" ".join(line.split()[2:6]) for line in path.read_text().splitlines() if line.strip()]


def test_bridge_exits_0_and_writes_the_stop_last_on_one_or_two_sigints_and_sigterm(
        processes: ProcessSet, tmp_path: Path, errors: ErrorPublisher) -> None:
    log = tmp_path / "frames.txt"
    _sim, url, _trace = start_sim(processes, tmp_path, "--link", str(tmp_path / "pelco"),
                                  "--frame-log", str(log))
    for name, steps in SIGNALS.items():
        bridge = processes.start("positioner_bridge", "--ros-args", "-p", f"port:={url}",
                                 "-p", "feedback_rate:=20.0")
        n0 = len(frames(log)) if log.exists() else 0

        def moving(n0=n0) -> bool:
            errors.publish_for(0.1)
            return any(f.startswith("00 04") for f in frames(log)[n0:])  # pan left at some speed

        assert wait_for(moving, 30.0, 0.0), (name, processes.log(bridge))
        errors.publish_for(0.3)
        rc = send(bridge, steps)
        text = processes.log(bridge)
        assert rc == 0 and clean(text), (name, rc, text)
        assert "stop written" in text, (name, text)
        time.sleep(0.3)
        assert frames(log)[-1] == STOP, (name, frames(log)[-5:])


@pytest.mark.parametrize("name", ["INT+INT 10 ms", "TERM"])
def test_tracker_exits_0_without_callback_errors_while_frames_arrive(processes: ProcessSet,
                                                                     name: str) -> None:
    processes.start("scene_camera")
    tracker = processes.start("tracker", "--ros-args", "-p", "init_box:=[270.0, 240.0, 30.0, 30.0]",
                              "-p", "diagnostics_period_s:=0.2")
    # tracking: frames are being processed when the signal comes
    assert wait_for(lambda: "tracking /camera/image_raw" in processes.log(tracker), 30.0)
    time.sleep(3.0)
    rc = send(tracker, SIGNALS[name])
    text = processes.log(tracker)
    assert rc == 0 and clean(text), (name, rc, text)


@pytest.mark.parametrize("exe", ["tracker", "acquisition", "positioner_bridge", "scene_camera", "pelco_sim"])
def test_a_signal_during_start_up_exits_0_quietly(processes: ProcessSet, exe: str) -> None:
    """Ctrl-C while the imports run (seconds on a loaded machine): exit 0, no traceback from an import."""
    args = ["--ros-args", "-p", "port:=loop://"] if exe == "positioner_bridge" else []
    proc = processes.start(exe, *args)
    time.sleep(0.8)
    rc = send(proc, SIGNALS["INT+INT 10 ms"])
    assert rc == 0 and clean(processes.log(proc)), (rc, processes.log(proc))


def test_a_sigint_inside_signals_deferred_takes_effect_when_the_block_ends() -> None:
    """The tracker loads its compiled FHOG loops inside `signals_deferred()`: a Ctrl-C there must neither
    be raised inside numba's ctypes callbacks (where ctypes swallows it) nor be lost. Python runs the
    SIGINT handler in the main thread wherever it is, whichever thread the kernel gave the signal to (the
    node has DDS threads), so masking the signal is no help; the handler is called here as Python would
    call it in the middle of the block."""
    from swir_tracker_ros.nodes.runner import _OneInterrupt, signals_deferred

    previous = signal.getsignal(signal.SIGINT)
    handler = _OneInterrupt()
    signal.signal(signal.SIGINT, handler)
    inside_done = False
    try:
        with pytest.raises(KeyboardInterrupt), signals_deferred():
            handler(signal.SIGINT, None)
            inside_done = True
        assert inside_done
        handler(signal.SIGINT, None)  # the first one counted: later ones are ignored as before
    finally:
        signal.signal(signal.SIGINT, previous)
