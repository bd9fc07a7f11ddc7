# SPDX-License-Identifier: Apache-2.0
"""`scene_camera`: a simulated SWIR camera on the pan-tilt head, rendering the synthetic world at its pose."""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from msg_adapters import diagnostics
from msg_adapters.camera_info import Intrinsics, camera_info_from_intrinsics
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_to_polygon, pixel_header
from msg_adapters.ground_truth import ground_truth_state_msg, scene_start_reply
from msg_adapters.image import numpy_to_image
from msg_adapters.joint_state import joint_state_to_sample
from msg_adapters.qos import profile
from msg_adapters.stamps import header as make_header
from swir_tracker_ros import topics
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.nodes.graph import input_publishers
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node
from swir_tracker_ros.paramfield import param, validate_params
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_scene import SceneClock, build_scene, scene_names
from swir_tracker_ros.scene.world import Truth

STATUS_NAME = "swir_tracker/scene_camera"


@dataclass
class SceneCameraParams:
    """Parameters of the `scene_camera` node (params/scene_camera.yaml)."""

    scene: str = param(
        "demo", "world to render: 'demo' (the closed-loop demo scene) or a harness scenario name")
    seed: int = param(7, "scene seed (same seed, same scene)", 0, 2**31 - 1)
    width: int = param(576, "image width, pixels", 16, 4096)
    height: int = param(504, "image height, pixels", 16, 4096)
    fps: float = param(25.0, "frame rate, Hz", 1.0, 200.0)
    hfov_deg: float = param(8.0, "horizontal field of view, degrees (square pixels)", 0.5, 120.0)
    bits: int = param(16, "sensor bit depth; 8 publishes mono8, else mono16", choices=(8, 10, 12, 14, 16))
    autostart: bool = param(
        True, "start the scene clock with the first frame; false: hold t = 0 until /scene/start is called")
    duration_s: float = param(
        0.0, "scene length, s; the clock holds at the end (0: the scene's own length)", 0.0, 3600.0)
    target_id: int = param(1, "identity of the pedestrian on /ground_truth/*", 0, 1_000_000)
    frame_id: str = param("camera_optical_frame", "header frame_id of the outputs")
    initial_pan_deg: float = param(0.0, "pan used until the first joint state, deg", -360.0, 360.0)
    initial_tilt_deg: float = param(0.0, "tilt used until the first joint state, deg", -90.0, 90.0)
    extrapolate_s: float = param(
        0.3, "extrapolate the last joint state (from its header stamp) with its velocity up to this age, s "
        "(0: hold)", 0.0, 2.0)

    def validate(self) -> SceneCameraParams:
        """Raise `ParameterError` naming the first bad field (`paramfield.validate_params`); returns self."""
        validate_params(self)
        return self

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.scene not in scene_names():
            raise ParameterError(f"parameter scene = {self.scene!r} is not one of {scene_names()}")
        if self.width % 2 or self.height % 2:
            raise ParameterError(f"width x height must be even, got {self.width}x{self.height}")


PARAMS_FILE = ParamsFile(
    "params/scene_camera.yaml", "/**", (("", SceneCameraParams, ""),),
    "Parameters of the `scene_camera` node (docs/demo.md), a simulated SWIR camera on the pan-tilt head, "
    "every one at its default. " + GENERATED + " swir_tracker_ros/simulation/scene_camera_node.py, not "
    "this file. Use: ros2 run swir_tracker_ros scene_camera --ros-args --params-file "
    "params/scene_camera.yaml")


def ground_truth_values(scene_time: float, truth: Truth | None, view: CameraView,
                        running: bool) -> dict[str, float]:
    """One frame's /ground_truth/state values (`msg_adapters.ground_truth.GT_KEYS`).

    pan_error / tilt_error are the exact angles of the target's centre from the optical axis in the
    convention of /track/pan_tilt_error (azimuth - pan, elevation - tilt; NaN when the target is not
    in the scene), head_pan / head_tilt the pose this frame was rendered at (rad).
    """
    in_view = truth is not None and truth.in_view
    return {
        "scene_time": scene_time,
        "in_view": 1.0 if in_view else 0.0,
        "visible": truth.visible_fraction if in_view else 0.0,
        "occlusion": truth.occlusion if in_view else 0.0,
        "occluded": 1.0 if in_view and truth.occluded else 0.0,
        "pan_error": truth.azimuth - view.pan if truth is not None else math.nan,
        "tilt_error": truth.elevation - view.tilt if truth is not None else math.nan,
        "head_pan": view.pan,
        "head_tilt": view.tilt,
        "running": 1.0 if running else 0.0,
    }


def camera_info_msg(view: CameraView, header: Header) -> CameraInfo:
    """CameraInfo of the ideal pinhole view: K from the FOV, zero distortion, P = [K | 0]."""
    intr = Intrinsics(view.fx, view.fy, view.cx, view.cy, view.width, view.height)
    return camera_info_from_intrinsics(intr, header)


