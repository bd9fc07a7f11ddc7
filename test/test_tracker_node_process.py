# SPDX-License-Identifier: Apache-2.0
"""The installed `tracker` executable over DDS: follows a moving target, survives malformed input."""

from __future__ import annotations

import array
import math
import signal
import time
from collections.abc import Iterator

import numpy as np
import pytest
from conftest import REPO, ProcessSet, SpinningProbe, ros_probe
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, Vector3Stamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image, JointState, RegionOfInterest
from test_tracker_node_unit import TW, H, W, scene

from msg_adapters.diagnostics import status_values
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon, pan_tilt_error_from_msg
from msg_adapters.image import numpy_to_image
from msg_adapters.stamps import header, stamp_to_seconds
from msg_adapters.track_state import track_state_from_msg
from swir_tracker_ros.nodes.tracker_node import DIAG_NAME
from swir_tracker_ros.types import Box, TrackState

FOV_DEG = 20.0
PARAMS = ["--ros-args", "--params-file", str(REPO / "params" / "tracker.yaml"),
          "-p", f"fov_h_deg:={FOV_DEG}", "-p", "diagnostics_period_s:=0.5"]


class Probe(SpinningProbe):
    """A test node: publishes camera frames and side inputs, collects the tracker's outputs by stamp."""

    def __init__(self, ctx: Context) -> None:
        self.node = Node("tracker_probe", context=ctx)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        n = self.node
        best_effort = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.image = n.create_publisher(Image, "/camera/image_raw", best_effort)
        self.init = n.create_publisher(RegionOfInterest, "/track/init", 10)
        self.info = n.create_publisher(CameraInfo, "/camera/camera_info", 10)
        self.joints = n.create_publisher(JointState, "/positioner/joint_states", 10)
        self.states: dict[float, DiagnosticArray] = {}
        self.boxes: dict[float, PolygonStamped] = {}
        self.errors: dict[float, Vector3Stamped] = {}
        self.diags: list[DiagnosticArray] = []
        n.create_subscription(DiagnosticArray, "/track/state", self._keep(self.states), 10)
        n.create_subscription(PolygonStamped, "/track/box", self._keep(self.boxes), 10)
        n.create_subscription(Vector3Stamped, "/track/pan_tilt_error", self._keep(self.errors), 10)
        n.create_subscription(DiagnosticArray, "/diagnostics", self.diags.append, 10)
        self.t = time.time()

    @staticmethod
    def _keep(store: dict):
        def cb(msg) -> None:
            store[stamp_to_seconds(msg.header.stamp)] = msg
        return cb

    def connected(self) -> bool:
        return (self.image.get_subscription_count() > 0 and self.init.get_subscription_count() > 0
                and self.node.count_publishers("/track/state") > 0)

    def next_stamp(self) -> float:
        self.t = max(self.t + 0.04, time.time())
        return round(self.t, 6)

    def frame(self, pixels: np.ndarray, big_endian: bool = False) -> float:
        """Publish one frame and wait for its /track/state (lock-step); returns the stamp."""
        for _ in range(8):
            # A frame (or its answer) sent while discovery completes may be lost: send the frame again
            # with a new stamp, since the node rightly drops a repeated stamp as stale.
            msg = numpy_to_image(pixels, header(self.next_stamp(), "swir"))
            stamp = stamp_to_seconds(msg.header.stamp)  # the key the collectors compute
            if big_endian:
                msg.is_bigendian = 1
                msg.data = array.array("B", pixels.astype(">u2").tobytes())
            self.image.publish(msg)
            if self.spin_until(lambda s=stamp: s in self.states, 1.5):
                return stamp
        raise AssertionError(f"no /track/state for frame {stamp}")

    def select(self, pixels: np.ndarray, centre: tuple[float, float]) -> None:
        """Send /track/init for a TW x TW box at `centre`; publish the still frame until the track starts."""
        x, y = round(centre[0] - TW / 2), round(centre[1] - TW / 2)
        self.init.publish(RegionOfInterest(x_offset=x, y_offset=y, width=TW, height=TW))
        for _ in range(40):
            if track_state_from_msg(self.states[self.frame(pixels)]) is TrackState.TRACKING:
                return
            self.spin_until(lambda: False, 0.1)
        raise AssertionError("the tracker never started tracking after /track/init")

    def raw(self, msg) -> None:
        """Publish a (malformed) message and give the tracker time to take it before anything else."""
        if isinstance(msg, Image):
            msg.header = header(self.next_stamp())
            self.image.publish(msg)
        elif isinstance(msg, RegionOfInterest):
            self.init.publish(msg)
        elif isinstance(msg, CameraInfo):
            self.info.publish(msg)
        else:
            self.joints.publish(msg)
        self.spin_until(lambda: False, 0.2)

    def diag(self) -> dict[str, str]:
        for msg in reversed(self.diags):
            try:
                return status_values(msg, DIAG_NAME)
            except MessageError:
                continue
        return {}


@pytest.fixture
def probe() -> Iterator[Probe]:
    with ros_probe(Probe) as p:
        yield p


def start_tracker(processes: ProcessSet, probe: Probe):
    proc = processes.start("tracker", *PARAMS)
    assert probe.spin_until(probe.connected, 30.0), processes.log(proc)
    return proc


def to_mono8(frame: np.ndarray) -> np.ndarray:
    return np.clip(frame / 40.0, 0, 255).astype(np.uint8)


