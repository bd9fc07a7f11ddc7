# SPDX-License-Identifier: Apache-2.0
"""End-to-end replay: publish a bag with its timing and /clock, record /track/* into a bag, score it."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import rclpy
from rclpy.node import Node
from rosbags.rosbag2 import StoragePlugin, Writer

from msg_adapters import bag as mb
from msg_adapters.backend import RCLPY, ROSBAGS
from msg_adapters.geometry import box_from_polygon, box_to_roi
from msg_adapters.ground_truth import occluded_from_msg
from msg_adapters.image import image_to_numpy
from msg_adapters.qos import profile
from msg_adapters.stamps import clock_msg, msg_ns, ns_to_stamp
from swir_tracker_ros import topics
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import GT_TOPIC, IMAGE_TOPIC, INFO_TOPIC, OCCLUDED_TOPIC
from swir_tracker_ros.harness.bagreader import BagReader
from swir_tracker_ros.harness.evaluate import Run
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.types import Box

RECORDED = tuple(topics.absolute(t) for t in (topics.TRACK_BOX, topics.TRACK_STATE, topics.PAN_TILT_ERROR))
PLAYED = (IMAGE_TOPIC, INFO_TOPIC, GT_TOPIC, OCCLUDED_TOPIC)


@dataclass
class ReplayResult:
    stats: RunStats  # frames after the start scored; an unanswered frame scores as no box
    recorded: Path
    frames: int
    answered: int  # frames for which a /track/box arrived


class _Player(Node):
    def __init__(self) -> None:
        super().__init__("harness_replay")
        record = profile(topics.RECORD)
        self.pubs = {t: self.create_publisher(RCLPY.cls(topics.TYPES[t]), t, record) for t in PLAYED}
        self.clock_pub = self.create_publisher(RCLPY.cls(topics.TYPES[topics.CLOCK]), topics.CLOCK, record)
        self.init_pub = self.create_publisher(RCLPY.cls(topics.TYPES[topics.TRACK_INIT]), topics.TRACK_INIT,
                                              profile(topics.RELIABLE))
        self.received: list[tuple[str, int, bytes]] = []
        for topic in RECORDED:
            self.create_subscription(RCLPY.cls(topics.TYPES[topic]), topic,
                                     lambda raw, t=topic: self._record(t, raw), record, raw=True)
        self.sim_ns = 0

    def _record(self, topic: str, raw: bytes) -> None:
        self.received.append((topic, self.sim_ns, bytes(raw)))

    def publish_clock(self, ns: int) -> None:
        self.sim_ns = ns
        self.clock_pub.publish(mb.serialize(clock_msg(ns_to_stamp(ns, ROSBAGS), ROSBAGS)))


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
    first_image = None
    for topic, t, raw in msgs:
        if topic == GT_TOPIC:
            m = mb.deserialize(raw, topics.TYPES[GT_TOPIC])
            gt_stamps[msg_ns(m)] = box_from_polygon(m)
        elif topic == OCCLUDED_TOPIC:
            occluded[t] = occluded_from_msg(mb.deserialize(raw, topics.TYPES[OCCLUDED_TOPIC]))
        elif topic == IMAGE_TOPIC and first_image is None:
            first_image = image_to_numpy(mb.deserialize(raw, topics.TYPES[IMAGE_TOPIC])).pixels
    first_gt = next((b for _, b in sorted(gt_stamps.items()) if b is not None), None)
    if first_image is None or first_gt is None:
        raise HarnessError(f"{bag}: replay needs {IMAGE_TOPIC} and a non-empty {GT_TOPIC}")
    height, width = first_image.shape[:2]
    owns_context = not rclpy.ok()
    if owns_context:
        rclpy.init()
    node = _Player()
    try:
        end = time.monotonic() + wait_s
        pubs = (node.pubs[IMAGE_TOPIC], node.init_pub)
        while min(p.get_subscription_count() for p in pubs) == 0:
            if time.monotonic() > end:
                raise HarnessError(f"no subscriber on {IMAGE_TOPIC} and {topics.TRACK_INIT} after "
                                   f"{wait_s:.0f} s; start the `tracker` node first")
            _spin_for(node, 0.1)
        t_first = msgs[0][1]
        node.publish_clock(t_first)
        node.init_pub.publish(mb.serialize(box_to_roi(first_gt, width, height, ROSBAGS)))
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
        if topic == topics.absolute(topics.TRACK_BOX):
            m = mb.deserialize(raw, topics.TYPES[topics.TRACK_BOX])
            boxes[msg_ns(m)] = box_from_polygon(m)
    stamps = sorted(gt_stamps)
    gts = [gt_stamps[x] for x in stamps]
    first = next(k for k, g in enumerate(gts) if g is not None)
    pred = [boxes.get(s) for s in stamps]
    pred[first] = gts[first] if pred[first] is None else pred[first]
    # the node's box is scored as it was published (state "reported"); a frame it did not answer is a miss
    states = ["idle"] * first + ["init"]
    states += ["reported" if x in boxes else "unanswered" for x in stamps[first + 1:]]
    period = (stamps[-1] - stamps[0]) / (len(stamps) - 1) if len(stamps) > 1 else 4e7
    stats = RunStats.of(Run(pred, gts, [occluded.get(x) for x in stamps], 0.0, states, [None] * len(stamps),
                            gts[first], first), 1e9 / period)
    answered = sum(1 for x in stamps if x in boxes)
    stats.fps = answered / played_s if played_s > 0 else 0.0
    return ReplayResult(stats, recorded, len(stamps), answered)


def _write_recording(out: Path, received: list[tuple[str, int, bytes]]) -> Path:
    if out.exists():
        raise HarnessError(f"{out} exists already; choose a new --out")
    ts = mb.typestore()
    with Writer(out, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {topic: w.add_connection(topic, topics.TYPES[topic], typestore=ts) for topic in RECORDED}
        last = 0
        for topic, t, raw in received:
            last = max(last, t)
            w.write(conns[topic], last, raw)
    return out
