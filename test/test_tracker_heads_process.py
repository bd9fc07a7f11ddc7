# SPDX-License-Identifier: Apache-2.0
"""Issue 33 over DDS: two namespaced heads on one domain, JPEG frames in, a target picked by a click stamped
in the past while it moves, acknowledged selection requests (installed `tracker` executables)."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from conftest import REPO, ProcessSet, SpinningProbe, ros_probe, wait_for
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point, PointStamped, PolygonStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage, Image, RegionOfInterest
from test_tracker_node_unit import TW, H, W, scene
from vision_msgs.msg import Detection2DArray
from visualization_msgs.msg import ImageMarker

from msg_adapters.compressed import numpy_to_compressed
from msg_adapters.detections import Detected, detections_from_msg
from msg_adapters.geometry import box_from_polygon
from msg_adapters.image import numpy_to_image
from msg_adapters.image_marker import marker_box
from msg_adapters.selection import selection_result
from msg_adapters.stamps import header, stamp_to_seconds
from msg_adapters.track_state import typed_state_from_msg
from swir_tracker_interfaces.msg import TrackState as TrackStateMsg
from swir_tracker_interfaces.srv import SelectTarget
from swir_tracker_ros.types import Box, TrackState

ALLOWED_OUTSIDE = {"/diagnostics", "/rosout", "/parameter_events"}
PERIOD = 0.05  # s between frames of the moving target


def node_topics(node: Node, name: str, namespace: str) -> set[str]:
    """The topics another node publishes or subscribes, as the graph reports them."""
    return ({n for n, _ in node.get_publisher_names_and_types_by_node(name, namespace)}
            | {n for n, _ in node.get_subscriber_names_and_types_by_node(name, namespace)})


def tracker_args(namespace: str, *extra: str) -> list[str]:
    return ["--ros-args", "-r", f"__ns:={namespace}", "--params-file", str(REPO / "params" / "tracker.yaml"),
            "-p", "fov_h_deg:=20.0", *(a for e in extra for a in ("-p", e))]


def to_mono8(frame: np.ndarray) -> np.ndarray:
    return np.clip(frame / 40.0, 0, 255).astype(np.uint8)


def truth(cx: float, cy: float) -> Box:
    return Box.from_center(cx, cy, TW, TW)


class Head:
    """The probe's side of one namespaced head: camera publisher, selection inputs, collected outputs."""

    def __init__(self, node: Node, ns: str, compressed: bool = False, click: type | None = None) -> None:
        best_effort = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.ns, self.compressed = ns, compressed
        image_type, image_topic = (CompressedImage, f"{ns}/camera/image_raw/compressed") if compressed else \
            (Image, f"{ns}/camera/image_raw")
        self.image = node.create_publisher(image_type, image_topic, best_effort)
        self.init = node.create_publisher(RegionOfInterest, f"{ns}/track/init", 10)
        self.click = node.create_publisher(click, f"{ns}/camera/image_raw_mouse_left", 10) if click else None
        self.select = node.create_client(SelectTarget, f"{ns}/track/select")
        self.boxes: dict[float, Box | None] = {}
        self.states: dict[float, tuple[TrackState, Box | None]] = {}
        self.markers: dict[float, Box | None] = {}
        self.truth: dict[float, Box] = {}
        self.box_frame_ids: set[str] = set()
        self.detections: dict[float, tuple[str, list[Detected]]] = {}  # stamp -> (frame_id, detections)
        node.create_subscription(PolygonStamped, f"{ns}/track/box", self._on_box, 10)
        node.create_subscription(Detection2DArray, f"{ns}/track/detections", self._on_detections, 10)
        node.create_subscription(TrackStateMsg, f"{ns}/track/state_typed", self._on_state, 10)
        node.create_subscription(ImageMarker, f"{ns}/track/image_markers", self._on_marker, 10)

    def _on_box(self, msg: PolygonStamped) -> None:
        self.boxes[stamp_to_seconds(msg.header.stamp)] = box_from_polygon(msg)
        self.box_frame_ids.add(msg.header.frame_id)

    def _on_detections(self, msg: Detection2DArray) -> None:
        self.detections[stamp_to_seconds(msg.header.stamp)] = (msg.header.frame_id, detections_from_msg(msg))

    def _on_state(self, msg: TrackStateMsg) -> None:
        self.states[stamp_to_seconds(msg.header.stamp)] = typed_state_from_msg(msg)

    def _on_marker(self, msg: ImageMarker) -> None:
        if msg.id == 0:
            self.markers[stamp_to_seconds(msg.header.stamp)] = marker_box(msg)

    def publish(self, cx: float, cy: float, stamp: float, seed: int) -> None:
        frame = to_mono8(scene(cx, cy, seed=seed))
        hdr = header(stamp, "swir_optical_frame")
        msg = numpy_to_compressed(frame, hdr, "jpeg", 90) if self.compressed else numpy_to_image(frame, hdr)
        self.truth[stamp_to_seconds(msg.header.stamp)] = truth(cx, cy)
        self.image.publish(msg)


