# SPDX-License-Identifier: Apache-2.0
"""The acquisition node: detect, associate (paper 004), publish tracks, hand a target off to /track/init."""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState, RegionOfInterest
from std_msgs.msg import UInt32
from vision_msgs.msg import Detection2DArray
from visualization_msgs.msg import MarkerArray

from msg_adapters.acquisition import (
    CANDIDATES_NS,
    TrackBox,
    render_tracks_debug,
    selected_id,
    tracks_to_markers,
)
from msg_adapters.camera_info import Intrinsics, intrinsics_from_camera_info, intrinsics_from_fov
from msg_adapters.compressed import compressed_to_numpy
from msg_adapters.detections import Detected, detections_msg
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_to_roi, ego_shift
from msg_adapters.image import image_to_numpy
from msg_adapters.joint_state import joint_state_to_pan_tilt
from msg_adapters.qos import profile
from msg_adapters.stamps import header_of
from msg_adapters.track_state import track_state_from_msg
from swir_tracker_ros import topics
from swir_tracker_ros.acquisition.descriptors import Appearance
from swir_tracker_ros.acquisition.handoff import AutoInitialiser, TrackView, lost_candidates, select
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker
from swir_tracker_ros.acquisition.params import AcquisitionParams
from swir_tracker_ros.errors import AcquisitionError, ParameterError
from swir_tracker_ros.nodes.graph import check_topic_names
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node
from swir_tracker_ros.types import Box, TrackState

NODE_NAME = "acquisition"
MOT_PREFIX = "mot."
PERSON = "person"  # the class of every detection: the detectors find pedestrians (docs/acquisition.md)


PARAMS_FILE = ParamsFile(
    "params/acquisition.yaml", "/**",
    (("", AcquisitionParams, ""),
     ("mot", MotParams, "association and life cycle (MotParams), declared as mot.<name>")),
    "Parameters of the acquisition node (`acquisition`, docs/acquisition.md), every one at its default. "
    + GENERATED + " swir_tracker_ros/acquisition/params.py and mot.py, not this file. Pixel values refer "
    "to full-resolution image pixels.")


