# SPDX-License-Identifier: Apache-2.0
"""The installed `acquisition` executable over DDS: tracks a synthetic crowd and hands a selected ID off."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import pytest
from conftest import REPO, ProcessSet, SpinningProbe, ros_probe
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, RegionOfInterest
from std_msgs.msg import UInt32
from vision_msgs.msg import Detection2DArray
from visualization_msgs.msg import MarkerArray

from msg_adapters.acquisition import CANDIDATES_NS, tracks_from_markers
from msg_adapters.detections import detections_from_msg
from msg_adapters.geometry import box_from_roi
from msg_adapters.image import numpy_to_image
from msg_adapters.stamps import header, stamp_to_seconds
from swir_tracker_ros.scene import crowd

PARAMS = ["--ros-args", "--params-file", str(REPO / "params" / "acquisition.yaml")]


class Probe(SpinningProbe):
    def __init__(self, ctx: Context) -> None:
        self.node = Node("acquisition_probe", context=ctx)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.node)
        n = self.node
        self.image = n.create_publisher(Image, "/camera/image_raw", QoSProfile(depth=1,
                                        reliability=ReliabilityPolicy.BEST_EFFORT))
        self.select = n.create_publisher(UInt32, "/acquisition/select", 10)
        self.state = n.create_publisher(DiagnosticArray, "/track/state", 10)
        self.tracks: dict[float, MarkerArray] = {}
        self.candidates: list[MarkerArray] = []
        self.inits: list[RegionOfInterest] = []
        n.create_subscription(MarkerArray, "/acquisition/tracks", self._on_tracks, 10)
        n.create_subscription(MarkerArray, "/acquisition/candidates", self.candidates.append, 10)
        n.create_subscription(RegionOfInterest, "/track/init", self.inits.append, 10)
        self.detections: dict[tuple[str, float], Detection2DArray] = {}  # (topic, stamp) -> message
        for topic in ("/acquisition/detections", "/acquisition/track_detections"):
            n.create_subscription(Detection2DArray, topic, lambda m, t=topic: self.detections.__setitem__(
                (t, stamp_to_seconds(m.header.stamp)), m), 10)
        self.t = time.time()

    def _on_tracks(self, msg: MarkerArray) -> None:
        self.tracks[stamp_to_seconds(msg.markers[0].header.stamp)] = msg

    def frame(self, pixels) -> MarkerArray:
        self.t = max(self.t + 0.04, time.time())
        msg = numpy_to_image(pixels, header(round(self.t, 6), "swir"))
        stamp = stamp_to_seconds(msg.header.stamp)
        for _ in range(8):
            self.image.publish(msg)
            if self.spin_until(lambda: stamp in self.tracks, 2.0):
                return self.tracks[stamp]
        raise AssertionError(f"no /acquisition/tracks for frame {stamp}")


@pytest.fixture
def probe() -> Iterator[Probe]:
    with ros_probe(Probe) as p:
        yield p


def _lost() -> DiagnosticArray:
    st = DiagnosticStatus(name="swir_tracker/track", message="lost",
                          values=[KeyValue(key="state", value="lost")])
    return DiagnosticArray(status=[st])


def test_select_publishes_the_track_box_on_track_init(processes: ProcessSet, probe: Probe) -> None:
    proc = processes.start("acquisition", *PARAMS)
    ok = probe.spin_until(lambda: probe.image.get_subscription_count() > 0
                          and probe.select.get_subscription_count() > 0, 30.0)
    assert ok, processes.log(proc)
    # Walks in from the left: no ghost of a frame-0 pedestrian in the background model.
    scene = crowd.occlusion_scene(2, occluder=False, start_u=-30.0)
    tracks = []
    for k in range(40):
        tracks = tracks_from_markers(probe.frame(crowd.render(scene, k)[0]))
        if tracks and k > 25:
            break
    assert len(tracks) == 1, processes.log(proc)
    chosen = tracks[0]
    # vision_msgs (issue 39): the same frame's tracks as Detection2DArray (id the track ID, class the status),
    # and the detector's own boxes (class person) on acquisition/detections
    stamp = max(probe.tracks)
    key, det_key = ("/acquisition/track_detections", stamp), ("/acquisition/detections", stamp)
    assert probe.spin_until(lambda: key in probe.detections and det_key in probe.detections, 2.0)
    as_detections = detections_from_msg(probe.detections[key])
    assert [(d.id, d.class_id) for d in as_detections] == [(str(chosen.id), chosen.label)]
    assert np.allclose(as_detections[0].box.as_tuple(), chosen.box.as_tuple(), atol=1e-3)
    assert 0.0 < as_detections[0].score <= 1.0
    found = detections_from_msg(probe.detections[det_key])
    assert found and all(d.class_id == "person" for d in found)
    assert max(d.box.iou(chosen.box) for d in found) > 0.5
    probe.select.publish(UInt32(data=chosen.id))
    assert probe.spin_until(lambda: probe.inits, 5.0), processes.log(proc)
    roi = box_from_roi(probe.inits[0])
    assert roi.iou(chosen.box) > 0.8
    probe.select.publish(UInt32(data=chosen.id + 1000))  # unknown ID: warned about, nothing sent
    probe.state.publish(_lost())
    probe.spin_until(lambda: False, 0.3)
    k0 = k
    for k in range(k0 + 1, k0 + 4):
        probe.frame(crowd.render(scene, k)[0])
    assert probe.spin_until(lambda: probe.candidates, 5.0), processes.log(proc)
    offered = tracks_from_markers(probe.candidates[-1], CANDIDATES_NS)
    assert offered and offered[0].id == chosen.id
    assert len(probe.inits) == 1
    assert "no displayed track" in processes.log(proc)