class Probe(SpinningProbe):
    def __init__(self, ctx: Context) -> None:
        self.node = Node("heads_probe", context=ctx)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        self.heads: dict[str, Head] = {}
        self.diagnostics: dict[str, str] = {}  # status name -> hardware_id
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 10)

    def _on_diag(self, msg: DiagnosticArray) -> None:
        self.diagnostics.update({st.name: st.hardware_id for st in msg.status})

    def add(self, ns: str, **kw) -> Head:
        self.heads[ns] = Head(self.node, ns, **kw)
        return self.heads[ns]

    def connected(self, head: Head) -> bool:
        return (head.image.get_subscription_count() > 0 and head.init.get_subscription_count() > 0
                and self.node.count_publishers(f"{head.ns}/track/box") > 0 and head.select.service_is_ready()
                and (head.click is None or head.click.get_subscription_count() > 0))

    def call(self, head: Head, request: SelectTarget.Request, timeout: float = 10.0) -> tuple:
        future = head.select.call_async(request)
        assert self.spin_until(future.done, timeout), "track/select did not answer"
        return selection_result(future.result())


@pytest.fixture
def probe() -> Iterator[Probe]:
    with ros_probe(Probe) as p:
        yield p


def start_head(processes: ProcessSet, probe: Probe, ns: str, *params: str):
    proc = processes.start("tracker", *tracker_args(ns, *params))
    assert probe.spin_until(lambda: probe.connected(probe.heads[ns]), 60.0), processes.log(proc)
    return proc


