# SPDX-License-Identifier: Apache-2.0
"""The tracker node's view of the camera and the head: intrinsics (CameraInfo, or the field-of-view fallback)
and the head's pose history from the joint states, with what the node derives from them (the ego-motion
shift between frames, the head's rate). Split from tracker_node.py along this seam (issue 37): the node
decodes frames and calls the core; this class answers "what did the optics and the head do at stamp t".
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, JointState

from msg_adapters.camera_info import Intrinsics, intrinsics_from_camera_info, intrinsics_from_fov
from msg_adapters.errors import MessageError
from msg_adapters.geometry import ego_shift
from msg_adapters.joint_state import joint_state_to_pan_tilt
from msg_adapters.qos import profile
from msg_adapters.rate import head_rate
from swir_tracker_ros import topics
from swir_tracker_ros.nodes.tracker_node_params import HeadPoseHistory, TrackerNodeParams


class HeadInputs:
    """camera_info and joint-state subscriptions of the tracker node and the geometry built on them."""

    def __init__(self, node: Node, params: TrackerNodeParams, guard: Callable,
                 warn: Callable[[str, str], None]) -> None:
        self.params = params
        self._warn = warn
        self.poses = HeadPoseHistory()
        self.camera_intr: Intrinsics | None = None
        self.prev_pose: tuple[float, float] | None = None
        sensor = profile(topics.SENSOR)
        node.create_subscription(CameraInfo, params.camera_info_topic, guard(self.on_camera_info), sensor)
        node.create_subscription(JointState, params.joint_states_topic, guard(self.on_joint_state), sensor)

    def on_camera_info(self, msg: CameraInfo) -> None:
        try:
            self.camera_intr = intrinsics_from_camera_info(msg)
        except MessageError as exc:
            self._warn("camera_info", f"ignoring CameraInfo, using the FOV fallback: {exc}")

    def on_joint_state(self, msg: JointState) -> None:
        try:
            pan, tilt, stamp = joint_state_to_pan_tilt(msg)
        except MessageError as exc:
            self._warn("joint_state", f"ignoring a joint state: {exc}")
            return
        self.poses.add(stamp, pan, tilt)

    @property
    def source(self) -> str:
        """Where the intrinsics come from: `camera_info` or `fov` (the diagnostics' `intrinsics`)."""
        return "camera_info" if self.params.use_camera_info and self.camera_intr is not None else "fov"

    def intrinsics(self, width: int, height: int) -> Intrinsics:
        if self.params.use_camera_info and self.camera_intr is not None:
            return self.camera_intr.scaled_to(width, height)
        return intrinsics_from_fov(width, height, self.params.fov_h_deg, self.params.fov_v_deg)

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