class SceneCameraNode(Node):
    """Renders one frame per timer tick at the latest (extrapolated) head pose and publishes it."""

    def __init__(self) -> None:
        super().__init__("scene_camera")
        self.p = bind_parameters(self, SceneCameraParams)
        p = self.p
        self.scene = build_scene(p.scene, p.seed, bits=p.bits, fps=p.fps)
        duration = p.duration_s or self.scene.duration_s
        self.clock = SceneClock(duration, started_at=None)
        self.pose = (math.radians(p.initial_pan_deg), math.radians(p.initial_tilt_deg), 0.0, 0.0, -math.inf)
        self.frames = 0
        # Reliable, shallow: sensor-data (best-effort) subscribers such as the tracker match it and get the
        # newest frame; a reliable recorder gets every frame, lost fragments of the large image re-sent.
        camera, reliable = profile(topics.CAMERA), profile(topics.RELIABLE)
        self.image_pub = self.create_publisher(Image, topics.IMAGE, camera)
        self.info_pub = self.create_publisher(CameraInfo, topics.CAMERA_INFO, camera)
        self.gt_pub = self.create_publisher(PolygonStamped, topics.GROUND_TRUTH_BOX, reliable)
        self.gt_state_pub = self.create_publisher(DiagnosticArray, topics.GROUND_TRUTH_STATE, reliable)
        self.create_subscription(JointState, topics.JOINT_STATES, self._on_joints, reliable)
        self.diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, reliable)
        self.create_service(Trigger, topics.SCENE_START, self._on_start)
        self.timer = self.create_timer(1.0 / p.fps, self._tick)
        self.create_timer(1.0, self._publish_diagnostics)
        self.get_logger().info(
            f"scene {p.scene!r} seed {p.seed}: {p.width}x{p.height} {p.bits}-bit at {p.fps:g} Hz, "
            f"hfov {p.hfov_deg:g} deg, {duration:g} s, "
            f"{'autostart' if p.autostart else 'waits for /scene/start'}")

    def _on_joints(self, msg: JointState) -> None:
        try:
            s = joint_state_to_sample(msg)
        except MessageError as exc:
            self.get_logger().warning(f"{topics.JOINT_STATES}: {exc}", throttle_duration_sec=5.0)
            return
        now = time.time()
        measured = s.stamp if 0.0 < s.stamp <= now else now  # the bridge stamps the measurement time
        self.pose = (s.pan, s.tilt, s.pan_velocity, s.tilt_velocity, measured)

    def _publish_diagnostics(self) -> None:
        """1 Hz health: frames so far, scene clock, whether head poses arrive (else: last pose held)."""
        if not self.context.ok():
            return
        now = time.time()
        age = now - self.pose[4]
        values = {"frames": self.frames, "scene_time": self.clock.time(now), "running": self.clock.running,
                  "head_pose_age_s": age if math.isfinite(age) else "never",
                  **input_publishers(self, (topics.JOINT_STATES,))}
        if math.isfinite(age) and age <= 1.0:
            level, text = diagnostics.OK, "rendering at the head pose"
        else:
            level, text = diagnostics.WARN, f"no {topics.JOINT_STATES} for 1 s: last known pose held"
        st = diagnostics.status(STATUS_NAME, level, text, values, hardware_id="scene_camera")
        self.diag_pub.publish(diagnostics.diagnostic_array(make_header(now, self.p.frame_id), [st]))

    def _on_start(self, _req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
        started = self.clock.start(time.time())
        self.get_logger().info(f"scene clock started at {started:.6f}")
        return scene_start_reply(resp, started)

    def head_view(self, now: float) -> CameraView:
        """The view at `now`: the last joint state moved on by its velocity for at most extrapolate_s.

        The real camera sees the head where it is now; joint states arrive late (query rate, line time),
        so the measured pose is carried forward from its stamp with the measured velocity.
        """
        pan, tilt, v_pan, v_tilt, at = self.pose
        age = min(max(now - at, 0.0), self.p.extrapolate_s) if math.isfinite(at) else 0.0
        return CameraView(pan + v_pan * age, tilt + v_tilt * age, self.p.hfov_deg, self.p.width,
                          self.p.height)

    def _tick(self) -> None:
        if not self.context.ok():
            return  # shutting down (SIGINT): publishing would fail on the invalid context
        now = time.time()
        if self.p.autostart and not self.clock.running:
            self.clock.start(now)
        t = self.clock.time(now)
        view = self.head_view(now)
        frame, truths = self.scene.world.render(t, view)
        target = next((tr for tr in truths if tr.id == self.p.target_id), None)
        hdr = make_header(now, self.p.frame_id)
        self.image_pub.publish(numpy_to_image(frame, hdr, "mono8" if self.p.bits == 8 else "mono16"))
        self.info_pub.publish(camera_info_msg(view, hdr))
        in_view = target is not None and target.in_view
        self.gt_pub.publish(box_to_polygon(target.box if in_view else None, pixel_header(hdr)))
        self.gt_state_pub.publish(ground_truth_state_msg(
            hdr, ground_truth_values(t, target, view, self.clock.running), hardware_id="scene_camera"))
        self.frames += 1


def main(args: list[str] | None = None) -> int:
    return run_node("scene_camera", SceneCameraNode, args)


if __name__ == "__main__":
    sys.exit(main())
