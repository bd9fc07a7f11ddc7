# SPDX-License-Identifier: Apache-2.0
"""The tracker node's outputs: one publisher per topic and what one frame publishes on each.

Every output of a frame carries that image's stamp; `track/box` a pixel frame_id (`msg_adapters.geometry.
pixel_frame_id`), `track/detections` (vision_msgs) and the image markers the image's header (the image plane
of that camera), the angles (`track/pan_tilt_error`, `track/target_rate`) the head's `angles_frame_id`. A new
per-frame output is one more publisher here and one more line in `publish`.
"""

from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import Header
from vision_msgs.msg import Detection2DArray
from visualization_msgs.msg import ImageMarker

from msg_adapters.camera_info import Intrinsics
from msg_adapters.debug_image import render_debug, render_debug_compressed
from msg_adapters.detections import track_detections
from msg_adapters.geometry import box_to_polygon, pan_tilt_error, pan_tilt_to_msg, pixel_header
from msg_adapters.image_marker import track_markers
from msg_adapters.qos import profile
from msg_adapters.rate import target_rate
from msg_adapters.track_state import track_result_to_msg, typed_state_msg
from swir_tracker_interfaces.msg import TrackState as TrackStateMsg
from swir_tracker_ros import topics
from swir_tracker_ros.types import Box, TrackResult, TrackState

ACTIVE = (TrackState.TRACKING, TrackState.OCCLUDED)
IDLE_RESULT = TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE)


class TrackOutputs:
    """Publishers of `track/*` and the per-frame publishing; counts frames since the target was tracked."""

    def __init__(self, node: Node) -> None:
        self.node = node
        output, debug = profile(topics.RELIABLE), profile(topics.DEBUG_IMAGE)
        self.box = node.create_publisher(PolygonStamped, topics.TRACK_BOX, output)
        self.error = node.create_publisher(Vector3Stamped, topics.PAN_TILT_ERROR, output)
        self.rate = node.create_publisher(Vector3Stamped, topics.TARGET_RATE, output)
        self.state = node.create_publisher(DiagnosticArray, topics.TRACK_STATE, output)
        self.typed = node.create_publisher(TrackStateMsg, topics.TRACK_STATE_TYPED, output)
        self.image_markers = node.create_publisher(ImageMarker, topics.TRACK_MARKERS, output)
        self.detections = node.create_publisher(Detection2DArray, topics.TRACK_DETECTIONS, output)
        self.debug = node.create_publisher(Image, topics.TRACK_DEBUG_IMAGE, debug)
        self.debug_compressed = node.create_publisher(
            CompressedImage, topics.transport_topic(topics.TRACK_DEBUG_IMAGE, "compressed"), debug)
        self.frames_occluded = 0
        self.tracks = 0  # targets tracked so far: a track's id on track/detections, new at each start
        self._was_active = False

    def publish(self, header: Header, result: TrackResult | None, intr: Intrinsics,
                motion: tuple[float, tuple[float, float]] | None = None) -> None:
        """A processed frame: box (empty polygon when absent), pan/tilt error while tracking or occluded and,
        with `motion` (the camera's frame period in s, the head's joint rates in rad/s, zero with ego-motion
        compensation), the target's angular rate with the error's layout and header; the state (both forms)
        and the image markers."""
        result = IDLE_RESULT if result is None else result
        active = result.state in ACTIVE and result.box.is_finite()
        self.box.publish(box_to_polygon(result.box if active else None, pixel_header(header)))
        if active and not self._was_active:
            self.tracks += 1
        self._was_active = active
        self.detections.publish(track_detections(result if active else None, header, str(self.tracks)))
        if active:
            aim = result.aim_box  # a network-led track's last accepted box while its verdict rejects `box`
            pan, tilt = pan_tilt_error(aim.cx, aim.cy, intr)
            angles = Header(stamp=header.stamp, frame_id=self.node.params.angles_frame_id)
            self.error.publish(pan_tilt_to_msg(pan, tilt, angles))
            if motion is not None:
                rate = target_rate(aim.cx, aim.cy, result.velocity, motion[0], intr, motion[1])
                self.rate.publish(pan_tilt_to_msg(*rate, angles))
        self.publish_state(header, result, intr.width, intr.height)
        for marker in track_markers(result, header):
            self.image_markers.publish(marker)

    def publish_state(self, header: Header, result: TrackResult, width: int, height: int) -> None:
        """`track/state` and `track/state_typed` alone (a frame answered without a measurement)."""
        if result.state is TrackState.TRACKING and result.measured:
            self.frames_occluded = 0
        elif result.state in ACTIVE:
            self.frames_occluded += 1
        else:
            self.frames_occluded = 0
        self.state.publish(track_result_to_msg(result, header))
        self.typed.publish(typed_state_msg(result, header, self.frames_occluded, width, height))

    def publish_debug(self, pixels: np.ndarray, result: TrackResult | None, header: Header,
                      quality: int) -> None:
        """The debug picture, raw and JPEG, each only while someone subscribes."""
        if self.debug.get_subscription_count() > 0:
            self.debug.publish(render_debug(pixels, result, header))
        if self.debug_compressed.get_subscription_count() > 0:
            self.debug_compressed.publish(render_debug_compressed(pixels, result, header, quality))
