# SPDX-License-Identifier: Apache-2.0
"""End-to-end replay: publish a bag with its timing and /clock, record /track/* into a bag, score it."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, Vector3Stamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest
from std_msgs.msg import Bool

from msg_adapters import bag as mb
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import GT_TOPIC, IMAGE_TOPIC, INFO_TOPIC, OCCLUDED_TOPIC, BagReader
from swir_tracker_ros.harness.metrics import Score, score
from swir_tracker_ros.types import Box

RECORDED = {"/track/box": (PolygonStamped, mb.POLYGON_STAMPED),
            "/track/state": (DiagnosticArray, mb.DIAGNOSTIC_ARRAY),
            "/track/pan_tilt_error": (Vector3Stamped, mb.VECTOR3_STAMPED)}
PLAYED = {IMAGE_TOPIC: Image, INFO_TOPIC: CameraInfo, GT_TOPIC: PolygonStamped, OCCLUDED_TOPIC: Bool}
RELIABLE = QoSProfile(depth=50, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE)


@dataclass
class ReplayResult:
    score: Score
    recorded: Path
    frames: int
    answered: int  # frames for which a /track/box arrived


class _Player(Node):
    def __init__(self) -> None:
        super().__init__("harness_replay")
        self.pubs = {t: self.create_publisher(cls, t, RELIABLE) for t, cls in PLAYED.items()}
        self.clock_pub = self.create_publisher(Clock, "/clock", RELIABLE)
        self.init_pub = self.create_publisher(RegionOfInterest, "/track/init", QoSProfile(
            depth=10, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE))
        self.received: list[tuple[str, int, bytes]] = []
        for topic, (cls, _) in RECORDED.items():
            self.create_subscription(cls, topic, lambda raw, t=topic: self._record(t, raw), RELIABLE,
                                     raw=True)
        self.sim_ns = 0

    def _record(self, topic: str, raw: bytes) -> None:
        self.received.append((topic, self.sim_ns, bytes(raw)))

    def publish_clock(self, ns: int) -> None:
        self.sim_ns = ns
        self.clock_pub.publish(mb.serialize(mb.clock_msg(ns)))


def _spin_for(node: Node, seconds: float) -> None:
    end = time.monotonic() + seconds
    while True:
        left = end - time.monotonic()
        if left <= 0:
            break
        rclpy.spin_once(node, timeout_sec=min(left, 0.01))


def replay(bag: Path | str, out: Path | str, rate: float = 1.0, wait_s: float = 20.0, grace_s: float = 2.0,
           log=print) -> ReplayResult:
    """Play `bag` to the ROS graph and score the `tracker` node's /track/box answers against its GT."""
    if rate <= 0:
        raise HarnessError(f"--rate must be positive, got {rate}")
    br = BagReader(bag)
    msgs = [(topic, t, raw) for topic, _, t, raw in br.messages(set(PLAYED))]
    gt_stamps: dict[int, Box | None] = {}
    occluded: dict[int, bool] = {}
    for topic, t, raw in msgs:
        if topic == GT_TOPIC:
            m = mb.deserialize(raw, mb.POLYGON_STAMPED)
            gt_stamps[mb.stamp_to_ns(m.header.stamp)] = mb.polygon_to_box(m)
        elif topic == OCCLUDED_TOPIC:
            occluded[t] = bool(mb.deserialize(raw, "std_msgs/msg/Bool").data)
    first_gt = next((b for _, b in sorted(gt_stamps.items()) if b is not None), None)
    if not any(topic == IMAGE_TOPIC for topic, _, _ in msgs) or first_gt is None:
        raise HarnessError(f"{bag}: replay needs {IMAGE_TOPIC} and a non-empty {GT_TOPIC}")
    owns_context = not rclpy.ok()
    if owns_context:
        rclpy.init()
    node = _Player()
    try:
        end = time.monotonic() + wait_s
        pubs = (node.pubs[IMAGE_TOPIC], node.init_pub)
        while min(p.get_subscription_count() for p in pubs) == 0:
            if time.monotonic() > end:
                raise HarnessError(f"no subscriber on {IMAGE_TOPIC} and /track/init after {wait_s:.0f} s; "
                                   "start the `tracker` node first")
            _spin_for(node, 0.1)
        t_first = msgs[0][1]
        node.publish_clock(t_first)
        node.init_pub.publish(mb.serialize(mb.roi_msg(first_gt)))
        _spin_for(node, 0.5)
        log(f"replaying {len(msgs)} messages from {bag} at rate {rate}")
        start = time.monotonic()
        for topic, t, raw in msgs:
            due = start + (t - t_first) / 1e9 / rate
            _spin_for(node, due - time.monotonic())
            if t != node.sim_ns:
                node.publish_clock(t)
            node.pubs[topic].publish(raw)
        played_s = time.monotonic() - start
        _spin_for(node, grace_s)
        received = list(node.received)
    finally:
        node.destroy_node()
        if owns_context:
            rclpy.shutdown()
    recorded = _write_recording(Path(out), received)
    boxes: dict[int, Box | None] = {}
    for topic, _, raw in received:
        if topic == "/track/box":
            m = mb.deserialize(raw, mb.POLYGON_STAMPED)
            boxes[mb.stamp_to_ns(m.header.stamp)] = mb.polygon_to_box(m)
    stamps = sorted(gt_stamps)
    pred = [boxes.get(s) for s in stamps]
    pred[0] = gt_stamps[stamps[0]] if pred[0] is None else pred[0]
    s = score(pred, [gt_stamps[x] for x in stamps], 0.0, [occluded.get(x) for x in stamps])
    answered = sum(1 for x in stamps if x in boxes)
    s.fps = answered / played_s if played_s > 0 else 0.0
    return ReplayResult(s, recorded, len(stamps), answered)


def _write_recording(out: Path, received: list[tuple[str, int, bytes]]) -> Path:
    if out.exists():
        raise HarnessError(f"{out} exists already; choose a new --out")
    ts = mb.typestore()
    with Writer(out, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {topic: w.add_connection(topic, msgtype, typestore=ts)
                 for topic, (_, msgtype) in RECORDED.items()}
        last = 0
        for topic, t, raw in received:
            last = max(last, t)
            w.write(conns[topic], last, raw)
    return out