def test_two_namespaced_heads_track_their_own_streams(processes: ProcessSet, probe: Probe) -> None:
    paths = {"/head1": [(60.0 + 3 * i, 70.0 + i) for i in range(30)],
             "/head2": [(170.0 - 3 * i, 120.0 - i) for i in range(30)]}
    procs = {}
    for ns in paths:
        probe.add(ns)
        procs[ns] = start_head(processes, probe, ns)
    t = time.time()
    for ns, path in paths.items():  # each head gets its own target, selected on its own track/init
        (cx, cy) = path[0]
        b = truth(cx, cy)
        probe.heads[ns].init.publish(RegionOfInterest(x_offset=round(b.x), y_offset=round(b.y), width=TW,
                                                      height=TW))
    probe.spin_until(lambda: False, 0.5)
    for i in range(len(paths["/head1"])):
        t = max(t + 0.04, time.time())
        for ns, path in paths.items():
            probe.heads[ns].publish(*path[i], round(t, 6), seed=i)
        stamp = round(t, 6)
        probe.spin_until(lambda s=stamp: all(s in h.states for h in probe.heads.values()), 3.0)
    for ns, head in probe.heads.items():
        tracked = [(s, b) for s, b in head.boxes.items() if b is not None]
        assert len(tracked) >= 20, (ns, len(tracked), processes.log(procs[ns]))
        for s, b in tracked[-10:]:
            assert b.center_distance(head.truth[s]) < 4.0, (ns, s, b, head.truth[s])
        assert head.states[max(head.states)][0] is TrackState.TRACKING
        assert head.box_frame_ids == {"swir_optical_frame_pixels"}
        # vision_msgs (issue 39): on every frame with a track/box, track/detections with the same box, stamp
        # and the image's frame_id; one detection while tracking (the state as its class), none without a box
        assert set(head.detections) >= set(head.boxes), (ns, sorted(set(head.boxes) - set(head.detections)))
        ids = set()
        for s, b in head.boxes.items():
            frame_id, dets = head.detections[s]
            assert frame_id == "swir_optical_frame"
            if b is None:
                assert dets == [], (ns, s, dets)
                continue
            assert len(dets) == 1, (ns, s, dets)
            d = dets[0]
            assert np.allclose(d.box.as_tuple(), b.as_tuple(), atol=1e-3), (ns, s, d.box, b)
            assert d.class_id == head.states[s][0].value and 0.0 <= d.score <= 1.0, (ns, s, d)
            ids.add(d.id)
        assert ids == {"1"}, ids  # one target, one track id
    # Issue 39: each head's status carries its node's full name; hardware_id the node (distinct per head).
    assert probe.spin_until(lambda: all(f"{ns}/tracker: tracker_node" in probe.diagnostics for ns in paths),
                            5.0), probe.diagnostics
    assert {probe.diagnostics[f"{ns}/tracker: tracker_node"] for ns in paths} == {"/head1/tracker",
                                                                                 "/head2/tracker"}
    # Every topic and service of each head's tracker, as the graph reports them, lies in its namespace but
    # the three graph-wide topics.
    for ns in paths:
        names = node_topics(probe.node, "tracker", ns)
        outside = {n for n in names if not n.startswith(f"{ns}/")}
        assert outside <= ALLOWED_OUTSIDE, sorted(outside)
        assert {f"{ns}/track/box", f"{ns}/track/pan_tilt_error", f"{ns}/track/state",
                f"{ns}/camera/image_raw", f"{ns}/track/state_typed", f"{ns}/track/image_markers",
                "/diagnostics"} <= names
        services = {n for n, _ in probe.node.get_service_names_and_types_by_node("tracker", ns)}
        assert all(s.startswith(f"{ns}/") for s in services), services
        assert {f"{ns}/track/select", f"{ns}/track/cancel", f"{ns}/tracker/set_parameters"} <= services