def follow(probe: Probe, path: list[tuple[float, float]], mono8: bool, seed0: int = 0) -> list[tuple]:
    """Publish the target along `path`; return (truth, box, pan, tilt, state) per frame."""
    out = []
    for i, (cx, cy) in enumerate(path):
        frame = scene(cx, cy, seed=seed0 + i)
        stamp = probe.frame(to_mono8(frame) if mono8 else frame)
        state = track_state_from_msg(probe.states[stamp])
        assert probe.spin_until(lambda s=stamp: s in probe.boxes, 5.0)
        box = box_from_polygon(probe.boxes[stamp])
        pan = tilt = None
        if state in (TrackState.TRACKING, TrackState.OCCLUDED):
            assert probe.spin_until(lambda s=stamp: s in probe.errors, 5.0)
            pan, tilt, err_stamp = pan_tilt_error_from_msg(probe.errors[stamp])
            assert err_stamp == stamp
        out.append(((cx, cy), box, pan, tilt, state))
    return out


@pytest.mark.parametrize("mono8", [False, True], ids=["mono16", "mono8"])
def test_installed_tracker_follows_a_moving_target(processes: ProcessSet, probe: Probe, mono8: bool) -> None:
    proc = start_tracker(processes, probe)
    start = (60.0, 70.0)
    still = to_mono8(scene(*start)) if mono8 else scene(*start)
    stamp = probe.frame(still)
    assert track_state_from_msg(probe.states[stamp]) is TrackState.IDLE  # nothing selected yet
    assert probe.spin_until(lambda: stamp in probe.boxes, 5.0)
    assert box_from_polygon(probe.boxes[stamp]) is None and not probe.errors  # empty polygon, no error
    probe.select(still, start)
    path = [(start[0] + 3.0 * i, start[1] + 1.5 * i) for i in range(40)]
    frames = follow(probe, path, mono8)
    fx = (W / 2) / math.tan(math.radians(FOV_DEG / 2))
    for (cx, cy), box, pan, tilt, state in frames:
        assert state is TrackState.TRACKING
        assert abs(box.cx - cx) < 4 and abs(box.cy - cy) < 4, (cx, cy, box)
        assert pan == pytest.approx(math.atan2(W / 2 - box.cx, fx), abs=1e-6)
        assert tilt == pytest.approx(math.atan2(H / 2 - box.cy, fx), abs=1e-6)
    # Left of / above the centre at the start (both errors positive), right of / below it at the end.
    assert frames[0][2] > 0 and frames[0][3] > 0 and frames[-1][2] < 0 and frames[-1][3] < 0
    assert processes.stop(proc, signal.SIGINT) == 0


def malformed_messages() -> list:
    def img(**kw) -> Image:
        fields = {"height": H, "width": W, "encoding": "mono16", "step": 2 * W, "data": bytes(2 * W * H)}
        fields.update(kw)
        fields["data"] = array.array("B", fields["data"])
        return Image(**fields)

    return [
        img(encoding="bayer_xyz8"),  # unknown encoding
        img(data=bytes(2 * W * H - 1)),  # data shorter than step * height
        img(step=W),  # step < width * bytes per pixel
        img(height=0, data=b""),  # zero size
        img(encoding="uyvy", width=W - 1, step=2 * (W - 1)),  # odd YUV width
        img(height=100000, width=100000, step=200000, data=bytes(16)),  # huge header, tiny data
        RegionOfInterest(x_offset=10, y_offset=10, width=0, height=0),  # zero-size init box
        RegionOfInterest(x_offset=90000, y_offset=10, width=20, height=20),  # init box outside the image
        CameraInfo(width=W, height=H),  # uncalibrated K
        JointState(name=["pan"], position=[0.1]),  # tilt missing
        JointState(name=["pan", "tilt"], position=[float("nan"), 0.0]),  # not finite
    ]


def test_installed_tracker_survives_malformed_input(processes: ProcessSet, probe: Probe) -> None:
    proc = start_tracker(processes, probe)
    start = (80.0, 90.0)
    probe.select(scene(*start), start)
    follow(probe, [(start[0] + 2.0 * i, start[1]) for i in range(5)], mono8=False)
    for msg in malformed_messages():
        probe.raw(msg)
        assert proc.poll() is None, processes.log(proc)
    # A valid big-endian frame is not malformed: it is decoded and tracked.
    stamp = probe.frame(scene(start[0] + 10.0, start[1], seed=50), big_endian=True)
    assert track_state_from_msg(probe.states[stamp]) is TrackState.TRACKING
    frames = follow(probe, [(start[0] + 12.0 + 2.0 * i, start[1] + i) for i in range(15)], mono8=False,
                    seed0=100)
    for (cx, cy), box, _pan, _tilt, state in frames:
        assert state is TrackState.TRACKING and isinstance(box, Box)
        assert abs(box.cx - cx) < 4 and abs(box.cy - cy) < 4
    malformed_images = 6
    assert probe.spin_until(lambda: int(probe.diag().get("total_dropped_malformed", 0)) >= malformed_images,
                            10.0), probe.diag()
    assert int(probe.diag()["total_callback_errors"]) == 0
    assert proc.poll() is None
    assert processes.stop(proc, signal.SIGTERM) == 0, processes.log(proc)


def test_installed_tracker_exits_2_on_a_bad_parameter(processes: ProcessSet) -> None:
    proc = processes.start("tracker", "--ros-args", "-p", "fov_h_deg:=500.0")
    assert proc.wait(60) == 2
    assert "fov_h_deg" in processes.log(proc)
