# SPDX-License-Identifier: Apache-2.0
"""The tracker node's view of the camera and the head: intrinsics (CameraInfo, or the field-of-view fallback)
and the head's pose history from the joint states, with what the node derives from them (the ego-motion
shift between frames, the head's rate).

CameraInfo is read beside the image by default (image_transport's sibling convention,
`topics.camera_info_topic`); when none arrives within `camera_info_timeout_s` of the first frame the node says
so (throttled warning, /diagnostics) instead of silently using the field-of-view fallback. The focal length
follows the head's zoom joint through the `zoom_focal_scale` table; the CameraInfo's distortion D travels with
the intrinsics and `msg_adapters.geometry.pan_tilt_error` undoes it. Split from tracker_node.py along this
seam (issue 37): the node decodes frames and calls the core; this class answers "what did the optics and the
head do at stamp t".
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, JointState

from msg_adapters.camera_info import Intrinsics, intrinsics_from_camera_info, intrinsics_from_fov
from msg_adapters.errors import MessageError
from msg_adapters.geometry import ego_shift
from msg_adapters.joint_state import joint_position, joint_state_to_pan_tilt
from msg_adapters.qos import profile
from msg_adapters.rate import head_rate
from swir_tracker_ros import topics
from swir_tracker_ros.nodes.tracker_node_params import HeadPoseHistory, TrackerNodeParams


class HeadInputs:
    """camera_info and joint-state subscriptions of the tracker node and the geometry built on them."""

    def __init__(self, node: Node, params: TrackerNodeParams, guard: Callable,
                 warn: Callable[[str, str], None]) -> None:
        self.params = params
        self.node = node
        self._warn = warn
        self.poses = HeadPoseHistory()
        self.camera_intr: Intrinsics | None = None
        self.prev_pose: tuple[float, float] | None = None
        self.ignored_joint_states = 0  # joint states without the named joints (/diagnostics)
        self.zoom: float | None = None  # the zoom joint's latest position (0 wide .. 1 tele)
        self._first_frame: float | None = None  # monotonic time of the first frame asked about
        self.camera_info_topic = params.camera_info_topic or topics.camera_info_topic(params.image_topic)
        sensor = profile(topics.SENSOR)
        node.create_subscription(CameraInfo, self.camera_info_topic, guard(self.on_camera_info), sensor)
        node.create_subscription(JointState, params.joint_states_topic, guard(self.on_joint_state), sensor)

    def on_camera_info(self, msg: CameraInfo) -> None:
        try:
            self.camera_intr = intrinsics_from_camera_info(msg)
        except MessageError as exc:
            self._warn("camera_info", f"ignoring CameraInfo, using the FOV fallback: {exc}")

    def on_joint_state(self, msg: JointState) -> None:
        p = self.params
        try:
            pan, tilt, stamp = joint_state_to_pan_tilt(msg, p.pan_joint, p.tilt_joint)
        except MessageError as exc:  # never silent: counted on /diagnostics and warned about (throttled)
            self.ignored_joint_states += 1
            self._warn("joint_state", f"ignoring a joint state on {p.joint_states_topic}: {exc} (parameters "
                       f"pan_joint={p.pan_joint!r}, tilt_joint={p.tilt_joint!r}); without the head's pose "
                       "ego-motion compensation and the head-rate term are off")
            return
        self.poses.add(stamp, pan, tilt)
        zoom = joint_position(msg, p.zoom_joint)
        if zoom is not None:
            self.zoom = zoom

    @property
    def source(self) -> str:
        """Where the intrinsics come from: `camera_info` or `fov` (the diagnostics' `intrinsics`)."""
        return "camera_info" if self.params.use_camera_info and self.camera_intr is not None else "fov"

    @property
    def camera_info_missing(self) -> bool:
        """CameraInfo is wanted and none has arrived `camera_info_timeout_s` after the first frame."""
        p = self.params
        return (p.use_camera_info and self.camera_intr is None and self._first_frame is not None
                and time.monotonic() - self._first_frame > p.camera_info_timeout_s)

    def focal_scale(self) -> float:
        """The `zoom_focal_scale` table at the zoom joint's position: linear between the pairs, held beyond
        the ends; 1 without a table or before the zoom is known."""
        table = self.params.zoom_focal_scale
        if not table or self.zoom is None:
            return 1.0
        return float(np.interp(self.zoom, table[0::2], table[1::2]))

    def report(self) -> dict[str, object]:
        """The inputs' values on /diagnostics."""
        return {"intrinsics": self.source, "camera_info_topic": self.node.resolve_topic_name(
                    self.camera_info_topic), "camera_info_missing": self.camera_info_missing,
                "zoom": "unknown" if self.zoom is None else self.zoom, "focal_scale": self.focal_scale(),
                "joint_states_ignored": self.ignored_joint_states}

    def intrinsics(self, width: int, height: int) -> Intrinsics:
        """The intrinsics of a width x height frame: CameraInfo (or the FOV fallback) at the head's zoom."""
        p = self.params
        if self._first_frame is None:
            self._first_frame = time.monotonic()
        if self.camera_info_missing:
            topic = self.node.resolve_topic_name(self.camera_info_topic)
            self._warn("no_camera_info", f"no CameraInfo on {topic} after {p.camera_info_timeout_s:g} s: "
                       f"the error uses the field-of-view fallback (fov_h_deg={p.fov_h_deg:g}); set "
                       "camera_info_topic, or use_camera_info false")
        if p.use_camera_info and self.camera_intr is not None:
            base = self.camera_intr.scaled_to(width, height)
        else:
            base = intrinsics_from_fov(width, height, p.fov_h_deg, p.fov_v_deg)
        return base.zoomed(self.focal_scale())

    def ego_shift(self, stamp: float, intr: Intrinsics) -> tuple[float, float]:
        """Image shift caused by the head since the previous frame (head pose interpolated at the stamp)."""
        pose = self.poses.at(stamp)
        prev, self.prev_pose = self.prev_pose, pose
        if not self.params.ego_motion_compensation or pose is None or prev is None:
            return (0.0, 0.0)
        return ego_shift(pose[0] - prev[0], pose[1] - prev[1], intr)

    def shift_between(self, t0: float, t1: float, width: int, height: int) -> tuple[float, float]:
        """Image shift caused by the head between two frame stamps (poses known now, at catch-up time)."""
        p0, p1 = self.poses.at(t0), self.poses.at(t1)
        if not self.params.ego_motion_compensation or p0 is None or p1 is None:
            return (0.0, 0.0)
        return ego_shift(p1[0] - p0[0], p1[1] - p0[1], self.intrinsics(width, height))

    def head_motion(self, stamp: float, period: float) -> tuple[float, tuple[float, float]] | None:
        """(the camera's median frame period, the head's joint rates) for `track/target_rate` at a frame's
        stamp: the head's rate from the joint states only without ego-motion compensation (with it the
        core's velocity is the target's own); None until the period (and the poses) are known."""
        if period <= 0.0:
            return None
        if self.params.ego_motion_compensation:
            return period, (0.0, 0.0)
        head = head_rate(self.poses.at, stamp, period)
        return None if head is None else (period, head)