def test_jpeg_frames_and_a_click_stamped_in_the_past(processes: ProcessSet, probe: Probe) -> None:
    head = probe.add("/cam", compressed=True, click=PointStamped)
    proc = start_head(processes, probe, "/cam", "image_transport:=compressed", "click_msg:=point_stamped")
    sent: list[tuple[float, float, float]] = []  # (stamp, cx, cy) of every frame, in order

    def frame(k: int) -> None:
        cx, cy = 50.0 + 2.5 * k, 80.0 + 0.8 * k  # moving right and down, 50 px/s
        stamp = round(time.time(), 6)
        head.publish(cx, cy, stamp, seed=k)
        sent.append((stamp, cx, cy))

    k = 0
    while k < 20:  # the target moves; nothing is selected yet
        frame(k)
        k += 1
        probe.spin_until(lambda: False, PERIOD)
    # The operator clicked on the frame shown 300 ms ago, at the target's centre in that frame.
    seen = next(s for s in reversed(sent) if s[0] <= sent[-1][0] - 0.3 + 1e-6)
    click = PointStamped(header=header(seen[0], "swir_optical_frame"), point=Point(x=seen[1], y=seen[2]))
    clicked_at = time.monotonic()
    head.click.publish(click)
    on_target = None
    while on_target is None and time.monotonic() - clicked_at < 1.5:
        frame(k)
        k += 1
        probe.spin_until(lambda: False, PERIOD)
        for s, b in sorted(head.boxes.items()):
            if b is not None and s > seen[0] and b.iou(head.truth[s]) >= 0.5:
                on_target = (s, b)
                break
    assert on_target is not None, (head.boxes, processes.log(proc))
    # It started on the clicked frame, not the newest, and caught up through the frames since.
    assert wait_for(lambda: "caught up over" in processes.log(proc), 5.0), processes.log(proc)
    log = processes.log(proc)
    assert f"on the frame stamped {seen[0]:.3f}" in log, log
    caught_up = int(log.split("caught up over ")[1].split()[0])
    assert caught_up >= round(0.3 / PERIOD) - 1, log
    # It keeps tracking the moving target; the markers and typed state say the same.
    for _ in range(10):
        frame(k)
        k += 1
        probe.spin_until(lambda: False, PERIOD)
    last = max(s for s, b in head.boxes.items() if b is not None)
    assert head.boxes[last].iou(head.truth[last]) >= 0.5
    assert probe.spin_until(lambda: last in head.markers and last in head.states, 3.0)
    assert head.markers[last].iou(head.boxes[last]) > 0.99  # Point32 (polygon) vs float64 (marker)
    state, roi = head.states[last]
    assert state is TrackState.TRACKING and roi.iou(head.boxes[last]) > 0.8  # whole pixels
    # A malformed JPEG is dropped; the track survives it.
    bad = numpy_to_compressed(to_mono8(scene(40, 40)), header(time.time()), "jpeg")
    bad.data = bad.data[:40]
    head.image.publish(bad)
    for _ in range(5):
        frame(k)
        k += 1
        probe.spin_until(lambda: False, PERIOD)
    last = max(s for s, b in head.boxes.items() if b is not None)
    assert head.boxes[last].iou(head.truth[last]) >= 0.5 and proc.poll() is None
    # Requests that cannot be served are answered at once with their reason; the track is kept.
    stale = SelectTarget.Request(header=header(sent[-1][0] - 10.0), box=RegionOfInterest(
        x_offset=40, y_offset=40, width=TW, height=TW))
    accepted, code, reason, _, _ = probe.call(head, stale)
    assert not accepted and code == "STAMP_TOO_OLD" and "history_max_age_s" in reason
    outside = SelectTarget.Request(header=header(sent[-1][0]), box=RegionOfInterest(
        x_offset=W + 50, y_offset=10, width=TW, height=TW))
    accepted, code, reason, _, _ = probe.call(head, outside)
    assert not accepted and code == "OUTSIDE_IMAGE" and f"{W}x{H}" in reason
    tiny = SelectTarget.Request(header=header(sent[-1][0]), box=RegionOfInterest(
        x_offset=40, y_offset=40, width=2, height=30))
    accepted, code, reason, _, _ = probe.call(head, tiny)
    assert not accepted and code == "TOO_SMALL"
    # An accepted request on a frame 300 ms old answers after catching up, with the box it started from.
    frame(k)
    k += 1
    probe.spin_until(lambda: False, PERIOD)
    old = next(s for s in reversed(sent) if s[0] <= sent[-1][0] - 0.3 + 1e-6)
    b = truth(old[1], old[2])
    good = SelectTarget.Request(header=header(old[0]), box=RegionOfInterest(
        x_offset=round(b.x), y_offset=round(b.y), width=TW, height=TW))
    accepted, code, reason, start_stamp, start = probe.call(head, good)
    assert accepted and code == "ACCEPTED", reason
    assert start_stamp == pytest.approx(old[0], abs=1e-6) and start == Box(round(b.x), round(b.y), TW, TW)
    assert proc.poll() is None


def test_rqt_image_view_click_selects_on_the_newest_frame(processes: ProcessSet, probe: Probe) -> None:
    """rqt_image_view publishes an unstamped geometry_msgs/Point on `<image topic>_mouse_left` (the
    default `click_msg`); it selects on the newest frame."""
    head = probe.add("/rqt", click=Point)
    proc = start_head(processes, probe, "/rqt")
    t = time.time()
    for k in range(8):
        t = max(t + 0.04, time.time())
        head.publish(100.0, 90.0, round(t, 6), seed=k)
        probe.spin_until(lambda: False, PERIOD)
    head.click.publish(Point(x=100.0, y=90.0))
    probe.spin_until(lambda: False, 0.3)
    for k in range(8, 16):
        t = max(t + 0.04, time.time())
        head.publish(100.0, 90.0, round(t, 6), seed=k)
        probe.spin_until(lambda: False, PERIOD)
    assert probe.spin_until(lambda: any(b is not None for b in head.boxes.values()), 3.0), processes.log(proc)
    last = max(s for s, b in head.boxes.items() if b is not None)
    assert head.boxes[last].iou(truth(100.0, 90.0)) >= 0.5