class AcquisitionNode(Node):
    """Thin wrapper: decode, call the detector, the multi-target tracker and hand-off, publish."""

    def __init__(self, **node_kwargs) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        self.params = bind_parameters(self, AcquisitionParams, on_change=self._on_params,
                                      vet=AcquisitionParams.detector_problem)
        check_topic_names(self.params)
        self.mot_params = bind_parameters(self, MotParams, prefix=MOT_PREFIX, on_change=self._on_mot_params)
        self.detector = self.params.make_detector()
        self.mot = MultiTargetTracker(self.mot_params)
        self.auto = AutoInitialiser(self.params.auto_init())
        self.views: list[TrackView] = []
        self.tracker_state = TrackState.IDLE
        self.awaiting_tracker = False  # a box was sent: no automatic hand-off until the tracker reports
        self.target_id: int | None = None
        self.target_app: Appearance | None = None
        self.pose: tuple[float, float] | None = None
        self.prev_pose: tuple[float, float] | None = None
        output = profile(topics.RELIABLE)
        self.pub_tracks = self.create_publisher(MarkerArray, topics.ACQUISITION_TRACKS, output)
        self.pub_candidates = self.create_publisher(MarkerArray, topics.ACQUISITION_CANDIDATES, output)
        self.pub_init = self.create_publisher(RegionOfInterest, topics.TRACK_INIT, output)
        self.pub_debug = self.create_publisher(Image, topics.ACQUISITION_DEBUG_IMAGE, output)
        self.pub_detections = self.create_publisher(Detection2DArray, topics.ACQUISITION_DETECTIONS, output)
        self.pub_track_detections = self.create_publisher(
            Detection2DArray, topics.ACQUISITION_TRACK_DETECTIONS, output)
        self.size = (0, 0)
        self.frames = 0  # images received (detect_every counts them)
        raw = self.params.image_transport == "raw"
        self.create_subscription(Image if raw else CompressedImage,
                                 topics.transport_topic(self.params.image_topic, self.params.image_transport),
                                 self._guard(self._on_image), profile(topics.LATEST))
        self.camera_intr: Intrinsics | None = None
        self.create_subscription(CameraInfo, self.params.camera_info_topic or topics.camera_info_topic(
            self.params.image_topic), self._guard(self._on_camera_info), profile(topics.SENSOR))
        self.create_subscription(JointState, self.params.joint_states_topic, self._guard(self._on_joints),
                                 profile(topics.SENSOR))
        self.create_subscription(UInt32, topics.ACQUISITION_SELECT, self._guard(self._on_select), output)
        self.create_subscription(DiagnosticArray, topics.TRACK_STATE, self._guard(self._on_track_state),
                                 output)
        self.get_logger().info(f"acquisition on {self.params.image_topic}: detector {self.params.detector}, "
                               f"siamese {'on' if self.mot_params.use_siamese else 'off'}, "
                               f"auto hand-off {'on' if self.params.auto_handoff else 'off'}")

    def _guard(self, fn):
        def wrapped(msg) -> None:
            try:
                fn(msg)
            except (MessageError, AcquisitionError) as exc:
                self.get_logger().warning(f"{fn.__name__}: {exc}", throttle_duration_sec=5.0)
        return wrapped

    def _on_params(self, params: AcquisitionParams) -> None:
        self.params = params
        self.detector = params.make_detector()
        self.auto = AutoInitialiser(params.auto_init())

    def _on_mot_params(self, params: MotParams) -> None:
        self.mot_params = params
        self.mot = MultiTargetTracker(params, self.mot.siamese)

    def _on_joints(self, msg: JointState) -> None:
        pan, tilt, _ = joint_state_to_pan_tilt(msg, self.params.pan_joint, self.params.tilt_joint)
        self.pose = (pan, tilt)

    def _shift(self, width: int, height: int) -> tuple[float, float]:
        if not self.params.ego_motion_compensation or self.pose is None:
            return (0.0, 0.0)
        prev, self.prev_pose = self.prev_pose, self.pose
        if prev is None:
            return (0.0, 0.0)
        intr = self.camera_intr.scaled_to(width, height) if self.camera_intr is not None else \
            intrinsics_from_fov(width, height, self.params.fov_h_deg)
        return ego_shift(self.pose[0] - prev[0], self.pose[1] - prev[1], intr)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        self.camera_intr = intrinsics_from_camera_info(msg)

    def _on_image(self, msg: Image | CompressedImage) -> None:
        self.frames += 1
        if (self.frames - 1) % self.params.detect_every:
            return  # not a detection frame: the pose difference accumulates until the next one (_shift)
        frame = (image_to_numpy(msg) if isinstance(msg, Image) else compressed_to_numpy(msg)).pixels
        hdr = header_of(msg)
        height, width = frame.shape[:2]
        self.size = (width, height)
        shift = self._shift(width, height)
        dets = self.detector.detect(frame, shift)
        tracks = self.mot.step(frame, dets, shift)
        self.views = [TrackView(t.id, t.box, t.appearance) for t in tracks]
        if self.target_id is not None:
            for v in self.views:
                if v.id == self.target_id:
                    self.target_app = v.appearance
        boxes = [TrackBox(t.id, t.box, t.status.value) for t in tracks]
        self.pub_tracks.publish(tracks_to_markers(boxes, hdr))
        # vision_msgs (issue 39): the detector's boxes (class person, its score) and the tracks (class their
        # life-cycle status, score the fraction of frames they were detected in, id the track ID)
        self.pub_detections.publish(detections_msg([Detected(d.box, PERSON, d.score) for d in dets], hdr))
        self.pub_track_detections.publish(detections_msg(
            [Detected(t.box, t.status.value, t.hits / max(t.age, 1), str(t.id)) for t in tracks], hdr))
        candidates: list[TrackBox] = []
        if self.tracker_state is TrackState.LOST and self.target_app is not None:
            by_id = {v.id: v for v in self.views}
            ranked = lost_candidates(self.target_app, self.views, self.mot.weights, self.params.candidates)
            candidates = [TrackBox(i, by_id[i].box, str(r), d) for r, (i, d) in enumerate(ranked, 1)]
            self.pub_candidates.publish(tracks_to_markers(candidates, hdr, CANDIDATES_NS))
        if self.params.auto_handoff and not self.awaiting_tracker and self.tracker_state in (
                TrackState.IDLE, TrackState.LOST):
            box = self.auto.step([d.box for d in dets], shift)
            if box is not None:
                self._hand_off(self._track_at(box), box)
        if self.params.publish_debug and self.pub_debug.get_subscription_count() > 0:
            self.pub_debug.publish(render_tracks_debug(frame, boxes, hdr, candidates, self.target_id))

    def _track_at(self, box: Box) -> int | None:
        best = max(self.views, key=lambda v: v.box.iou(box), default=None)
        return best.id if best is not None and best.box.iou(box) > 0.3 else None

    def _hand_off(self, track_id: int | None, box: Box) -> None:
        width, height = self.size
        self.pub_init.publish(box_to_roi(box, width, height))
        self.target_id = track_id
        self.target_app = next((v.appearance for v in self.views if v.id == track_id), None)
        self.awaiting_tracker = True
        self.auto.reset()
        where = tuple(round(v, 1) for v in box.as_tuple())
        self.get_logger().info(f"hand-off of track {track_id} at {where}")

    def _on_select(self, msg: UInt32) -> None:
        track_id = selected_id(msg)
        box = select(self.views, track_id)
        if box is None:
            known = sorted(v.id for v in self.views)
            self.get_logger().warning(f"{topics.ACQUISITION_SELECT}: no displayed track {track_id}; "
                                      f"shown: {known}")
            return
        self._hand_off(track_id, box)

    def _on_track_state(self, msg: DiagnosticArray) -> None:
        state = track_state_from_msg(msg)
        if state is not self.tracker_state and state is TrackState.LOST:
            self.get_logger().info(f"tracker lost track {self.target_id}; offering candidates")
        if state in (TrackState.TRACKING, TrackState.OCCLUDED) or (
                state is TrackState.LOST and self.tracker_state is not TrackState.LOST):
            self.awaiting_tracker = False  # the tracker answered: automatic hand-off allowed again
        self.tracker_state = state


def main(argv: list[str] | None = None) -> int:
    """Console entry point `acquisition`: spin until SIGINT/SIGTERM; exit 2 on a bad parameter or model."""
    return run_node(NODE_NAME, AcquisitionNode, argv, startup_errors=(ParameterError, AcquisitionError))


if __name__ == "__main__":
    sys.exit(main())
